#include "tools/yamorctl/tracking.h"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>

#include <fmt/format.h>

#include "common/format.h"
#include "common/status.h"
#include "host/camera_model.h"
#include "host/led_tracker.h"

namespace yamor::yamorctl {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kUsage = 2;  // yamorctl.h's kUsageExitCode

// "yamorctl: CODE: message" and the code's number (2 for a local file).
int Fail(std::ostream& err, const Error& e) {
  err << "yamorctl: " << StatusCodeName(e.code()) << ": " << e.what() << "\n";
  return static_cast<int>(e.code());
}

int Usage(std::ostream& err, const std::string& message) {
  err << "yamorctl: " << message << "\n";
  return kUsage;
}

bool ReadText(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  return !in.bad();
}

std::string Mm(double metres) { return fmt::format("{:.2f}", metres * 1e3); }

}  // namespace

int Track(const TrackOptions& o, std::ostream& out, std::ostream& err) {
  host::LedTrackerOptions tracker_options;
  const auto colon = o.camapp.rfind(':');
  try {
    size_t used = 0;
    tracker_options.port = colon == std::string::npos || colon == 0
                               ? -1
                               : std::stoi(o.camapp.substr(colon + 1), &used);
    if (colon + 1 + used != o.camapp.size()) tracker_options.port = -1;
  } catch (const std::exception&) {
    tracker_options.port = -1;
  }
  if (tracker_options.port < 1 || tracker_options.port > 65535) {
    return Usage(err, "--camapp '" + o.camapp + "' is not HOST:PORT");
  }
  tracker_options.host = o.camapp.substr(0, colon);
  tracker_options.reconnect_delay = 0.2;
  if (!(o.seconds >= 0) || !(o.connect_timeout > 0)) {
    return Usage(err, "--seconds must be >= 0 and --connect-timeout > 0");
  }
  std::unique_ptr<host::LedTracker> tracker;
  try {
    if (o.calibration.empty()) {
      tracker = std::make_unique<host::LedTracker>(o.width, o.height, tracker_options);
    } else {
      tracker = std::make_unique<host::LedTracker>(host::LoadCameraModel(o.calibration), tracker_options);
    }
  } catch (const Error& e) {
    if (e.code() == StatusCode::kNotFound) return Usage(err, e.what());
    return Fail(err, e);
  }
  std::unique_ptr<std::ofstream> csv;
  if (!o.record.empty()) {
    csv = std::make_unique<std::ofstream>(o.record, std::ios::binary | std::ios::trunc);
    if (!*csv) return Usage(err, "cannot write " + o.record);
    *csv << kTrackCsvHeader << "\n" << std::flush;
  }

  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<host::LedSample> queue;
  tracker->SetSampleHandler([&](const host::LedSample& s) {
    {
      std::lock_guard lock(mutex);
      queue.push_back(s);
    }
    arrived.notify_one();
  });
  struct Unhook {  // no handler call may outlive this function's locals
    host::LedTracker& tracker;
    ~Unhook() { tracker.SetSampleHandler(nullptr); }
  } unhook{*tracker};

  const auto start = Clock::now();
  const auto connect_deadline =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.connect_timeout));
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.seconds));
  std::uint64_t received = 0, seen = 0, corrected = 0;
  while (true) {
    const auto now = Clock::now();
    if (o.seconds > 0 && now >= end) break;
    if (o.samples > 0 && received >= o.samples) break;
    if (tracker->connections() == 0 && now >= connect_deadline) {
      return Fail(err, Error(StatusCode::kUnavailable,
                             tracker->name() + ": not connected after " + FormatRounded(o.connect_timeout) + " s"));
    }
    std::deque<host::LedSample> batch;
    {
      std::unique_lock lock(mutex);
      arrived.wait_for(lock, std::chrono::milliseconds(100), [&] { return !queue.empty(); });
      batch.swap(queue);
    }
    for (const host::LedSample& s : batch) {
      if (o.samples > 0 && received >= o.samples) break;
      ++received;
      std::optional<Eigen::Vector2d> ground;
      std::string why;
      if (s.sample.seen) {
        ++seen;
        if (tracker->has_model()) {
          try {
            ground = tracker->Locate(s).ground;
            ++corrected;
          } catch (const Error& e) {
            why = e.what();
          }
        }
      }
      const double host_time = std::chrono::duration<double>(s.arrival - start).count();
      if (csv) {
        *csv << fmt::format("{:.6f},{},{},{},{},{},{},{},{}\n", host_time, s.sample.seq,
                            s.sample.camera_time_us, s.sample.seen ? 1 : 0,
                            s.sample.seen ? FormatDouble(s.sample.pixel.x()) : "",
                            s.sample.seen ? FormatDouble(s.sample.pixel.y()) : "",
                            ground ? FormatDouble(ground->x()) : "", ground ? FormatDouble(ground->y()) : "",
                            s.connection)
             << std::flush;  // an interrupted recording keeps every row
      } else if (o.json) {
        out << fmt::format("{{\"host_time\":{:.6f},\"seq\":{},\"camera_time_us\":{},\"seen\":{}", host_time,
                           s.sample.seq, s.sample.camera_time_us, s.sample.seen ? "true" : "false");
        if (s.sample.seen) {
          out << ",\"pixel\":[" << FormatDouble(s.sample.pixel.x()) << "," << FormatDouble(s.sample.pixel.y()) << "]";
        }
        if (ground) out << ",\"position\":[" << FormatDouble(ground->x()) << "," << FormatDouble(ground->y()) << "]";
        out << ",\"connection\":" << s.connection << "}\n" << std::flush;
      } else {
        out << fmt::format("seq {}  camera {:.6f} s  ", s.sample.seq, s.sample.camera_time_us * 1e-6);
        if (!s.sample.seen) {
          out << "LED not seen\n";
        } else {
          out << "pixel (" << FormatDouble(s.sample.pixel.x()) << ", " << FormatDouble(s.sample.pixel.y()) << ")";
          if (ground) out << fmt::format("  ->  ({:.4f}, {:.4f}) m", ground->x(), ground->y());
          if (!why.empty()) out << "  (" << why << ")";
          out << "\n";
        }
        out.flush();
      }
    }
  }
  if (csv) {
    out << "recorded " << received << " samples (" << seen << " with the LED, " << corrected
        << " in metres) over " << tracker->connections() << " connection(s) to " << o.record << "\n";
  }
  return 0;
}

int Calibrate(const CalibrateOptions& o, std::ostream& out, std::ostream& err) {
  std::string points_text, lens_text;
  if (!ReadText(o.points, &points_text)) return Usage(err, "cannot read " + o.points);
  if (!o.lens.empty() && !ReadText(o.lens, &lens_text)) return Usage(err, "cannot read " + o.lens);
  if (o.led_height && !std::isfinite(*o.led_height)) return Usage(err, "--led-height must be finite");
  host::CameraCalibration calibration;
  std::optional<host::CameraModel> model;
  try {
    if (o.lens.empty()) {
      calibration = host::ParseCameraCalibration(points_text, o.points);
    } else {
      calibration = host::ParseCameraCalibration(lens_text, o.lens);
      calibration.points = host::ParseReferencePoints(points_text, o.points);
    }
    if (o.led_height) calibration.led_height = *o.led_height;
    model.emplace(calibration, o.points);
  } catch (const Error& e) {
    return Fail(err, e);
  }
  const host::HomographyFit& fit = model->fit();
  size_t worst = 0;
  for (size_t i = 0; i < fit.residuals.size(); ++i) {
    if (fit.residuals[i] > fit.residuals[worst]) worst = i;
  }
  const auto& points = calibration.points;
  auto fitted = [&](size_t i) {
    return host::ApplyHomography(fit.h, model->lens().Undistort(points[i].pixel));
  };
  if (o.json) {
    out << "{\"points\":[";
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d f = fitted(i);
      out << (i ? "," : "") << "{\"line\":" << points[i].line << ",\"pixel\":[" << FormatDouble(points[i].pixel.x())
          << "," << FormatDouble(points[i].pixel.y()) << "],\"ground\":[" << FormatDouble(points[i].ground.x())
          << "," << FormatDouble(points[i].ground.y()) << "],\"fitted\":[" << FormatDouble(f.x()) << ","
          << FormatDouble(f.y()) << "],\"error_m\":" << FormatDouble(fit.residuals[i]) << "}";
    }
    out << "],\"rms_m\":" << FormatDouble(fit.rms_error) << ",\"max_m\":" << FormatDouble(fit.max_error)
        << ",\"led_height\":" << FormatDouble(calibration.led_height) << "}\n";
  } else {
    out << fmt::format("{:>5}  {:>19}  {:>19}  {:>19}  {:>8}\n", "line", "pixel x, y", "ground X, Y [m]",
                       "fitted X, Y [m]", "err [mm]");
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d f = fitted(i);
      out << fmt::format("{:>5}  {:>9.3f} {:>9.3f}  {:>9.4f} {:>9.4f}  {:>9.4f} {:>9.4f}  {:>8}\n", points[i].line,
                         points[i].pixel.x(), points[i].pixel.y(), points[i].ground.x(), points[i].ground.y(),
                         f.x(), f.y(), Mm(fit.residuals[i]));
    }
    out << points.size() << " reference points: reprojection error RMS " << Mm(fit.rms_error) << " mm, max "
        << Mm(fit.max_error) << " mm (line " << points[worst].line << ")\n";
  }
  if (!o.output.empty()) {
    const std::string text = host::FormatCameraCalibration(
        calibration, fmt::format("written by yamorctl calibrate from {}\n{} reference points, reprojection "
                                 "error RMS {} mm, max {} mm",
                                 o.points, points.size(), Mm(fit.rms_error), Mm(fit.max_error)));
    std::ofstream file(o.output, std::ios::binary | std::ios::trunc);
    file << text;
    file.close();
    if (!file) return Usage(err, "cannot write " + o.output);
    if (!o.json) out << "calibration written to " << o.output << "\n";
  }
  return 0;
}

}  // namespace yamor::yamorctl
