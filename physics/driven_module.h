// A kinematically driven module: one module (no robot, no ODE) moved along a
// prescribed path of position and orientation in time, as a hand moves the
// sensor board in thesis 4.3.4, read through the accelerometer model.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "physics/accelerometer.h"

namespace yamor::physics {

/// The state of a driven module at one instant: its body frame (the body
/// box's centre and orientation, world frame, z up, ground at z = 0) and the
/// derivatives the accelerometer needs.
/// Thread-safety: plain value.
struct PathPoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      ///< Body centre, m.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      ///< Body centre, m/s.
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  ///< Body centre, m/s².
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< Body → world.
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();       ///< World frame, rad/s.
  Eigen::Vector3d angular_acceleration = Eigen::Vector3d::Zero();   ///< World frame, rad/s².
};

/// A prescribed path: the module's state as a function of time over
/// [0, duration]; outside it the module rests at the end points.
/// Thread-safety: immutable after construction; safe to share between threads.
class MotionPath {
 public:
  /// The state at time t (s), called for t in [0, duration].
  using Function = std::function<PathPoint(double)>;
  /// A named path. kInvalidArgument for a non-finite or non-positive duration
  /// or an empty function.
  MotionPath(std::string name, double duration, Function function);
  /// The path's name (e.g. "sine").
  const std::string& name() const { return name_; }
  /// Length of the path, s.
  double duration() const { return duration_; }
  /// The state at time `t` (clamped to [0, duration]).
  PathPoint At(double t) const;

 private:
  std::string name_;
  double duration_;
  Function function_;
};

/// Body-centre height of a module lying upright on the ground, m.
double RestingHeight();

/// Sine move of 4.3.4: `length` along +x while y swings one period of
/// `amplitude` (peak), after `rest` s at rest and before `rest` s at rest.
MotionPath SineMove(double amplitude = 0.10, double length = 0.25, double move_time = 2.0,
                    double rest = 1.0);
/// Circle of 4.3.4: `radius`, clockwise seen from above, back to the start.
MotionPath CircleMove(double radius = 0.05, double move_time = 2.0, double rest = 1.0);
/// Go and return of 4.3.4: `distance` along +x, a pause, back to the start.
MotionPath GoAndReturnMove(double distance = 0.10, double leg_time = 0.8, double pause = 0.5,
                           double rest = 1.0);
/// Random move in the air with tilting (4.3.4): a seeded smooth excursion
/// lifting the module at most `max_height` above its resting height, tilting
/// it up to `max_tilt` rad about a seeded horizontal axis, back to the start.
MotionPath RandomAirMove(std::uint64_t seed, double max_height = 0.10, double max_tilt = 0.6,
                         double move_time = 4.0, double rest = 1.0);
/// Drop of 4.3.4: held with its lowest point `height` above the ground,
/// released, free fall, then an impact that stops it within `contact_time` s
/// (half-sine deceleration; the ground yields by v·contact_time/2), then rest.
MotionPath DropMove(double height = 0.07, double contact_time = 0.004, double rest = 1.0,
                    double settle = 2.0);
/// Lifts the module by `lift`, turns it by π about the world x axis and sets
/// it down upside down (the test of the orientation detector).
MotionPath FlipMove(double lift = 0.06, double move_time = 2.0, double rest = 1.0);

/// Settings of a driven module.
/// Thread-safety: plain value.
struct DrivenModuleOptions {
  double sample_rate = 6400;        ///< Raw accelerometer readings per second, Hz.
  double gravity = 9.81;            ///< Magnitude of gravity (along −z), m/s².
  std::uint64_t seed = 0;           ///< Seed of the sensor noise and the shock offsets.
  int module_id = 0;                ///< Module id (part of the noise hash).
  double max_acceleration = 1000;   ///< Largest sensor acceleration a path may ask, m/s².
  double ground_tolerance = 0.003;  ///< How far a box corner may sink into the ground, m.
  AccelerometerSpec accelerometer;  ///< Sensor model.
};

/// One sample of a driven module.
/// Thread-safety: plain value.
struct DrivenSample {
  std::uint64_t index = 0;  ///< Sample index (time = index / sample_rate).
  double time = 0;          ///< s.
  PathPoint state;          ///< The prescribed body state.
  Eigen::Vector3d sensor_position = Eigen::Vector3d::Zero();      ///< World, m.
  Eigen::Vector3d sensor_velocity = Eigen::Vector3d::Zero();      ///< World, m/s.
  Eigen::Vector3d sensor_acceleration = Eigen::Vector3d::Zero();  ///< World, m/s².
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();  ///< True, module frame, m/s².
  AccelerometerReading reading;                              ///< What the sensor reads.
};

/// A module driven along a path, sampled at a fixed rate. The whole path is
/// checked at construction: every sample must be finite, keep the body box
/// above the ground (within ground_tolerance) and ask at most
/// max_acceleration of the sensor; otherwise kOutOfRange (kInvalidArgument
/// for bad options) naming the path, time and value.
/// Thread-safety: not thread-safe (the sample cursor and the sensor board's
/// offsets are mutable state); one thread at a time.
class DrivenModule {
 public:
  /// Validates `path` under `options` and starts at sample 0.
  DrivenModule(MotionPath path, DrivenModuleOptions options = DrivenModuleOptions());
  /// True once every sample up to the end of the path was read.
  bool Done() const;
  /// Reads the next sample. kOutOfRange when Done().
  DrivenSample Next();
  /// Every remaining sample.
  std::vector<DrivenSample> Run();
  /// Number of samples of the whole path.
  std::uint64_t SampleCount() const { return sample_count_; }
  /// The path.
  const MotionPath& path() const { return path_; }
  /// The options.
  const DrivenModuleOptions& options() const { return options_; }
  /// The sensor board (its offsets after shocks).
  const AccelerometerBoard& board() const { return board_; }

 private:
  DrivenSample Kinematics(std::uint64_t index) const;

  const MotionPath path_;
  const DrivenModuleOptions options_;
  std::uint64_t sample_count_ = 0;
  std::uint64_t next_ = 0;
  AccelerometerBoard board_;
};

}  // namespace yamor::physics
