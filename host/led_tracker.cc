#include "host/led_tracker.h"

#include <utility>  // before Asio: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <charconv>
#include <cmath>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include "common/log.h"
#include "common/status.h"

namespace yamor::host {
namespace asio = boost::asio;
using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

constexpr std::size_t kMaxLine = 128;  // docs/camapp.md, including '\n'

Error BadLine(const std::string& what, std::string_view line) {
  return Error(StatusCode::kInvalidArgument, "camapp: " + what + " in line \"" + std::string(line) + "\"");
}

std::vector<std::string_view> SplitSpaces(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && line[i] == ' ') ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

template <typename T>
T ParseUnsigned(std::string_view field, const char* what, std::string_view line) {
  T value{};
  const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || ptr != field.data() + field.size()) {
    throw BadLine(std::string(what) + " \"" + std::string(field) + "\" is not an unsigned integer", line);
  }
  return value;
}

// digits[.digits(1..6)], no sign, no exponent.
double ParseCoordinate(std::string_view field, const char* what, int limit, std::string_view line) {
  const size_t dot = field.find('.');
  const std::string_view whole = field.substr(0, dot);
  const std::string_view frac = dot == std::string_view::npos ? std::string_view() : field.substr(dot + 1);
  auto digits = [](std::string_view s) {
    for (char c : s) if (c < '0' || c > '9') return false;
    return true;
  };
  if (whole.empty() || whole.size() > 6 || !digits(whole) ||
      (dot != std::string_view::npos && (frac.empty() || frac.size() > 6 || !digits(frac)))) {
    throw BadLine(std::string(what) + " \"" + std::string(field) + "\" is not a decimal number", line);
  }
  double value = 0;
  for (char c : whole) value = value * 10 + (c - '0');
  double scale = 0.1;
  for (char c : frac) {
    value += (c - '0') * scale;
    scale /= 10;
  }
  if (value > limit - 1) {
    throw BadLine(std::string(what) + " " + std::string(field) + " is outside 0.." + std::to_string(limit - 1), line);
  }
  return value;
}

}  // namespace

CamAppSample ParseCamAppSample(std::string_view line, int width, int height) {
  const auto f = SplitSpaces(line);
  if (f.size() != 4) throw BadLine("expected 4 fields, got " + std::to_string(f.size()), line);
  CamAppSample s;
  s.seq = ParseUnsigned<std::uint32_t>(f[0], "seq", line);
  s.camera_time_us = ParseUnsigned<std::uint64_t>(f[1], "time_us", line);
  if (f[2] == "-" && f[3] == "-") return s;
  s.seen = true;
  s.pixel = {ParseCoordinate(f[2], "x", width, line), ParseCoordinate(f[3], "y", height, line)};
  return s;
}

// The tracker's state. Thread-safety: the Asio objects and the stream state are
// used on the I/O thread only; the members marked below are guarded by mutex_.
struct LedTracker::Impl {
  Impl(CameraModel m, LedTrackerOptions o)
      : model_(std::move(m)),
        options_(std::move(o)),
        name_("led-tracker " + options_.host + ":" + std::to_string(options_.port)),
        socket_(io_),
        resolver_(io_),
        timer_(io_) {}

  void Connect() {
    buffer_.clear();
    hello_done_ = false;
    resolver_.async_resolve(options_.host, std::to_string(options_.port),
                           [this](const boost::system::error_code& ec, tcp::resolver::results_type results) {
                             if (ec) return Fail("resolve: " + ec.message());
                             timer_.expires_after(std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(options_.connect_timeout)));
                             timer_.async_wait([this](const boost::system::error_code& tec) {
                               if (!tec) socket_.close();  // connect timed out
                             });
                             asio::async_connect(socket_, results,
                                                 [this](const boost::system::error_code& cec, const tcp::endpoint&) {
                                                   timer_.cancel();
                                                   if (cec) return Fail("connect: " + cec.message());
                                                   Read();
                                                 });
                           });
  }

  void Read() {
    asio::async_read_until(socket_, asio::dynamic_buffer(buffer_, kMaxLine), '\n',
                           [this](const boost::system::error_code& ec, std::size_t n) {
                             if (ec == asio::error::not_found) return Fail("line longer than 128 bytes");
                             if (ec) return Fail(ec == asio::error::eof ? "closed by the server" : ec.message());
                             std::string line = buffer_.substr(0, n - 1);
                             buffer_.erase(0, n);
                             if (!line.empty() && line.back() == '\r') line.pop_back();
                             try {
                               Handle(line);
                             } catch (const Error& e) {
                               return Fail(e.what());
                             }
                             Read();
                           });
  }

  void Handle(const std::string& line) {
    if (!line.empty() && line[0] == '#') return;
    if (!hello_done_) {
      const auto f = SplitSpaces(line);
      if (f.size() != 4 || f[0] != "YAMOR-CAMAPP" || f[1] != "1") {
        throw BadLine("bad hello (expected \"YAMOR-CAMAPP 1 <width> <height>\")", line);
      }
      const int w = ParseUnsigned<int>(f[2], "width", line), h = ParseUnsigned<int>(f[3], "height", line);
      const auto& lens = model_.lens().params();
      if (w != lens.width || h != lens.height) {
        throw BadLine("image " + std::to_string(w) + "x" + std::to_string(h) + " but the calibration is for " +
                          std::to_string(lens.width) + "x" + std::to_string(lens.height), line);
      }
      hello_done_ = true;
      std::lock_guard lock(mutex_);
      connected_ = true;
      ++connections_;
      Log().info("{}: connected", name_);
      return;
    }
    const auto& lens = model_.lens().params();
    LedSample sample{ParseCamAppSample(line, lens.width, lens.height), Clock::now()};
    std::lock_guard lock(mutex_);
    latest_ = sample;
  }

  void Fail(const std::string& why) {
    if (stopping_) return;
    boost::system::error_code ignored;
    socket_.close(ignored);
    {
      std::lock_guard lock(mutex_);
      if (connected_ || why != last_error_) Log().warn("{}: {}; reconnecting", name_, why);
      connected_ = false;
      last_error_ = why;
    }
    timer_.expires_after(std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(options_.reconnect_delay)));
    timer_.async_wait([this](const boost::system::error_code& ec) {
      if (!ec && !stopping_) Connect();
    });
  }

  const CameraModel model_;
  const LedTrackerOptions options_;
  const std::string name_;

  // Used on the I/O thread only.
  asio::io_context io_;
  tcp::socket socket_;
  tcp::resolver resolver_;
  asio::steady_timer timer_;
  std::string buffer_;
  bool hello_done_ = false;
  bool stopping_ = false;  // set on the I/O thread by the destructor's post
  std::thread thread_;

  mutable std::mutex mutex_;
  std::optional<LedSample> latest_;   // guarded by mutex_
  bool connected_ = false;            // guarded by mutex_
  std::uint64_t connections_ = 0;     // guarded by mutex_
  std::string last_error_ = "not connected yet";  // guarded by mutex_
};

LedTracker::LedTracker(CameraModel model, LedTrackerOptions options)
    : impl_(std::make_unique<Impl>(std::move(model), std::move(options))) {
  if (impl_->options_.port <= 0 || impl_->options_.port > 65535) {
    throw Error(StatusCode::kInvalidArgument, "led tracker: port " + std::to_string(impl_->options_.port) +
                                                  " is outside 1..65535");
  }
  if (!(impl_->options_.connect_timeout > 0) || !(impl_->options_.reconnect_delay >= 0)) {
    throw Error(StatusCode::kInvalidArgument, "led tracker: connect_timeout must be > 0 and reconnect_delay >= 0");
  }
  asio::post(impl_->io_, [impl = impl_.get()] { impl->Connect(); });
  impl_->thread_ = std::thread([impl = impl_.get()] { impl->io_.run(); });
}

LedTracker::~LedTracker() {
  asio::post(impl_->io_, [impl = impl_.get()] {
    impl->stopping_ = true;
    boost::system::error_code ignored;
    impl->timer_.cancel();
    impl->resolver_.cancel();
    impl->socket_.close(ignored);
    impl->io_.stop();
  });
  impl_->thread_.join();
}

const std::string& LedTracker::name() const noexcept { return impl_->name_; }
const CameraModel& LedTracker::model() const noexcept { return impl_->model_; }

std::optional<LedSample> LedTracker::LatestSample() const {
  std::lock_guard lock(impl_->mutex_);
  return impl_->latest_;
}

bool LedTracker::connected() const {
  std::lock_guard lock(impl_->mutex_);
  return impl_->connected_;
}

std::uint64_t LedTracker::connections() const {
  std::lock_guard lock(impl_->mutex_);
  return impl_->connections_;
}

TrackedPosition LedTracker::LatestPosition(std::chrono::duration<double> max_age) const {
  std::optional<LedSample> latest;
  bool connected = false;
  std::string last_error;
  {
    std::lock_guard lock(impl_->mutex_);
    latest = impl_->latest_;
    connected = impl_->connected_;
    last_error = impl_->last_error_;
  }
  const std::string state = connected ? "connected" : "disconnected: " + last_error;
  if (!latest) throw Error(StatusCode::kUnavailable, impl_->name_ + ": no sample received yet (" + state + ")");
  const double age = std::chrono::duration<double>(Clock::now() - latest->arrival).count();
  if (age > max_age.count()) {
    std::ostringstream msg;
    msg.precision(3);
    msg << impl_->name_ << ": the last sample (seq " << latest->sample.seq << ") is " << std::fixed << age
        << " s old, more than the " << max_age.count() << " s allowed (" << state << ")";
    throw Error(StatusCode::kUnavailable, msg.str());
  }
  if (!latest->sample.seen) {
    throw Error(StatusCode::kUnavailable,
                impl_->name_ + ": LED not seen in the last frame (seq " + std::to_string(latest->sample.seq) + ")");
  }
  TrackedPosition out;
  try {
    out.ground = impl_->model_.PixelToGround(latest->sample.pixel);
  } catch (const Error& e) {
    throw Error(StatusCode::kUnavailable, impl_->name_ + ": " + e.what());
  }
  out.pixel = latest->sample.pixel;
  out.seq = latest->sample.seq;
  out.camera_time_us = latest->sample.camera_time_us;
  out.arrival = latest->arrival;
  return out;
}

}  // namespace yamor::host
