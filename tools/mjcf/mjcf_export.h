// Exports a YaMoR morphology as a MuJoCo model (MJCF XML), for the
// simulation benchmark's MuJoCo comparison (docs/benchmarks.md).
//
// MuJoCo needs a kinematic tree: parts rigidly screwed together become one
// MuJoCo body (several box geoms, each with its own mass, so MuJoCo computes
// the same mass and inertia as ODE's summed boxes); the rigid group holding
// the central module's body is the root with a free joint; every servo is a
// hinge joint in the child group, oriented so that its joint angle is the
// servo angle of physics/module.h, with a position actuator. A servo hinge
// that would close a kinematic loop (the wheel) cannot be a tree joint and is
// left out (listed in ExportSummary::skipped_hinges).
#pragma once

#include <string>
#include <vector>

#include "physics/morphology.h"
#include "physics/world.h"

namespace yamor::mjcf {

/// How to export. The world options give step, gravity, friction, servo.
/// Thread-safety: plain value.
struct ExportOptions {
  physics::WorldOptions world;  ///< Step, gravity, friction, servo figures, drop gap.
  /// Damping of the position actuator, N·m·s/rad. The servo of physics::World
  /// is a velocity-limited P-controller enforced as a velocity constraint
  /// (commanded speed gain·error, torque up to the stall torque). MuJoCo gets
  /// kp = gain·kv and kv: below the torque limit the joint then tracks
  /// dq/dt = gain·error as ODE's motor does, the stiffer the larger kv; the
  /// speed limit is not modelled (see docs/benchmarks.md).
  double actuator_damping = 1.0;
  /// Contact softness: MuJoCo's solref time constant, s (damping ratio 1).
  /// ODE's spring-damper (physics::WorldOptions) has no exact MuJoCo
  /// counterpart; MuJoCo's default 0.02 s makes the quadruped travel within a
  /// few percent of our world at every step up to 2 ms, while a constant tied
  /// to the step (2 steps, MuJoCo's stiffest) makes the gait step-dependent.
  double contact_time_constant = 0.02;
  std::string model_name;  ///< <mujoco model=...>; default: the morphology's source stem.
  /// Modules whose servo is unpowered (the configuration's inactive modules,
  /// bridge::IsInactive): their hinge gets no actuator, only the gearbox's
  /// back-drive friction (servo.limp_friction) as MuJoCo frictionloss, as
  /// physics::World models a motor that is off. Ids must be in the morphology.
  std::vector<int> unpowered_modules;
};

/// What the export produced. Thread-safety: plain value.
struct ExportSummary {
  int bodies = 0;                   ///< MuJoCo bodies (rigid groups), root included.
  int hinges = 0;                   ///< Servo hinge joints exported.
  std::vector<int> skipped_hinges;  ///< Modules whose hinge would close a loop.
  std::vector<int> locked_servos;   ///< Modules whose body and handle are one rigid group.
};

/// The MJCF document of `morphology` (free modules are left out). Throws
/// yamor::Error kInvalidArgument for bad options (as physics::World does).
std::string ExportMjcf(const physics::Morphology& morphology, const ExportOptions& options,
                       ExportSummary* summary = nullptr);

}  // namespace yamor::mjcf
