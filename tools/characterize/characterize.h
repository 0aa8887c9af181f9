// Thesis chapter 4 in simulation: the noise measurement of a module at rest
// (Table 4.1, Figures B.1–B.4) and the moves of 4.3.4 seen by the tracker, the
// noise-filtered and the fully filtered accelerometer data (Figures B.5–B.19).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "physics/accelerometer.h"
#include "physics/an3397.h"
#include "physics/driven_module.h"
#include "tools/characterize/logged_csv.h"

namespace yamor::characterize {

/// Table 4.1 as the thesis printed it (x, y, z), m/s².
/// Thread-safety: immutable constants.
struct ThesisTable41 {
  static constexpr std::array<double, 3> kMin{-0.269, -0.267, -0.249};  ///< N_min.
  static constexpr std::array<double, 3> kMax{0.363, 0.246, 0.304};     ///< N_max.
  static constexpr std::array<double, 3> kAmpl{0.632, 0.514, 0.553};    ///< N_ampl.
  static constexpr std::array<double, 3> kRatio{0.0156, 0.0127, 0.0137};  ///< N_ratio.
};

/// Settings of the noise measurement.
/// Thread-safety: plain value.
struct NoiseOptions {
  double duration = 10;        ///< Seconds at rest (4.3.1: about 10 s).
  double sample_rate = 110;    ///< Readings per second (> 1000 in 10 s).
  std::uint64_t seed = 0;      ///< Sensor noise seed.
  physics::AccelerometerSpec accelerometer;  ///< Sensor model.
};

/// One axis of Table 4.1.
/// Thread-safety: plain value.
struct NoiseAxis {
  double n_min = 0;   ///< Smallest noise, m/s².
  double n_max = 0;   ///< Largest noise, m/s².
  double n_ampl = 0;  ///< n_max − n_min, m/s².
  double n_ratio = 0; ///< n_ampl / (1024·δ).
  double mean = 0;    ///< Mean noise, m/s².
  double stddev = 0;  ///< Standard deviation, m/s².
  std::map<int, int> histogram;  ///< Occurrences per ADC code.
};

/// The noise measurement's result.
/// Thread-safety: plain value.
struct NoiseResult {
  std::vector<double> time;                       ///< s, per reading.
  std::vector<std::array<int, 3>> counts;         ///< Raw codes per reading.
  std::vector<Eigen::Vector3d> noise;             ///< Reading − true specific force, m/s².
  Eigen::Vector3d true_force = Eigen::Vector3d::Zero();  ///< The constant true specific force, m/s².
  std::array<NoiseAxis, 3> axes;                  ///< Table 4.1 per axis.
  double count_size = 0;                          ///< δ used, m/s².
};

/// A module resting upright for `duration` s: readings, their noise (reading
/// minus the true specific force, so gravity is out of z) and Table 4.1.
/// Throws kInvalidArgument for bad options.
NoiseResult MeasureNoise(const NoiseOptions& options);

/// Settings of a move measurement.
/// Thread-safety: plain value.
struct MoveOptions {
  physics::DrivenModuleOptions module;   ///< Raw sampling (6400 Hz) and sensor.
  physics::An3397Options filter;         ///< The chain (sample_period is set from module).
  double tracker_resolution = 0.0033;    ///< LED tracker's resolution, m (appendix B).
  /// Camera frames per second (CamApp, docs/camapp.md): the tracker sees the
  /// LED only at its frames and is differentiated there, not at the AN3397 rate.
  double tracker_rate = 25;
};

/// One output row of a move, at the AN3397 sample rate.
/// Thread-safety: plain value.
struct MoveRow {
  double time = 0;  ///< s since the path started.
  Eigen::Vector3d true_position = Eigen::Vector3d::Zero();  ///< Sensor, from calibration end, m.
  /// The tracker's last frame at or before `time`: quantised to the resolution.
  Eigen::Vector3d tracker_position = Eigen::Vector3d::Zero();
  /// Central difference over the tracker's frames at that frame, m/s.
  Eigen::Vector3d tracker_velocity = Eigen::Vector3d::Zero();
  /// The velocity differentiated again over the frames, m/s².
  Eigen::Vector3d tracker_acceleration = Eigen::Vector3d::Zero();
  physics::DeadReckoningSample noise_filtered;  ///< Noise filter only (black curve).
  physics::DeadReckoningSample filtered;        ///< Window + movement end too (red curve).
};

/// A move's curves and its end-point errors.
/// Thread-safety: plain value.
struct MoveResult {
  std::string name;                 ///< The path's name.
  std::vector<MoveRow> rows;        ///< One per AN3397 sample.
  Eigen::Vector3d final_error_noise_filtered = Eigen::Vector3d::Zero();  ///< End − truth, m.
  Eigen::Vector3d final_error_filtered = Eigen::Vector3d::Zero();        ///< End − truth, m.
  int impacts = 0;                  ///< Shocks the board saw.
};

/// Drives a module along `path` and runs both filter chains on its readings.
/// The sensor frame is taken as the world frame (as the thesis did); the
/// tilting moves show what that costs. Throws what DrivenModule throws.
MoveResult MeasureMove(const physics::MotionPath& path, const MoveOptions& options);

/// The moves of 4.3.4 by name: sine, circle, go-and-return, random, drop.
std::vector<physics::MotionPath> ThesisMoves(std::uint64_t seed);

/// Table 4.1 from logged readings of a board at rest: the noise is taken
/// from each axis's mean (its true value is unknown), `count_size` m/s² per
/// count. kInvalidArgument for fewer than two readings.
NoiseResult NoiseFromLog(const std::vector<LoggedReading>& readings, double count_size = 0.0395);

/// Runs both AN3397 chains over logged readings (the first
/// filter.calibration_readings must be at rest); rows without a tracker (its
/// fields stay zero). The sample period is the log's mean reading interval ×
/// average_count. kInvalidArgument when the log is shorter than the calibration.
MoveResult FilterLog(const std::string& name, const std::vector<LoggedReading>& readings,
                     physics::An3397Options filter = physics::An3397Options());

/// Writes `text` to `path` through a temporary file and a rename, so a
/// reader never sees half a file. Throws kUnavailable naming the path.
void WriteFileAtomically(const std::filesystem::path& path, const std::string& text);

/// CSV of a noise measurement: time, codes and noise per axis.
std::string NoiseCsv(const NoiseResult& result);
/// CSV of the per-axis histograms: axis, code, value (m/s² from zero g), count.
std::string HistogramCsv(const NoiseResult& result);
/// CSV of Table 4.1, measured next to the thesis.
std::string Table41Csv(const NoiseResult& result);
/// CSV of a move: time, then per axis the tracker's, noise-filtered and
/// filtered acceleration, velocity and position, and the true position.
std::string MoveCsv(const MoveResult& result);

}  // namespace yamor::characterize
