#include "host/led_tracker.h"

#include <utility>  // before Asio: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <charconv>
#include <cmath>
#include <condition_variable>
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
  Impl(std::optional<CameraModel> m, int width, int height, LedTrackerOptions o)
      : model_(std::move(m)),
        width_(width),
        height_(height),
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
      if (w != width_ || h != height_) {
        throw BadLine("image " + std::to_string(w) + "x" + std::to_string(h) + " but the " +
                          (model_ ? "calibration" : "tracker") + " is for " + std::to_string(width_) +
                          "x" + std::to_string(height_), line);
      }
      hello_done_ = true;
      std::lock_guard lock(mutex_);
      connected_ = true;
      ++connections_;
      Log().info("{}: connected", name_);
      return;
    }
    LedSample sample{ParseCamAppSample(line, width_, height_), Clock::now(), 0};
    {
      std::lock_guard lock(mutex_);
      sample.connection = connections_;
    }
    {
      // Before the sample becomes the latest: whoever waited for it finds it handled.
      std::lock_guard lock(handler_mutex_);
      if (handler_) handler_(sample);
    }
    {
      std::lock_guard lock(mutex_);
      latest_ = sample;
    }
    sample_cv_.notify_all();
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

  const std::optional<CameraModel> model_;
  const int width_;
  const int height_;
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
  mutable std::condition_variable sample_cv_;  // notified on each sample, with mutex_
  std::optional<LedSample> latest_;   // guarded by mutex_
  bool connected_ = false;            // guarded by mutex_
  std::uint64_t connections_ = 0;     // guarded by mutex_
  std::string last_error_ = "not connected yet";  // guarded by mutex_

  // Held while the handler runs, so replacing it waits for a call in flight.
  std::mutex handler_mutex_;
  std::function<void(const LedSample&)> handler_;  // guarded by handler_mutex_
};

LedTracker::LedTracker(CameraModel model, LedTrackerOptions options)
    : LedTracker(std::optional<CameraModel>(std::move(model)), 0, 0, std::move(options)) {}

LedTracker::LedTracker(int width, int height, LedTrackerOptions options)
    : LedTracker(std::nullopt, width, height, std::move(options)) {}

LedTracker::LedTracker(std::optional<CameraModel> model, int width, int height, LedTrackerOptions options) {
  if (model) {
    width = model->lens().params().width;
    height = model->lens().params().height;
  }
  if (width <= 0 || height <= 0 || width > 1000000 || height > 1000000) {
    throw Error(StatusCode::kInvalidArgument, "led tracker: image size " + std::to_string(width) + "x" +
                                                  std::to_string(height) + " is not positive");
  }
  impl_ = std::make_unique<Impl>(std::move(model), width, height, std::move(options));
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
bool LedTracker::has_model() const noexcept { return impl_->model_.has_value(); }

const CameraModel& LedTracker::model() const {
  if (!impl_->model_) {
    throw Error(StatusCode::kFailedPrecondition, impl_->name_ + ": no camera calibration (raw pixels only)");
  }
  return *impl_->model_;
}

std::optional<LedSample> LedTracker::WaitForSample(const std::function<bool(const LedSample&)>& accept,
                                                   std::chrono::duration<double> timeout) const {
  std::unique_lock lock(impl_->mutex_);
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(timeout);
  std::optional<LedSample> found;
  impl_->sample_cv_.wait_until(lock, deadline, [&] {
    if (impl_->latest_ && accept(*impl_->latest_)) found = impl_->latest_;
    return found.has_value();
  });
  return found;
}

void LedTracker::SetSampleHandler(std::function<void(const LedSample&)> handler) {
  std::lock_guard lock(impl_->handler_mutex_);
  impl_->handler_ = std::move(handler);
}

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
  return Locate(*latest);
}

TrackedPosition LedTracker::Locate(const LedSample& sample) const {
  const CameraModel& camera = model();
  if (!sample.sample.seen) {
    throw Error(StatusCode::kUnavailable,
                impl_->name_ + ": LED not seen in the frame (seq " + std::to_string(sample.sample.seq) + ")");
  }
  TrackedPosition out;
  try {
    out.ground = camera.PixelToGround(sample.sample.pixel);
  } catch (const Error& e) {
    throw Error(StatusCode::kUnavailable, impl_->name_ + ": " + e.what());
  }
  out.pixel = sample.sample.pixel;
  out.seq = sample.sample.seq;
  out.camera_time_us = sample.sample.camera_time_us;
  out.arrival = sample.arrival;
  return out;
}

namespace {

// PositionTracker over an LedTracker (yamord's --led-tracker).
// Thread-safety: immutable; the tracker is thread-safe.
class LedPositionTracker final : public PositionTracker {
 public:
  LedPositionTracker(std::shared_ptr<LedTracker> tracker, std::chrono::duration<double> max_age)
      : tracker_(std::move(tracker)), max_age_(max_age), led_height_(tracker_->model().led_height()) {
    if (!(max_age_.count() > 0)) {
      throw Error(StatusCode::kInvalidArgument, "led tracker: max age must be > 0 s");
    }
  }

  ~LedPositionTracker() override { tracker_->SetSampleHandler(nullptr); }
  LedPositionTracker(const LedPositionTracker&) = delete;
  LedPositionTracker& operator=(const LedPositionTracker&) = delete;

  const std::string& name() const override { return tracker_->name(); }

  TrackedPose Latest() const override { return Pose(tracker_->LatestPosition(max_age_)); }

  TrackedPose CapturedBetween(double earliest, const std::function<double()>& latest) const override {
    // Camera times are whole microseconds: compare with half a microsecond to spare.
    auto wanted = [&](const LedSample& s) {
      const double t = static_cast<double>(s.sample.camera_time_us);
      return t >= earliest * 1e6 - 0.5 && t <= latest() * 1e6 + 0.5;
    };
    const auto found =
        tracker_->WaitForSample([&](const LedSample& s) { return wanted(s) && s.sample.seen; }, max_age_);
    if (found) return Pose(tracker_->Locate(*found));
    // Say what the camera sent instead: nothing, only older frames, or frames without the LED.
    const auto last = tracker_->LatestSample();
    std::ostringstream msg;
    msg.precision(6);
    msg << tracker_->name() << ": no frame with the LED captured at or after camera time " << earliest
        << " s within " << max_age_.count() << " s";
    if (!last) {
      msg << " (no sample received" << (tracker_->connected() ? ")" : "; not connected)");
    } else if (wanted(*last)) {
      msg << " (LED not seen since; last frame seq " << last->sample.seq << ")";
    } else {
      msg << " (last frame seq " << last->sample.seq << " captured at "
          << static_cast<double>(last->sample.camera_time_us) * 1e-6
          << " s; is the camera yamor-camapp filming this simulation?)";
    }
    throw Error(StatusCode::kUnavailable, msg.str());
  }

  void SetHandler(std::function<void(const TrackedPose&)> handler) override {
    if (!handler) return tracker_->SetSampleHandler(nullptr);
    tracker_->SetSampleHandler([this, handler = std::move(handler)](const LedSample& s) {
      if (!s.sample.seen) return;
      try {
        handler(Pose(tracker_->Locate(s)));
      } catch (const Error& e) {
        Log().debug("{}: sample dropped: {}", tracker_->name(), e.what());
      }
    });
  }

 private:
  TrackedPose Pose(const TrackedPosition& p) const {
    return TrackedPose{.position = {p.ground.x(), p.ground.y(), led_height_},
                       .camera_time = static_cast<double>(p.camera_time_us) * 1e-6,
                       .arrival = p.arrival};
  }

  const std::shared_ptr<LedTracker> tracker_;
  const std::chrono::duration<double> max_age_;
  const double led_height_;
};

}  // namespace

std::shared_ptr<PositionTracker> MakeLedPositionTracker(std::shared_ptr<LedTracker> tracker,
                                                        std::chrono::duration<double> max_age) {
  YAMOR_CHECK(tracker != nullptr, "MakeLedPositionTracker needs a tracker");
  return std::make_shared<LedPositionTracker>(std::move(tracker), max_age);
}

}  // namespace yamor::host
