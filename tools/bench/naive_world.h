// Bench-only baseline for issue 3: the same robot in an ODE world built the
// obvious way — one ODE body per part (every module body and every handle),
// a fixed joint for every connection, the servo hinges, dWorldStep. Contacts,
// servo controller and joint softness are copied from physics/world.cc so the
// only difference from yamor::physics::World is how rigid parts are modelled.
// Not a library: it lives beside the benchmark that compares against it.
#pragma once

#include <memory>

#include <Eigen/Geometry>

#include "physics/morphology.h"
#include "physics/world.h"

namespace yamor::bench {

/// One robot in a naive ODE world (see the file comment).
/// Thread-safety: not thread-safe; one thread at a time.
class NaiveWorld {
 public:
  /// Builds the world; every part starts where physics::World puts it.
  NaiveWorld(const physics::Morphology& morphology, const physics::WorldOptions& options);
  ~NaiveWorld();
  NaiveWorld(const NaiveWorld&) = delete;
  NaiveWorld& operator=(const NaiveWorld&) = delete;

  /// Servo set-point (rad), clamped to ±90° like physics::World.
  void SetServoTarget(int id, double angle);
  /// Powers a servo on or off; off leaves only the gearbox's back-drive
  /// friction, like physics::World::SetMotorEnabled.
  void SetMotorEnabled(int id, bool enabled);
  /// One fixed step: servos, collision, dWorldStep, divergence check.
  void Step();
  /// World position of the central module's body frame, m.
  Eigen::Vector3d CentralPosition() const;
  /// Number of ODE bodies.
  int BodyCount() const;
  /// Number of joints that are not contacts (hinges + fixed).
  int JointCount() const;
  /// True once a body state went non-finite or too fast.
  bool Diverged() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace yamor::bench
