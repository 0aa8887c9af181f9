// The ODE world of one robot: ground, gravity, contacts, the modules of a
// morphology with their servos, sensors and faults. Rigidly connected parts
// share one ODE body; the servos are hinges between those bodies.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "physics/accelerometer.h"
#include "physics/module.h"
#include "physics/morphology.h"

namespace yamor::physics {

/// How the world advances one step.
enum class StepMethod {
  /// dWorldStep: exact (Dantzig LCP), deterministic; cost grows ~cubically
  /// with the number of constraint rows (contacts + joints).
  kExact,
  /// dWorldQuickStep: iterative (projected Gauss-Seidel with over-relaxation,
  /// WorldOptions::iterations sweeps), cost roughly linear in the rows,
  /// approximate. ODE draws its constraint order from one process-wide random
  /// generator, so these steps run one at a time in the process with each
  /// world's own generator state (seeded from WorldOptions::seed) swapped in:
  /// deterministic for a seed, but serialised across threads.
  kIterative,
  /// Chooses by robot size whenever the world is built (construction, Reset,
  /// Connect, Disconnect): kExact while the world has at most
  /// WorldOptions::auto_max_exact_bodies bodies, kIterative above
  /// (docs/benchmarks.md, "Faster worlds", for the thresholds).
  kAuto,
};

/// Settings of a world (defaults documented in docs/module.md).
/// Thread-safety: plain value.
struct WorldOptions {
  double time_step = 0.002;        ///< Fixed step, s (see docs/benchmarks.md for why 2 ms).
  StepMethod step_method = StepMethod::kAuto;  ///< Solver (kAuto: by robot size).
  int iterations = 35;             ///< Iterations per step of the iterative solver, [1, 10000] (35: see docs/benchmarks.md, "Faster worlds").
  double over_relaxation = 1.3;    ///< SOR factor ω of the iterative solver, in (0, 2).
  int auto_max_exact_bodies = 16;  ///< kAuto: most bodies stepped by kExact, >= 0 (16: robots of up to 8 modules).
  double gravity = 9.81;           ///< Magnitude of gravity, m/s².
  double ground_friction = 0.6;    ///< Coulomb friction module/ground.
  double module_friction = 0.5;    ///< Coulomb friction module/module.
  double slope = 0.0;              ///< Ground slope, rad, in [0, π/2).
  double slope_direction = 0.0;    ///< Azimuth of the downhill direction, rad.
  std::uint64_t seed = 0;          ///< Seed of every random source (sensor noise, iterative order).
  double contact_stiffness = 2e5;  ///< Contact spring, N/m (→ ERP/CFM per step).
  double contact_damping = 200;    ///< Contact damper, N·s/m.
  double drop_gap = 1e-4;          ///< Height of the lowest point above the ground at start, m.
  double max_linear_speed = 50;    ///< Speed beyond which the world counts as diverged, m/s.
  double max_angular_speed = 2000; ///< Angular speed beyond which it diverged, rad/s.
  ServoSpec servo;                 ///< Servo figures shared by every module.
  AccelerometerSpec accelerometer; ///< Accelerometer model shared by every module.
};

/// Fault state of a module's motor.
enum class MotorFault {
  kNone,   ///< Works normally.
  kLimp,   ///< No torque: the handle swings freely (gear friction only).
  kStuck,  ///< Jammed at the angle it had when the fault was set.
};

/// Where a module is.
enum class ModulePresence {
  kInRobot,  ///< Connected (directly or not) to the central module.
  kLoose,    ///< In the world but not connected to the robot (it dropped away).
  kPutAway,  ///< Not in the world: a free spare or a module put away.
};

/// What the world knows about a divergence.
struct DivergenceInfo {
  bool diverged = false;       ///< The world is diverged now (Step() refuses to run).
  std::uint64_t count = 0;     ///< Divergences since construction (survives Reset()).
  std::uint64_t step = 0;      ///< Step index at which it was detected.
  int module_id = -1;          ///< A module of the first offending body (-1: unknown).
  std::string reason;          ///< Human-readable cause.
};

/// One robot in its own ODE world. Building a world from a Morphology places
/// the robot resting on flat ground (lowest point `drop_gap` above z = 0, the
/// central module above the origin), every servo at its morphology starting
/// angle (the set-point too) with its motor on. The morphology's static boxes
/// (tables, platforms) are fixed in the world and collide with the modules
/// with the ground's friction; a robot whose central module is above a box
/// starts standing on the highest such box instead of the ground.
/// Thread-safety: not thread-safe; one thread at a time may use a World (it may
/// change threads between calls). Worlds are independent: different threads may
/// each run their own World concurrently.
class World {
 public:
  /// Builds the world. Throws kInvalidArgument for bad options and for a
  /// static box that overlaps the robot where it starts (naming the box, its
  /// file and line, and the module).
  explicit World(Morphology morphology, WorldOptions options = WorldOptions());
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// The morphology the world was built from (the initial state); see
  /// CurrentMorphology() for the robot as it is now.
  const Morphology& morphology() const;
  /// The robot as it is now, validated: the initial modules, central module and
  /// orientation with the current Connections() of the robot; modules not in the
  /// robot (put away or loose) are `free` and links between loose modules are
  /// left out; each module at its initial starting angle (a free one at 0). The
  /// initial morphology itself while nothing changed. kFailedPrecondition (naming
  /// why) when that graph does not place at the starting angles (overlap, loop).
  /// Reads only; the class's one-thread-at-a-time rule applies.
  Morphology CurrentMorphology() const;
  /// The options the world was built with.
  const WorldOptions& options() const;
  /// The static boxes of the world (the morphology's), in declaration order.
  const std::vector<StaticBox>& StaticBoxes() const;
  /// The solver stepping the world now: options().step_method with kAuto
  /// resolved for the robot as it is (never kAuto).
  StepMethod ActiveStepMethod() const;

  /// Advances the world by one fixed step. Throws kFailedPrecondition when the
  /// world is diverged; a step that diverges returns normally with Diverged() set.
  void Step();
  /// Advances `count` steps (stops early if the world diverges).
  void Step(int count);
  /// Simulated time since the start or the last Reset(), s.
  double Time() const;
  /// Steps since the start or the last Reset().
  std::uint64_t StepCount() const;

  /// Restores the initial state exactly: a reset world replays bit-identically
  /// to a freshly built one. Clears faults, slope and friction changes.
  void Reset();

  /// Ids of all modules (connected and free), ascending.
  std::vector<int> ModuleIds() const;
  /// True when the module is part of the robot (connected to the central module).
  bool IsConnected(int id) const;
  /// Where the module is: in the robot, loose in the world, or put away.
  ModulePresence Presence(int id) const;
  /// The current physical links (the morphology's, changed by Connect/Disconnect).
  std::vector<MorphologyConnection> Connections() const;

  /// Connects module `from` (put away or loose, with no links) by connector
  /// `from_connector` onto `to_connector` of robot module `to`, the norths
  /// `angle_steps`·15° apart. The world is frozen meanwhile: the module is
  /// placed exactly on the connector as it is now (its own servo and set-point
  /// at 0) and joined in the same instant. When only the ground is in the way the robot
  /// is lifted first. Errors: kNotFound unknown module, kInvalidArgument
  /// self-connection, kFailedPrecondition connector in use, module in the robot
  /// or still linked, no room, or a diverged world.
  void Connect(int from, ConnectorId from_connector, int to, ConnectorId to_connector,
               int angle_steps);
  /// Removes every link of module `id`: with `put_away` it leaves the world,
  /// otherwise it stays as a loose body and drops. Parts cut off from the
  /// central module become loose. kFailedPrecondition for the central module.
  void Disconnect(int id, bool put_away = true);
  /// Id of the central module.
  int CentralModule() const;
  /// World position of the central module's body centre, m.
  Eigen::Vector3d CentralPosition() const;
  /// World orientation of the central module's body frame.
  Eigen::Quaterniond CentralOrientation() const;
  /// World pose of a module's body frame; kNotFound unknown, kFailedPrecondition put away.
  Eigen::Isometry3d ModulePose(int id) const;
  /// World pose of a module's handle frame.
  Eigen::Isometry3d HandlePose(int id) const;

  /// Sets a servo set-point (rad), clamped to ±90°. kNotFound for an unknown
  /// module, kInvalidArgument for a non-finite angle.
  void SetServoTarget(int id, double angle);
  /// The current set-point of a servo, rad.
  double ServoTarget(int id) const;
  /// The measured hinge angle of a module (0 for a free module), rad.
  double ServoAngle(int id) const;
  /// Powers a servo on or off (off: the handle is back-drivable, like kLimp).
  void SetMotorEnabled(int id, bool enabled);
  /// True when the servo is powered.
  bool MotorEnabled(int id) const;

  /// Sets a motor fault (kStuck locks the handle at its current angle).
  void SetMotorFault(int id, MotorFault fault);
  /// The motor fault of a module.
  MotorFault GetMotorFault(int id) const;
  /// Marks a module defective: its motor goes limp; the emulated firmware
  /// reads the flag to silence the module's oscillator.
  void SetModuleDefect(int id, bool defective);
  /// True when the module is marked defective.
  bool ModuleDefective(int id) const;

  /// Changes the ground friction coefficient (e.g. a new floor material).
  /// kInvalidArgument unless finite and >= 0.
  void SetGroundFriction(double mu);
  /// Current ground friction coefficient.
  double GroundFriction() const;
  /// Tilts the ground: gravity is rotated by `slope` rad towards azimuth
  /// `direction` (downhill). kInvalidArgument non-finite, kOutOfRange outside [0, π/2).
  void SetSlope(double slope, double direction = 0.0);
  /// Current gravity vector in the world frame, m/s².
  Eigen::Vector3d Gravity() const;
  /// Turns the robot upside down about its central module (rotation of π about
  /// the world x axis through it), sets it back at rest on the ground or on
  /// the highest static box under its central module.
  void TurnUpsideDown();

  /// Accelerometer of a module (MMA7260Q model, module frame, seeded noise).
  AccelerometerReading Accelerometer(int id) const;

  /// True when the world has diverged (non-finite or exploding state).
  bool Diverged() const;
  /// Details of the current or last divergence.
  const DivergenceInfo& Divergence() const;

  /// Number of ODE bodies (rigid groups) in the world.
  int BodyCount() const;
  /// Total mass of all bodies, kg.
  double TotalMass() const;
  /// Mass of the rigid body carrying a module's `part`, kg.
  double GroupMass(int id, Part part) const;
  /// Lowest point of the robot (over all collision boxes), world z, m.
  double LowestPoint() const;

  /// Test hook: writes NaNs into the velocity of the body carrying the module's
  /// body, as a diverging solver would. The next Step() finds them before ODE
  /// sees them; with `reach_ode` it hands them to ODE, whose internal checks
  /// then fail inside the step (the path of a solver blowing up). Tests only.
  void InjectNonFiniteForTesting(int id, bool reach_ode = false);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace yamor::physics
