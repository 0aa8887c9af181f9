#include "bridge/bridge_transport.h"

#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include "common/log.h"
#include "common/status.h"

namespace yamor::bridge {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using ErrorCode = boost::system::error_code;

void ParseTcpEndpoint(const std::string& text, TransportOptions& options) {
  std::string host = "127.0.0.1";
  std::string port_text = text;
  const std::size_t colon = text.rfind(':');
  if (colon != std::string::npos) {
    host = text.substr(0, colon);
    port_text = text.substr(colon + 1);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
      host = host.substr(1, host.size() - 2);
    }
    if (host.empty()) {
      throw Error(StatusCode::kInvalidArgument, "--tcp '" + text + "': empty host");
    }
  }
  int port = kDefaultBridgePort;
  if (!port_text.empty()) {
    if (port_text.size() > 5 ||
        !std::all_of(port_text.begin(), port_text.end(),
                     [](char c) { return c >= '0' && c <= '9'; }) ||
        (port = std::stoi(port_text)) > 65535) {
      throw Error(StatusCode::kInvalidArgument,
                  "--tcp '" + text + "': port '" + port_text + "' is not a number in 0..65535");
    }
  } else if (colon != std::string::npos) {
    throw Error(StatusCode::kInvalidArgument, "--tcp '" + text + "': empty port");
  }
  options.tcp_host = host;
  options.tcp_port = static_cast<uint16_t>(port);
}

class BridgeTransport::Impl {
 public:
  Impl(BridgeServer& server, TransportOptions options)
      : server_(server),
        options_(std::move(options)),
        pace_timer_(io_),
        free_run_timer_(io_),
        retry_timer_(io_),
        signals_(io_) {
    if (options_.baud <= 0) {
      throw Error(StatusCode::kInvalidArgument,
                  "baud rate must be positive, got " + std::to_string(options_.baud));
    }
    if (!std::isfinite(options_.real_time_factor) || options_.real_time_factor < 0.0) {
      throw Error(StatusCode::kInvalidArgument, "real-time factor must be finite and >= 0");
    }
    byte_seconds_ = 10.0 / options_.baud;  // 8N1: start + 8 data + stop bits
    if (options_.kind == TransportOptions::Kind::kPty) {
      OpenPty();
    } else {
      OpenTcp();
    }
  }

  ~Impl() {
    if (!link_made_.empty()) ::unlink(link_made_.c_str());
    if (slave_fd_ >= 0) ::close(slave_fd_);
  }

  std::string Endpoint() const {
    if (options_.kind == TransportOptions::Kind::kPty) return "pty " + slave_path_;
    const tcp::endpoint ep = acceptor_->local_endpoint();
    const std::string address = ep.address().to_string();
    return "tcp " + (ep.address().is_v6() ? "[" + address + "]" : address) + ":" +
           std::to_string(ep.port());
  }
  std::string SlavePath() const { return slave_path_; }
  uint16_t Port() const { return acceptor_ ? acceptor_->local_endpoint().port() : 0; }
  TransportStats stats() const { return stats_; }

  int Run(bool stop_on_signals) {
    int stopped_by = 0;
    if (stop_on_signals) {
      signals_.add(SIGTERM);
      signals_.add(SIGINT);
      signals_.async_wait([this, &stopped_by](const ErrorCode& ec, int number) {
        if (ec) return;
        stopped_by = number;
        io_.stop();
      });
    }
    if (pty_) {
      StartRead(*pty_, generation_);
    } else {
      StartAccept();
    }
    if (options_.real_time_factor > 0.0) {
      last_tick_ = Clock::now();
      ScheduleFreeRun();
    }
    io_.run();
    return stopped_by;
  }

  void Stop() { io_.stop(); }

 private:
  // ---- Set-up ---------------------------------------------------------------

  void OpenPty() {
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (master < 0) ThrowErrno("posix_openpt");
    pty_.emplace(io_, master);  // owns the descriptor from here on
    if (::grantpt(master) != 0) ThrowErrno("grantpt");
    if (::unlockpt(master) != 0) ThrowErrno("unlockpt");
    char name[256];
    if (::ptsname_r(master, name, sizeof name) != 0) ThrowErrno("ptsname_r");
    slave_path_ = name;
    // Our own slave descriptor: the line stays up (and keeps its raw
    // settings) while the host closes and reopens the device.
    slave_fd_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (slave_fd_ < 0) ThrowErrno(std::string("open ") + name);
    termios attributes{};
    if (::tcgetattr(slave_fd_, &attributes) != 0) ThrowErrno("tcgetattr");
    ::cfmakeraw(&attributes);
    attributes.c_cflag |= CLOCAL | CREAD;
    attributes.c_cc[VMIN] = 1;
    attributes.c_cc[VTIME] = 0;
    ::cfsetispeed(&attributes, B115200);
    ::cfsetospeed(&attributes, B115200);
    if (::tcsetattr(slave_fd_, TCSANOW, &attributes) != 0) ThrowErrno("tcsetattr");
    if (!options_.link.empty()) MakeLink();
  }

  void MakeLink() {
    struct stat st{};
    if (::lstat(options_.link.c_str(), &st) == 0) {
      if (!S_ISLNK(st.st_mode)) {
        throw Error(StatusCode::kInvalidArgument,
                    "--link " + options_.link + " exists and is not a symlink");
      }
      ::unlink(options_.link.c_str());  // a stale link, as socat replaces it
    }
    if (::symlink(slave_path_.c_str(), options_.link.c_str()) != 0) {
      ThrowErrno("symlink " + options_.link + " -> " + slave_path_);
    }
    link_made_ = options_.link;
  }

  void OpenTcp() {
    ErrorCode ec;
    const std::string host = options_.tcp_host == "localhost" ? "127.0.0.1" : options_.tcp_host;
    const asio::ip::address address = asio::ip::make_address(host, ec);
    if (ec) {
      throw Error(StatusCode::kInvalidArgument,
                  "--tcp host '" + options_.tcp_host + "' is not a numeric address");
    }
    const tcp::endpoint endpoint(address, options_.tcp_port);
    acceptor_.emplace(io_);
    const std::string where = options_.tcp_host + ":" + std::to_string(options_.tcp_port);
    if (acceptor_->open(endpoint.protocol(), ec) ||
        acceptor_->set_option(tcp::acceptor::reuse_address(true), ec) ||
        acceptor_->bind(endpoint, ec) || acceptor_->listen(4, ec)) {
      throw Error(StatusCode::kUnavailable, "cannot listen on " + where + ": " + ec.message());
    }
    socket_.emplace(io_);
  }

  [[noreturn]] static void ThrowErrno(const std::string& what) {
    throw Error(StatusCode::kUnavailable, what + ": " + std::strerror(errno));
  }

  // ---- Reading ----------------------------------------------------------------

  template <typename Stream>
  void StartRead(Stream& stream, uint64_t generation) {
    stream.async_read_some(
        asio::buffer(rx_), [this, &stream, generation](const ErrorCode& ec, std::size_t n) {
          if (ec == asio::error::operation_aborted || generation != generation_) return;
          if (!ec) {
            stats_.bytes_in += n;
            scratch_.clear();
            server_.HandleBytes(std::span<const uint8_t>(rx_.data(), n), scratch_);
            Queue(scratch_);
            StartRead(stream, generation);
            return;
          }
          if (socket_) {
            Log().info("yamor-bridge: host disconnected ({})", ec.message());
            CloseConnection();
            return;
          }
          // A pty whose every slave descriptor closed reads EIO; ours stays
          // open, so this is unexpected: retry instead of spinning.
          Log().warn("yamor-bridge: pty read failed: {}; retrying", ec.message());
          retry_timer_.expires_after(std::chrono::milliseconds(100));
          retry_timer_.async_wait([this, &stream, generation](const ErrorCode& wait_ec) {
            if (!wait_ec) StartRead(stream, generation);
          });
        });
  }

  // ---- TCP connections --------------------------------------------------------

  void StartAccept() {
    acceptor_->async_accept(*socket_, [this](const ErrorCode& ec) {
      if (ec == asio::error::operation_aborted) return;
      if (ec) {
        Log().warn("yamor-bridge: accept failed: {}; retrying", ec.message());
        retry_timer_.expires_after(std::chrono::milliseconds(100));
        retry_timer_.async_wait([this](const ErrorCode& wait_ec) {
          if (!wait_ec) StartAccept();
        });
        return;
      }
      ++stats_.connections;
      connected_ = true;
      ErrorCode ignored;
      socket_->set_option(tcp::no_delay(true), ignored);
      const tcp::endpoint peer = socket_->remote_endpoint(ignored);
      Log().info("yamor-bridge: host connected from {}:{}", peer.address().to_string(),
                 peer.port());
      StartRead(*socket_, generation_);
    });
  }

  void CloseConnection() {
    ++generation_;  // stale read/write/pace handlers of this connection stop
    connected_ = false;
    ErrorCode ignored;
    socket_->shutdown(tcp::socket::shutdown_both, ignored);
    socket_->close(ignored);
    pending_.clear();
    writing_ = false;
    pace_timer_.cancel();
    server_.EndStream();
    StartAccept();
  }

  // ---- Writing, optionally paced -----------------------------------------------

  void Queue(const std::vector<uint8_t>& bytes) {
    if (bytes.empty()) return;
    if (socket_ && !connected_) {  // TCP with no host: nobody to hear it
      stats_.dropped_bytes += bytes.size();
      return;
    }
    const std::size_t room = options_.max_pending_bytes - std::min(options_.max_pending_bytes,
                                                                    pending_.size());
    const std::size_t take = std::min(room, bytes.size());
    if (take < bytes.size()) {
      stats_.dropped_bytes += bytes.size() - take;
      Log().warn("yamor-bridge: host is not reading; dropped {} outgoing bytes",
                 bytes.size() - take);
    }
    pending_.insert(pending_.end(), bytes.begin(), bytes.begin() + static_cast<long>(take));
    if (writing_ || pending_.empty()) return;
    if (options_.pace && Deadline(burst_bytes_) < Clock::now()) {
      // The line was idle: a new burst starts now (no credit for idle time).
      burst_start_ = Clock::now();
      burst_bytes_ = 0;
    }
    Pump();
  }

  // When byte `index` of the current burst may start on the line.
  Clock::time_point Deadline(uint64_t index) const {
    return burst_start_ + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double>(static_cast<double>(index) *
                                                            byte_seconds_));
  }

  void Pump() {
    if (pending_.empty()) {
      writing_ = false;
      return;
    }
    writing_ = true;
    std::size_t n = pending_.size();
    const uint64_t generation = generation_;
    if (options_.pace) {
      const Clock::time_point now = Clock::now();
      const Clock::time_point next = Deadline(burst_bytes_);
      if (next > now) {
        pace_timer_.expires_at(next);
        pace_timer_.async_wait([this, generation](const ErrorCode& ec) {
          if (ec || generation != generation_) return;
          Pump();
        });
        return;
      }
      // Every byte whose deadline has passed goes now (a late wake-up catches
      // up, so the average rate is exact).
      const double elapsed = std::chrono::duration<double>(now - burst_start_).count();
      const auto due_total = static_cast<uint64_t>(std::floor(elapsed / byte_seconds_)) + 1;
      const uint64_t due = due_total > burst_bytes_ ? due_total - burst_bytes_ : 1;
      n = static_cast<std::size_t>(std::min<uint64_t>(n, due));
    }
    write_buffer_.assign(pending_.begin(), pending_.begin() + static_cast<long>(n));
    auto done = [this, generation](const ErrorCode& ec, std::size_t written) {
      if (ec == asio::error::operation_aborted || generation != generation_) return;
      if (ec) {
        Log().warn("yamor-bridge: write failed: {}", ec.message());
        writing_ = false;
        if (socket_) {
          CloseConnection();
        } else {
          stats_.dropped_bytes += pending_.size();
          pending_.clear();
        }
        return;
      }
      pending_.erase(pending_.begin(), pending_.begin() + static_cast<long>(written));
      burst_bytes_ += written;
      stats_.bytes_out += written;
      Pump();
    };
    if (pty_) {
      asio::async_write(*pty_, asio::buffer(write_buffer_), done);
    } else {
      asio::async_write(*socket_, asio::buffer(write_buffer_), done);
    }
  }

  // ---- Free-running time ----------------------------------------------------------

  void ScheduleFreeRun() {
    free_run_timer_.expires_after(std::chrono::milliseconds(10));
    free_run_timer_.async_wait([this](const ErrorCode& ec) {
      if (ec) return;
      const Clock::time_point now = Clock::now();
      const double wall = std::chrono::duration<double>(now - last_tick_).count();
      last_tick_ = now;
      const double factor = options_.real_time_factor;
      const double dt = server_.TimeStep();
      // Owed simulated time; a slow machine catches up at most a quarter
      // second instead of stepping in ever longer bursts.
      debt_ = std::min(debt_ + wall * factor, 0.25 * factor + dt);
      scratch_.clear();
      const double advanced = server_.Advance(debt_, scratch_);
      debt_ -= advanced;
      if (advanced == 0.0 && debt_ >= dt) debt_ = 0.0;  // diverged world
      Queue(scratch_);
      ScheduleFreeRun();
    });
  }

  BridgeServer& server_;
  TransportOptions options_;
  asio::io_context io_;
  asio::steady_timer pace_timer_;
  asio::steady_timer free_run_timer_;
  asio::steady_timer retry_timer_;
  asio::signal_set signals_;

  // Pty.
  std::optional<asio::posix::stream_descriptor> pty_;
  int slave_fd_ = -1;
  std::string slave_path_;
  std::string link_made_;

  // TCP.
  std::optional<tcp::acceptor> acceptor_;
  std::optional<tcp::socket> socket_;
  bool connected_ = false;
  uint64_t generation_ = 0;  // bumped per closed connection

  std::array<uint8_t, 4096> rx_{};
  std::vector<uint8_t> scratch_;
  std::deque<uint8_t> pending_;
  std::vector<uint8_t> write_buffer_;
  bool writing_ = false;
  double byte_seconds_ = 0.0;
  Clock::time_point burst_start_{};
  uint64_t burst_bytes_ = 0;

  Clock::time_point last_tick_{};
  double debt_ = 0.0;
  TransportStats stats_;
};

BridgeTransport::BridgeTransport(BridgeServer& server, TransportOptions options)
    : impl_(std::make_unique<Impl>(server, std::move(options))) {}
BridgeTransport::~BridgeTransport() = default;
std::string BridgeTransport::Endpoint() const { return impl_->Endpoint(); }
std::string BridgeTransport::SlavePath() const { return impl_->SlavePath(); }
uint16_t BridgeTransport::Port() const { return impl_->Port(); }
int BridgeTransport::Run(bool stop_on_signals) { return impl_->Run(stop_on_signals); }
void BridgeTransport::Stop() { impl_->Stop(); }
TransportStats BridgeTransport::stats() const { return impl_->stats(); }

}  // namespace yamor::bridge
