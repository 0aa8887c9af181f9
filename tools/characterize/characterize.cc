#include "tools/characterize/characterize.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <system_error>

#include "common/format.h"
#include "common/status.h"

namespace yamor::characterize {
namespace {

constexpr const char* kAxes = "xyz";

physics::MotionPath RestPath(double duration) {
  return physics::MotionPath("rest", duration, [](double) {
    physics::PathPoint p;
    p.position = Eigen::Vector3d(0, 0, physics::RestingHeight());
    return p;
  });
}

double Quantise(double value, double resolution) {
  return std::round(value / resolution) * resolution;
}

// Central differences inside, one-sided at the ends.
std::vector<Eigen::Vector3d> Differentiate(const std::vector<Eigen::Vector3d>& x, double dt) {
  std::vector<Eigen::Vector3d> d(x.size(), Eigen::Vector3d::Zero());
  if (x.size() < 2) return d;
  for (size_t i = 0; i < x.size(); ++i) {
    const size_t lo = i == 0 ? 0 : i - 1, hi = i + 1 == x.size() ? i : i + 1;
    d[i] = (x[hi] - x[lo]) / (double(hi - lo) * dt);
  }
  return d;
}

void AppendVector(std::ostringstream& out, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) out << ',' << FormatDouble(v[i]);
}

}  // namespace

NoiseResult MeasureNoise(const NoiseOptions& options) {
  if (!(std::isfinite(options.duration) && options.duration > 0)) {
    throw Error(StatusCode::kInvalidArgument,
                "noise duration must be finite and > 0, got " + FormatDouble(options.duration));
  }
  physics::DrivenModuleOptions module_options;
  module_options.sample_rate = options.sample_rate;
  module_options.seed = options.seed;
  module_options.accelerometer = options.accelerometer;
  physics::DrivenModule module(RestPath(options.duration), module_options);
  NoiseResult result;
  result.count_size = options.accelerometer.count_size;
  std::array<double, 3> sum{}, sum2{};
  while (!module.Done()) {
    const physics::DrivenSample s = module.Next();
    const Eigen::Vector3d noise = s.reading.acceleration - s.specific_force;
    result.true_force = s.specific_force;
    result.time.push_back(s.time);
    result.counts.push_back(s.reading.counts);
    result.noise.push_back(noise);
    for (size_t axis = 0; axis < 3; ++axis) {
      NoiseAxis& a = result.axes[axis];
      const double n = noise[static_cast<int>(axis)];
      if (result.noise.size() == 1) a.n_min = a.n_max = n;
      a.n_min = std::min(a.n_min, n);
      a.n_max = std::max(a.n_max, n);
      ++a.histogram[s.reading.counts[axis]];
      sum[axis] += n;
      sum2[axis] += n * n;
    }
  }
  const double count = double(result.noise.size());
  for (size_t axis = 0; axis < 3; ++axis) {
    NoiseAxis& a = result.axes[axis];
    a.n_ampl = a.n_max - a.n_min;
    a.n_ratio = a.n_ampl / (1024 * result.count_size);
    a.mean = sum[axis] / count;
    a.stddev = std::sqrt(std::max(0.0, sum2[axis] / count - a.mean * a.mean));
  }
  return result;
}

MoveResult MeasureMove(const physics::MotionPath& path, const MoveOptions& options) {
  physics::DrivenModule module(path, options.module);
  physics::An3397Options full = options.filter;
  full.sample_period = full.average_count / options.module.sample_rate;
  full.count_size = options.module.accelerometer.count_size;
  physics::An3397Options noise_only = full;
  noise_only.window_filter = false;
  noise_only.movement_end = false;
  physics::An3397Filter filtered(full), noise_filtered(noise_only);
  if (!(std::isfinite(options.tracker_resolution) && options.tracker_resolution > 0)) {
    throw Error(StatusCode::kInvalidArgument, "tracker_resolution must be finite and > 0, got " +
                                                  FormatDouble(options.tracker_resolution));
  }
  if (!(std::isfinite(options.tracker_rate) && options.tracker_rate > 0)) {
    throw Error(StatusCode::kInvalidArgument, "tracker_rate must be finite and > 0, got " +
                                                  FormatDouble(options.tracker_rate));
  }
  MoveResult result;
  result.name = path.name();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  bool have_origin = false;
  while (!module.Done()) {
    const physics::DrivenSample s = module.Next();
    const auto a = filtered.Add(s.reading.counts);
    const auto b = noise_filtered.Add(s.reading.counts);
    if (filtered.calibrated() && !have_origin) {
      origin = s.sensor_position;  // dead reckoning starts here at 0
      have_origin = true;
    }
    if (!a) continue;
    MoveRow row;
    row.time = s.time;
    row.true_position = s.sensor_position - origin;
    row.filtered = *a;
    row.noise_filtered = *b;
    result.rows.push_back(row);
  }
  // The camera sees the LED at its frames only: positions sampled (and held)
  // at tracker_rate, differentiated over the frames.
  const double frame = 1.0 / options.tracker_rate;
  std::vector<Eigen::Vector3d> frames;   // quantised position at each frame
  std::vector<size_t> frame_of_row(result.rows.size(), 0);
  double next_frame_time = result.rows.empty() ? 0.0 : result.rows.front().time;
  for (size_t i = 0; i < result.rows.size(); ++i) {
    MoveRow& row = result.rows[i];
    if (frames.empty() || row.time >= next_frame_time - 1e-12) {
      Eigen::Vector3d q;
      for (int k = 0; k < 3; ++k) q[k] = Quantise(row.true_position[k], options.tracker_resolution);
      frames.push_back(q);
      next_frame_time += frame;
    }
    frame_of_row[i] = frames.size() - 1;
  }
  const std::vector<Eigen::Vector3d> v = Differentiate(frames, frame);
  const std::vector<Eigen::Vector3d> acc = Differentiate(v, frame);
  for (size_t i = 0; i < result.rows.size(); ++i) {
    result.rows[i].tracker_position = frames[frame_of_row[i]];
    result.rows[i].tracker_velocity = v[frame_of_row[i]];
    result.rows[i].tracker_acceleration = acc[frame_of_row[i]];
  }
  if (!result.rows.empty()) {
    const MoveRow& last = result.rows.back();
    result.final_error_noise_filtered = last.noise_filtered.position - last.true_position;
    result.final_error_filtered = last.filtered.position - last.true_position;
  }
  result.impacts = module.board().impacts();
  return result;
}

NoiseResult NoiseFromLog(const std::vector<LoggedReading>& readings, double count_size) {
  if (readings.size() < 2) {
    throw Error(StatusCode::kInvalidArgument,
                "a noise log needs at least 2 readings, got " + std::to_string(readings.size()));
  }
  NoiseResult result;
  result.count_size = count_size;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const LoggedReading& r : readings) mean += Eigen::Vector3d(r.counts[0], r.counts[1], r.counts[2]);
  mean /= double(readings.size());
  // Noise relative to the mean; true_force makes HistogramCsv() use the same zero.
  result.true_force = (mean - Eigen::Vector3d::Constant(512)) * count_size;
  std::array<double, 3> sum2{};
  for (const LoggedReading& r : readings) {
    const Eigen::Vector3d noise =
        (Eigen::Vector3d(r.counts[0], r.counts[1], r.counts[2]) - mean) * count_size;
    result.time.push_back(r.time);
    result.counts.push_back(r.counts);
    result.noise.push_back(noise);
    for (size_t axis = 0; axis < 3; ++axis) {
      NoiseAxis& a = result.axes[axis];
      const double n = noise[static_cast<int>(axis)];
      if (result.noise.size() == 1) a.n_min = a.n_max = n;
      a.n_min = std::min(a.n_min, n);
      a.n_max = std::max(a.n_max, n);
      ++a.histogram[r.counts[axis]];
      sum2[axis] += n * n;
    }
  }
  for (size_t axis = 0; axis < 3; ++axis) {
    NoiseAxis& a = result.axes[axis];
    a.n_ampl = a.n_max - a.n_min;
    a.n_ratio = a.n_ampl / (1024 * count_size);
    a.mean = 0;
    a.stddev = std::sqrt(sum2[axis] / double(readings.size()));
  }
  return result;
}

MoveResult FilterLog(const std::string& name, const std::vector<LoggedReading>& readings,
                     physics::An3397Options filter) {
  if (readings.size() < static_cast<size_t>(std::max(filter.calibration_readings, 2))) {
    throw Error(StatusCode::kInvalidArgument,
                "log '" + name + "' has " + std::to_string(readings.size()) +
                    " readings, fewer than the " + std::to_string(filter.calibration_readings) +
                    " of the rest calibration");
  }
  const double interval = (readings.back().time - readings.front().time) / double(readings.size() - 1);
  filter.sample_period = interval * filter.average_count;
  physics::An3397Options noise_only = filter;
  noise_only.window_filter = false;
  noise_only.movement_end = false;
  physics::An3397Filter full(filter), partial(noise_only);
  MoveResult result;
  result.name = name;
  for (const LoggedReading& r : readings) {
    const auto a = full.Add(r.counts);
    const auto b = partial.Add(r.counts);
    if (!a) continue;
    MoveRow row;
    row.time = r.time;
    row.filtered = *a;
    row.noise_filtered = *b;
    result.rows.push_back(row);
  }
  return result;
}

std::vector<physics::MotionPath> ThesisMoves(std::uint64_t seed) {
  return {physics::SineMove(), physics::CircleMove(), physics::GoAndReturnMove(),
          physics::RandomAirMove(seed), physics::DropMove()};
}

void WriteFileAtomically(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::path temporary = path;
  temporary += ".partial";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw Error(StatusCode::kFailedPrecondition, "cannot write " + temporary.string());
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw Error(StatusCode::kFailedPrecondition,
                "cannot rename " + temporary.string() + " to " + path.string() + ": " +
                    error.message());
  }
}

std::string NoiseCsv(const NoiseResult& r) {
  std::ostringstream out;
  out << "time,count_x,count_y,count_z,noise_x,noise_y,noise_z\n";
  for (size_t i = 0; i < r.time.size(); ++i) {
    out << FormatDouble(r.time[i]);
    for (int c : r.counts[i]) out << ',' << c;
    AppendVector(out, r.noise[i]);
    out << '\n';
  }
  return out.str();
}

std::string HistogramCsv(const NoiseResult& r) {
  std::ostringstream out;
  out << "axis,code,noise,count\n";
  for (size_t axis = 0; axis < 3; ++axis) {
    const NoiseAxis& a = r.axes[axis];
    if (a.histogram.empty()) continue;
    // Every code of the span, zero counts included: the missing codes show.
    for (int code = a.histogram.begin()->first; code <= a.histogram.rbegin()->first; ++code) {
      const auto it = a.histogram.find(code);
      const double value = (code - 512) * r.count_size - r.true_force[static_cast<int>(axis)];
      out << kAxes[axis] << ',' << code << ',' << FormatDouble(value) << ','
          << (it == a.histogram.end() ? 0 : it->second) << '\n';
    }
  }
  return out.str();
}

std::string Table41Csv(const NoiseResult& r) {
  std::ostringstream out;
  out << "axis,n_min,n_max,n_ampl,n_ratio,mean,stddev,samples,thesis_n_min,thesis_n_max,"
         "thesis_n_ampl,thesis_n_ratio\n";
  for (size_t axis = 0; axis < 3; ++axis) {
    const NoiseAxis& a = r.axes[axis];
    out << kAxes[axis] << ',' << FormatDouble(a.n_min) << ',' << FormatDouble(a.n_max) << ','
        << FormatDouble(a.n_ampl) << ',' << FormatDouble(a.n_ratio) << ','
        << FormatDouble(a.mean) << ',' << FormatDouble(a.stddev) << ',' << r.noise.size() << ','
        << FormatDouble(ThesisTable41::kMin[axis]) << ',' << FormatDouble(ThesisTable41::kMax[axis])
        << ',' << FormatDouble(ThesisTable41::kAmpl[axis]) << ','
        << FormatDouble(ThesisTable41::kRatio[axis]) << '\n';
  }
  return out.str();
}

std::string MoveCsv(const MoveResult& r) {
  std::ostringstream out;
  out << "time";
  for (const char* quantity : {"acceleration", "velocity", "position"}) {
    for (const char* curve : {"tracker", "noise_filtered", "filtered"}) {
      for (int axis = 0; axis < 3; ++axis) out << ',' << curve << '_' << quantity << '_' << kAxes[axis];
    }
  }
  for (int axis = 0; axis < 3; ++axis) out << ",true_position_" << kAxes[axis];
  out << '\n';
  for (const MoveRow& row : r.rows) {
    out << FormatDouble(row.time);
    AppendVector(out, row.tracker_acceleration);
    AppendVector(out, row.noise_filtered.acceleration);
    AppendVector(out, row.filtered.acceleration);
    AppendVector(out, row.tracker_velocity);
    AppendVector(out, row.noise_filtered.velocity);
    AppendVector(out, row.filtered.velocity);
    AppendVector(out, row.tracker_position);
    AppendVector(out, row.noise_filtered.position);
    AppendVector(out, row.filtered.position);
    AppendVector(out, row.true_position);
    out << '\n';
  }
  return out.str();
}

}  // namespace yamor::characterize
