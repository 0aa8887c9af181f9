#include "host/serial_backend.h"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/write.hpp>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "proto/snp/decoder.h"

namespace yamor::host {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using ErrorCode = boost::system::error_code;

namespace {

constexpr std::string_view kTcpScheme = "tcp://";

struct BaudRate {
  int baud;
  speed_t speed;
};

constexpr BaudRate kBaudRates[] = {
    {50, B50},           {75, B75},           {110, B110},         {134, B134},
    {150, B150},         {200, B200},         {300, B300},         {600, B600},
    {1200, B1200},       {1800, B1800},       {2400, B2400},       {4800, B4800},
    {9600, B9600},       {19200, B19200},     {38400, B38400},     {57600, B57600},
    {115200, B115200},   {230400, B230400},   {460800, B460800},   {500000, B500000},
    {576000, B576000},   {921600, B921600},   {1000000, B1000000}, {1152000, B1152000},
    {1500000, B1500000}, {2000000, B2000000}, {2500000, B2500000}, {3000000, B3000000},
    {3500000, B3500000}, {4000000, B4000000},
};

std::optional<speed_t> SpeedOf(int baud) {
  for (const BaudRate& rate : kBaudRates) {
    if (rate.baud == baud) return rate.speed;
  }
  return std::nullopt;
}

bool IsTcp(const std::string& device) { return device.starts_with(kTcpScheme); }

struct TcpAddress {
  std::string host;
  std::string port;
};

// "tcp://HOST:PORT" or "tcp://[V6]:PORT"; INVALID_ARGUMENT naming the text.
TcpAddress ParseTcpAddress(const std::string& device) {
  const std::string rest = device.substr(kTcpScheme.size());
  const std::size_t colon = rest.rfind(':');
  auto bad = [&](const std::string& why) -> Error {
    return Error(StatusCode::kInvalidArgument,
                 "device '" + device + "' is not tcp://HOST:PORT: " + why);
  };
  if (colon == std::string::npos) throw bad("no port");
  TcpAddress address{rest.substr(0, colon), rest.substr(colon + 1)};
  if (address.host.size() >= 2 && address.host.front() == '[' && address.host.back() == ']') {
    address.host = address.host.substr(1, address.host.size() - 2);
  }
  if (address.host.empty()) throw bad("empty host");
  const bool digits = !address.port.empty() && address.port.size() <= 5 &&
                      std::all_of(address.port.begin(), address.port.end(),
                                  [](char c) { return c >= '0' && c <= '9'; });
  if (!digits || std::stoi(address.port) < 1 || std::stoi(address.port) > 65535) {
    throw bad("port '" + address.port + "' is not a number in 1..65535");
  }
  return address;
}

bool RefusedByPty(int error) { return error == ENOTTY || error == EINVAL; }

std::chrono::milliseconds Millis(double seconds) {
  return std::chrono::milliseconds(static_cast<int64_t>(std::ceil(seconds * 1000.0)));
}

}  // namespace

Parity ParseParity(std::string_view text) {
  if (text == "none") return Parity::kNone;
  if (text == "odd") return Parity::kOdd;
  if (text == "even") return Parity::kEven;
  throw Error(StatusCode::kInvalidArgument,
              "parity '" + std::string(text) + "' is not none, odd or even");
}

FlowControl ParseFlowControl(std::string_view text) {
  if (text == "none") return FlowControl::kNone;
  if (text == "software") return FlowControl::kSoftware;
  if (text == "hardware") return FlowControl::kHardware;
  throw Error(StatusCode::kInvalidArgument,
              "flow_control '" + std::string(text) + "' is not none, software or hardware");
}

std::string_view ParityName(Parity parity) {
  switch (parity) {
    case Parity::kNone: return "none";
    case Parity::kOdd: return "odd";
    case Parity::kEven: return "even";
  }
  return "none";
}

std::string_view FlowControlName(FlowControl flow) {
  switch (flow) {
    case FlowControl::kNone: return "none";
    case FlowControl::kSoftware: return "software";
    case FlowControl::kHardware: return "hardware";
  }
  return "none";
}

bool IsSupportedBaudRate(int baud) { return SpeedOf(baud).has_value(); }

void ValidateSerialOptions(const SerialOptions& o) {
  if (o.device.empty()) {
    throw Error(StatusCode::kInvalidArgument, "device is empty: give a path or tcp://HOST:PORT");
  }
  if (IsTcp(o.device)) ParseTcpAddress(o.device);
  if (!IsSupportedBaudRate(o.baud)) {
    throw Error(StatusCode::kOutOfRange, "baud " + std::to_string(o.baud) +
                                             " is not a supported line rate (50 .. 4000000, "
                                             "e.g. 9600, 57600, 115200, 921600)");
  }
  if (o.data_bits < 5 || o.data_bits > 8) {
    throw Error(StatusCode::kOutOfRange,
                "data_bits " + std::to_string(o.data_bits) + " is outside 5..8");
  }
  if (o.stop_bits != 1 && o.stop_bits != 2) {
    throw Error(StatusCode::kOutOfRange,
                "stop_bits " + std::to_string(o.stop_bits) + " is not 1 or 2");
  }
  auto check_time = [](std::string_view name, double value) {
    if (!std::isfinite(value) || value <= 0.0 || value > 600.0) {
      throw Error(StatusCode::kOutOfRange, std::string(name) + " " + FormatDouble(value) +
                                               " s is outside (0, 600]");
    }
  };
  check_time("hello_timeout", o.hello_timeout);
  check_time("connect_timeout", o.connect_timeout);
  check_time("write_timeout", o.write_timeout);
  if (o.max_inbox_frames == 0) {
    throw Error(StatusCode::kOutOfRange, "max_inbox_frames must be at least 1");
  }
}

// ---- Impl --------------------------------------------------------------------

// Everything except the members marked "guarded by mutex_" is touched only
// by the one caller of Send / Receive / Reopen (and the io_context handlers,
// which run inside those calls on the same thread).
class SerialBackend::Impl {
 public:
  explicit Impl(SerialOptions options)
      : options_(std::move(options)), tcp_(IsTcp(options_.device)) {
    ValidateSerialOptions(options_);
    Open();
  }

  ~Impl() { CloseStream(); }

  void Send(const snp::Frame& frame) {
    std::vector<uint8_t> bytes = snp::EncodeFrame(frame);  // INVALID_ARGUMENT if bad
    Poll();  // notice a peer that went away since the last call
    if (!connected_) {
      Log().info("{}: link lost ({}); reopening", Who(), lost_reason_);
      Open();
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.reconnects;
    }
    if (frame.destination.kind == snp::NodeKind::kBridge && !IsSimulation()) {
      // docs/snp.md: a backend without a simulation answers bridge commands
      // itself; a real robot would drop them and the caller would time out.
      inbox_.push_back(snp::MakeFrame(
          snp::Address::Bridge(), snp::Address::Host(),
          snp::SpecialError{.acked = frame.type,
                            .code = StatusCode::kUnimplemented,
                            .text = "manual assembly required: a real robot, no simulation"}));
      return;
    }
    Write(bytes);
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.frames_out;
  }

  std::optional<snp::Frame> Receive(std::chrono::milliseconds timeout) {
    const Clock::time_point deadline =
        Clock::now() + std::max(timeout, std::chrono::milliseconds(0));
    RunUntil([this] { return !inbox_.empty() || !connected_; }, deadline);
    if (!inbox_.empty()) {
      snp::Frame frame = std::move(inbox_.front());
      inbox_.pop_front();
      return frame;
    }
    if (!connected_) ThrowLost();
    return std::nullopt;
  }

  void Reopen() {
    CloseStream();
    connected_ = false;
    lost_reason_ = "closed for reopening";
    Open();
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.reconnects;
  }

  bool IsOpen() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return open_;
  }
  bool IsSimulation() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sim_info_.has_value();
  }
  std::optional<snp::SimInfo> sim_info() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sim_info_;
  }
  SerialStats stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
  }
  uint64_t Generation() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return 1 + stats_.reconnects;
  }
  std::string Name() const { return tcp_ ? "tcp" : "serial"; }
  // "serial /dev/ttyUSB0" or "tcp://host:port", for logs.
  std::string Who() const { return tcp_ ? options_.device : "serial " + options_.device; }
  const std::string& device() const { return options_.device; }

 private:
  // ---- Opening ----------------------------------------------------------------

  // Opens the stream, arms the reader and says hello. On failure the link
  // stays closed (connected_ false) and UNAVAILABLE is thrown.
  void Open() {
    CloseStream();
    Drain();
    if (tcp_) {
      OpenTcp();
    } else {
      OpenDevice();
    }
    decoder_.Reset();
    connected_ = true;
    lost_reason_.clear();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      open_ = true;
    }
    StartRead();
    try {
      Hello();
    } catch (...) {
      CloseStream();
      connected_ = false;
      throw;
    }
  }

  void OpenDevice() {
    const std::string& path = options_.device;
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
      throw Error(StatusCode::kUnavailable,
                  "cannot open serial device " + path + ": " + std::strerror(errno));
    }
    try {
      ConfigureTerminal(fd);
    } catch (...) {
      ::close(fd);
      throw;
    }
    ErrorCode ec;
    stream_.assign(fd, ec);
    if (ec) {
      ::close(fd);
      throw Error(StatusCode::kUnavailable,
                  "cannot use serial device " + path + ": " + ec.message());
    }
  }

  // Raw mode, line rate and framing; flow control separately, since a pty
  // may refuse modem-control bits (then logged at debug, not an error).
  void ConfigureTerminal(int fd) {
    const std::string& path = options_.device;
    termios t{};
    if (::tcgetattr(fd, &t) != 0) {
      if (RefusedByPty(errno)) {
        Log().debug("serial {}: not a terminal ({}); using it as a plain byte stream", path,
                    std::strerror(errno));
        return;
      }
      throw Error(StatusCode::kUnavailable,
                  "cannot read the line settings of " + path + ": " + std::strerror(errno));
    }
    ::cfmakeraw(&t);
    t.c_cflag |= CLOCAL | CREAD;
    t.c_cflag &= ~static_cast<tcflag_t>(CSIZE);
    static constexpr tcflag_t kSizes[] = {CS5, CS6, CS7, CS8};
    t.c_cflag |= kSizes[options_.data_bits - 5];
    t.c_cflag &= ~static_cast<tcflag_t>(PARENB | PARODD);
    if (options_.parity != Parity::kNone) t.c_cflag |= PARENB;
    if (options_.parity == Parity::kOdd) t.c_cflag |= PARODD;
    if (options_.stop_bits == 2) {
      t.c_cflag |= CSTOPB;
    } else {
      t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB);
    }
    t.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS);
    t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    const speed_t speed = *SpeedOf(options_.baud);
    ::cfsetispeed(&t, speed);
    ::cfsetospeed(&t, speed);
    if (::tcsetattr(fd, TCSANOW, &t) != 0) {
      if (!RefusedByPty(errno)) {
        throw Error(StatusCode::kUnavailable,
                    "cannot set raw mode and " + std::to_string(options_.baud) + " baud on " +
                        path + ": " + std::strerror(errno));
      }
      Log().debug("serial {}: line settings refused ({}); raw mode only", path,
                  std::strerror(errno));
      termios raw{};
      if (::tcgetattr(fd, &raw) == 0) {
        ::cfmakeraw(&raw);
        raw.c_cflag |= CLOCAL | CREAD;
        if (::tcsetattr(fd, TCSANOW, &raw) != 0) {
          throw Error(StatusCode::kUnavailable,
                      "cannot set raw mode on " + path + ": " + std::strerror(errno));
        }
      }
    }
    ReportIgnoredSettings(fd, t);
    if (options_.flow_control != FlowControl::kNone) {
      termios flow{};
      if (::tcgetattr(fd, &flow) == 0) {
        if (options_.flow_control == FlowControl::kHardware) {
          flow.c_cflag |= CRTSCTS;
        } else {
          flow.c_iflag |= IXON | IXOFF;
        }
        if (::tcsetattr(fd, TCSANOW, &flow) != 0) {
          if (!RefusedByPty(errno)) {
            throw Error(StatusCode::kUnavailable,
                        "cannot set " + std::string(FlowControlName(options_.flow_control)) +
                            " flow control on " + path + ": " + std::strerror(errno));
          }
          Log().debug("serial {}: {} flow control refused ({}); continuing without", path,
                      FlowControlName(options_.flow_control), std::strerror(errno));
        }
      }
    }
    // Bytes a previous user left in the input buffer are not ours.
    if (::tcflush(fd, TCIFLUSH) != 0) {
      Log().debug("serial {}: tcflush refused ({})", path, std::strerror(errno));
    }
  }

  // tcsetattr succeeds when any change was taken: read the settings back and
  // say which were not (a pty keeps CS8 without parity; debug there, since
  // the bytes are the same; a warning on a real line).
  void ReportIgnoredSettings(int fd, const termios& wanted) {
    termios got{};
    if (::tcgetattr(fd, &got) != 0) return;
    std::string ignored;
    auto note = [&](bool differs, std::string_view what) {
      if (!differs) return;
      if (!ignored.empty()) ignored += ", ";
      ignored += what;
    };
    note((got.c_cflag & CSIZE) != (wanted.c_cflag & CSIZE), "data bits");
    note((got.c_cflag & (PARENB | PARODD)) != (wanted.c_cflag & (PARENB | PARODD)), "parity");
    note((got.c_cflag & CSTOPB) != (wanted.c_cflag & CSTOPB), "stop bits");
    note(::cfgetospeed(&got) != ::cfgetospeed(&wanted), "baud rate");
    if (ignored.empty()) return;
    std::error_code ec;
    const bool pty =
        std::filesystem::weakly_canonical(options_.device, ec).string().starts_with("/dev/pts/");
    Log().log(pty ? spdlog::level::debug : spdlog::level::warn,
              "serial {}: the driver did not take the {} asked for", options_.device, ignored);
  }

  void OpenTcp() {
    const TcpAddress address = ParseTcpAddress(options_.device);
    ErrorCode ec;
    tcp::resolver resolver(io_);
    const tcp::resolver::results_type endpoints = resolver.resolve(address.host, address.port, ec);
    if (ec) {
      throw Error(StatusCode::kUnavailable,
                  "cannot resolve " + options_.device + ": " + ec.message());
    }
    auto state = std::make_shared<std::pair<bool, ErrorCode>>(false, ErrorCode());
    asio::async_connect(socket_, endpoints,
                        [state](const ErrorCode& error, const tcp::endpoint&) {
                          state->first = true;
                          state->second = error;
                        });
    RunUntil([&] { return state->first; }, Clock::now() + Millis(options_.connect_timeout));
    if (!state->first) {
      CloseStream();  // cancels the connect
      Drain();        // and lets it finish before the socket is reused
      throw Error(StatusCode::kUnavailable,
                  "cannot connect to " + options_.device + ": no answer within " +
                      FormatDouble(options_.connect_timeout) + " s");
    }
    if (state->second) {
      CloseStream();
      throw Error(StatusCode::kUnavailable,
                  "cannot connect to " + options_.device + ": " + state->second.message());
    }
    socket_.set_option(tcp::no_delay(true), ec);
  }

  // GetSimInfo to the bridge; SimInfo within hello_timeout = yamor-bridge.
  // Other frames arriving meanwhile stay in the inbox.
  void Hello() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      sim_info_.reset();
    }
    const std::vector<uint8_t> hello = snp::EncodeFrame(
        snp::MakeFrame(snp::Address::Host(), snp::Address::Bridge(), snp::GetSimInfo{}));
    // Armed before the write: the answer may be read while the write's
    // completion is still being processed.
    hello_pending_ = true;
    hello_answered_ = false;
    try {
      Write(hello);
    } catch (...) {
      hello_pending_ = false;
      throw;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.frames_out;
    }
    RunUntil([this] { return hello_answered_ || !connected_; },
             Clock::now() + Millis(options_.hello_timeout));
    hello_pending_ = false;
    if (!connected_) ThrowLost();
    const std::optional<snp::SimInfo> info = sim_info();
    if (info) {
      Log().info("{}: yamor-bridge answered the hello (time step {} s): a simulation", Who(),
                 info->time_step);
    } else {
      Log().info("{}: no answer to the hello within {} s: a real robot", Who(),
                 options_.hello_timeout);
    }
  }

  // ---- The io_context, run on the caller's thread --------------------------------

  // Runs handlers until `done()` or `deadline` (always processes ready ones).
  template <typename Done>
  void RunUntil(Done done, Clock::time_point deadline) {
    Poll();
    while (!done() && Clock::now() < deadline) {
      io_.restart();
      if (io_.run_one_until(deadline) == 0 && !done() && Clock::now() < deadline) {
        // Nothing outstanding at all (no reader armed): nothing can change.
        return;
      }
    }
  }

  void Poll() {
    io_.restart();
    io_.poll();
  }

  // Runs the completions of a closed stream's cancelled operations, so a
  // stale composed operation never sees the stream reopened. Never call from
  // inside a handler.
  void Drain() { Poll(); }

  void StartRead() {
    if (reading_ || !connected_) return;
    reading_ = true;
    const uint64_t generation = generation_;
    auto handler = [this, generation](const ErrorCode& ec, std::size_t n) {
      if (generation != generation_) return;  // a closed connection's read
      reading_ = false;
      if (n > 0) Consume(n);
      if (ec) {
        if (ec != asio::error::operation_aborted) Lost("read failed: " + ec.message());
        return;
      }
      StartRead();
    };
    if (tcp_) {
      socket_.async_read_some(asio::buffer(rx_), handler);
    } else {
      stream_.async_read_some(asio::buffer(rx_), handler);
    }
  }

  void Consume(std::size_t n) {
    events_.clear();
    decoder_.Feed(std::span<const uint8_t>(rx_.data(), n), events_);
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.bytes_in += n;
    HandleEventsLocked();
  }

  // Moves decoded frames to the inbox (or, during the hello, takes SimInfo).
  void HandleEventsLocked() {
    const snp::DecoderStats& d = decoder_.stats();
    stats_.skipped_bytes = skipped_before_ + d.skipped_bytes;
    stats_.decode_errors = errors_before_ + d.TotalErrors();
    for (snp::DecodeEvent& event : events_) {
      if (auto* decoded = std::get_if<snp::DecodedFrame>(&event)) {
        ++stats_.frames_in;
        if (hello_pending_ && !hello_answered_ && TakeHelloAnswerLocked(decoded->frame)) continue;
        if (inbox_.size() >= options_.max_inbox_frames) {
          inbox_.pop_front();
          ++stats_.dropped_frames;
          Log().warn("{}: inbox full ({} frames); dropped the oldest", Who(),
                     options_.max_inbox_frames);
        }
        inbox_.push_back(std::move(decoded->frame));
      } else {
        if (!Log().should_log(spdlog::level::trace)) continue;  // garbage can be megabytes
        const auto& error = std::get<snp::DecodeError>(event);
        Log().trace("{}: skipped a frame candidate at byte {}: {}", Who(), error.offset(),
                    error.reason());
      }
    }
  }

  // True when `frame` answers the hello (SimInfo, or SpecialError to GetSimInfo).
  bool TakeHelloAnswerLocked(const snp::Frame& frame) {
    if (frame.source.kind != snp::NodeKind::kBridge) return false;
    if (frame.type == snp::MessageType::kSimInfo) {
      try {
        sim_info_ = std::get<snp::SimInfo>(snp::DecodeMessage(frame));
        hello_answered_ = true;
        return true;
      } catch (const Error& e) {
        Log().warn("{}: malformed SimInfo ignored: {}", Who(), e.what());
        return false;
      }
    }
    if (frame.type == snp::MessageType::kSpecialError) {
      try {
        const auto error = std::get<snp::SpecialError>(snp::DecodeMessage(frame));
        if (error.acked != snp::MessageType::kGetSimInfo) return false;
        Log().info("{}: the peer refused the hello ({}): not a simulation", Who(), error.text);
        hello_answered_ = true;
        return true;
      } catch (const Error&) {
        return false;
      }
    }
    return false;
  }

  // Writes all of `bytes` within write_timeout; a failure or stall loses the link.
  void Write(const std::vector<uint8_t>& bytes) {
    if (!connected_) ThrowLost();
    struct WriteState {
      bool done = false;
      ErrorCode error;
      std::size_t written = 0;
    };
    auto state = std::make_shared<WriteState>();
    auto handler = [state](const ErrorCode& ec, std::size_t n) {
      state->done = true;
      state->error = ec;
      state->written = n;
    };
    if (tcp_) {
      asio::async_write(socket_, asio::buffer(bytes), handler);
    } else {
      asio::async_write(stream_, asio::buffer(bytes), handler);
    }
    RunUntil([&] { return state->done; }, Clock::now() + Millis(options_.write_timeout));
    if (!state->done) {
      Lost("write stalled: the peer did not read " + std::to_string(bytes.size()) +
           " bytes within " + FormatDouble(options_.write_timeout) + " s");
      // The aborted write completes at once; wait for it so `bytes` outlives it.
      while (!state->done) {
        io_.restart();
        if (io_.run_one() == 0) break;
      }
      ThrowLost();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.bytes_out += state->written;
    }
    if (state->error) {
      Lost("write failed: " + state->error.message());
      ThrowLost();
    }
  }

  // ---- Losing the link -----------------------------------------------------------

  void Lost(const std::string& reason) {
    if (!connected_) return;
    lost_reason_ = reason;
    Log().warn("{}: link lost: {}", Who(), reason);
    CloseStream();
  }

  [[noreturn]] void ThrowLost() const {
    throw Error(StatusCode::kUnavailable, (tcp_ ? "tcp link " : "serial link ") +
                                              options_.device + " is gone: " + lost_reason_);
  }

  // Closes the stream (cancelling its operations; the stream objects live
  // as long as the backend, so cancelled handlers never see a dead one) and
  // ends the decoder's stream, so a partial frame is counted as skipped.
  // Safe inside a handler.
  void CloseStream() {
    ++generation_;
    reading_ = false;
    connected_ = false;
    ErrorCode ignored;
    if (stream_.is_open()) stream_.close(ignored);
    if (socket_.is_open()) {
      socket_.shutdown(tcp::socket::shutdown_both, ignored);
      socket_.close(ignored);
    }
    events_.clear();
    decoder_.Flush(events_);
    std::lock_guard<std::mutex> lock(mutex_);
    HandleEventsLocked();
    skipped_before_ = stats_.skipped_bytes;
    errors_before_ = stats_.decode_errors;
    decoder_.Reset();
    open_ = false;
  }

  SerialOptions options_;
  const bool tcp_;
  asio::io_context io_;  // declared before the streams: destroyed after them
  asio::posix::stream_descriptor stream_{io_};  // the device (unused for TCP)
  tcp::socket socket_{io_};                     // the TCP connection (unused for devices)
  uint64_t generation_ = 0;     // bumped per closed stream; stale handlers return
  bool connected_ = false;      // open and not failed
  bool reading_ = false;        // a read is armed
  std::string lost_reason_;     // why the link went away
  bool hello_pending_ = false;  // a hello waits for its answer
  bool hello_answered_ = false;
  std::array<uint8_t, 4096> rx_{};
  snp::FrameDecoder decoder_;
  std::vector<snp::DecodeEvent> events_;
  std::deque<snp::Frame> inbox_;
  uint64_t skipped_before_ = 0;  // skipped bytes of earlier connections
  uint64_t errors_before_ = 0;   // decode errors of earlier connections

  mutable std::mutex mutex_;
  SerialStats stats_;                   // guarded by mutex_
  std::optional<snp::SimInfo> sim_info_;  // guarded by mutex_
  bool open_ = false;                   // guarded by mutex_
};

// ---- SerialBackend ---------------------------------------------------------------

SerialBackend::SerialBackend(SerialOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}

SerialBackend::~SerialBackend() = default;

void SerialBackend::Send(const snp::Frame& frame) { impl_->Send(frame); }

std::optional<snp::Frame> SerialBackend::Receive(std::chrono::milliseconds timeout) {
  return impl_->Receive(timeout);
}

bool SerialBackend::IsSimulation() const { return impl_->IsSimulation(); }

std::string SerialBackend::Name() const { return impl_->Name(); }

uint64_t SerialBackend::Generation() const { return impl_->Generation(); }

void SerialBackend::Reopen() { impl_->Reopen(); }

bool SerialBackend::IsOpen() const { return impl_->IsOpen(); }

const std::string& SerialBackend::device() const { return impl_->device(); }

std::optional<snp::SimInfo> SerialBackend::sim_info() const { return impl_->sim_info(); }

SerialStats SerialBackend::stats() const { return impl_->stats(); }

}  // namespace yamor::host
