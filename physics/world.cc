#include "physics/world.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include <ode/ode.h>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "physics/box_overlap.h"
#include "physics/disjoint_sets.h"
#include "physics/ode_contact.h"
#include "physics/ode_runtime.h"
#include "physics/placement.h"

namespace yamor::physics {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxPosition = 1e4;  // m: anything farther away has blown up
// A module being connected must clear every other box shrunk by this much per
// face (the mated faces themselves are 100 µm apart).
constexpr double kRoomTolerance = 5e-4;  // m

Eigen::Matrix3d ToEigen(const dReal* r) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m(i, j) = r[i * 4 + j];
  }
  return m;
}

void ToOde(const Eigen::Matrix3d& m, dMatrix3 r) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[i * 4 + j] = m(i, j);
    r[i * 4 + 3] = 0;
  }
}

Eigen::Vector3d ToEigen3(const dReal* v) { return Eigen::Vector3d(v[0], v[1], v[2]); }

std::string FormatVector(const Eigen::Vector3d& v) {
  return "(" + FormatDouble(v.x()) + ", " + FormatDouble(v.y()) + ", " + FormatDouble(v.z()) + ")";
}


void CheckFinite(double value, const char* what) {
  if (!std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument, std::string(what) + " must be finite, got " +
                                                  std::to_string(value));
  }
}

void CheckOptions(const WorldOptions& o) {
  auto positive = [](double value, const char* what) {
    CheckFinite(value, what);
    if (value <= 0) {
      throw Error(StatusCode::kInvalidArgument,
                  std::string(what) + " must be > 0, got " + std::to_string(value));
    }
  };
  auto non_negative = [](double value, const char* what) {
    CheckFinite(value, what);
    if (value < 0) {
      throw Error(StatusCode::kInvalidArgument,
                  std::string(what) + " must be >= 0, got " + std::to_string(value));
    }
  };
  positive(o.time_step, "time_step");
  if (o.step_method != StepMethod::kExact && o.step_method != StepMethod::kIterative &&
      o.step_method != StepMethod::kAuto) {
    throw Error(StatusCode::kInvalidArgument,
                "step_method " + std::to_string(static_cast<int>(o.step_method)) +
                    " is not kExact, kIterative or kAuto");
  }
  if (o.iterations < 1 || o.iterations > 10000) {
    throw Error(StatusCode::kInvalidArgument,
                "iterations must be in [1, 10000], got " + std::to_string(o.iterations));
  }
  CheckFinite(o.over_relaxation, "over_relaxation");
  if (o.over_relaxation <= 0 || o.over_relaxation >= 2) {
    throw Error(StatusCode::kInvalidArgument,
                "over_relaxation must be in (0, 2), got " + std::to_string(o.over_relaxation));
  }
  if (o.auto_max_exact_bodies < 0) {
    throw Error(StatusCode::kInvalidArgument, "auto_max_exact_bodies must be >= 0, got " +
                                                  std::to_string(o.auto_max_exact_bodies));
  }
  if (o.time_step > 0.05) {
    throw Error(StatusCode::kOutOfRange,
                "time_step " + std::to_string(o.time_step) + " s is above 0.05 s");
  }
  non_negative(o.gravity, "gravity");
  non_negative(o.ground_friction, "ground_friction");
  non_negative(o.module_friction, "module_friction");
  non_negative(o.slope, "slope");
  CheckFinite(o.slope_direction, "slope_direction");
  if (o.slope >= kPi / 2) {
    throw Error(StatusCode::kOutOfRange, "slope must be below pi/2 rad");
  }
  positive(o.contact_stiffness, "contact_stiffness");
  non_negative(o.contact_damping, "contact_damping");
  non_negative(o.drop_gap, "drop_gap");
  positive(o.max_linear_speed, "max_linear_speed");
  positive(o.max_angular_speed, "max_angular_speed");
  positive(o.servo.stall_torque, "servo.stall_torque");
  positive(o.servo.max_speed, "servo.max_speed");
  positive(o.servo.gain, "servo.gain");
  non_negative(o.servo.limp_friction, "servo.limp_friction");
  positive(o.servo.lock_torque, "servo.lock_torque");
  positive(o.servo.lock_gain, "servo.lock_gain");
  positive(o.accelerometer.count_size, "accelerometer.count_size");
  ValidateAccelerometerSpec(o.accelerometer);
}

// A static box as the overlap test sees it.
OrientedBox ToOriented(const StaticBox& box) {
  return OrientedBox{.pose = box.Pose(), .half_size = box.size / 2};
}

// Half extents of a static box's axis-aligned bounding box in the world.
Eigen::Vector3d WorldExtent(const StaticBox& box) {
  return RotationFromRollPitchYaw(box.orientation_degrees).cwiseAbs() * (box.size / 2);
}

// Highest point of a static box (over its corners), world z.
double TopOf(const StaticBox& box) { return box.position.z() + WorldExtent(box).z(); }

// True when the vertical line through (x, y) crosses the box's bounding box.
bool Above(const StaticBox& box, double x, double y) {
  const Eigen::Vector3d extent = WorldExtent(box);
  return std::abs(x - box.position.x()) <= extent.x() && std::abs(y - box.position.y()) <= extent.y();
}

// The height the robot stands on at (x, y): the top of the highest static box
// whose bounding box lies under that point, else the ground (0).
double SupportHeight(const std::vector<StaticBox>& boxes, double x, double y) {
  double height = 0.0;
  for (const StaticBox& box : boxes) {
    if (Above(box, x, y)) height = std::max(height, TopOf(box));
  }
  return height;
}

// Guards ODE's process-wide random generator used by dWorldQuickStep.
std::mutex quick_step_mutex;

// The starting state of a world's share of ODE's generator (a 32-bit linear
// congruential generator) for a seed: SplitMix64 of the seed, low 32 bits.
unsigned long OdeRandomState(std::uint64_t seed) {
  std::uint64_t z = seed + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return static_cast<unsigned long>(z & 0xffffffffULL);
}

Eigen::Vector3d GravityVector(double g, double slope, double direction) {
  return g * Eigen::Vector3d(std::sin(slope) * std::cos(direction),
                             std::sin(slope) * std::sin(direction), -std::cos(slope));
}

}  // namespace

struct World::Impl {
  struct ModuleState {
    int id = 0;
    ModulePresence presence = ModulePresence::kPutAway;
    bool simulated() const { return presence != ModulePresence::kPutAway; }
    int group[2] = {-1, -1};     // rigid group of the body and the handle part
    Eigen::Isometry3d offset[2] = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()};
    dJointID hinge = nullptr;    // null when put away or when body and handle are one rigid group
    double hinge_offset = 0;     // servo angle = hinge angle + offset
    double target = 0;
    bool motor_on = true;
    MotorFault fault = MotorFault::kNone;
    double stuck_angle = 0;
    bool defect = false;
    Eigen::Vector3d sensor_velocity_before_step = Eigen::Vector3d::Zero();
  };
  struct Group {
    dBodyID body = nullptr;
    double mass = 0;
    std::vector<std::pair<size_t, Part>> parts;  // (module index, part)
  };
  // Where a part is and how it moves, used to (re)build bodies.
  struct PartMotion {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    Eigen::Vector3d linear = Eigen::Vector3d::Zero();   // velocity of the part frame origin
    Eigen::Vector3d angular = Eigen::Vector3d::Zero();
  };

  Morphology morphology;
  WorldOptions options;

  dWorldID world = nullptr;
  // ODE's default threading implementation is one process-wide object that is
  // not safe to share between worlds stepping in different threads: each world
  // gets its own (self-threaded, i.e. it runs in the caller's thread).
  dThreadingImplementationID threading = nullptr;
  dSpaceID space = nullptr;
  dJointGroupID contacts = nullptr;
  dGeomID ground = nullptr;
  std::vector<ModuleState> modules;  // ascending id
  std::map<int, size_t> index;
  std::vector<MorphologyConnection> connections;  // current physical links
  std::vector<Group> groups;
  double ground_friction = 0;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  double contact_erp = 0;
  double contact_cfm = 0;
  std::uint64_t steps = 0;
  DivergenceInfo divergence;
  bool poisoned = false;            // ODE threw during a step: never touch its objects again
  unsigned long random_state = 0;   // this world's share of ODE's generator (kIterative)
  StepMethod active_method = StepMethod::kExact;  // step_method, kAuto resolved at Build()
  bool skip_pre_step_check = false;  // test hook: let a bad state reach ODE

  Impl(Morphology m, WorldOptions o) : morphology(std::move(m)), options(std::move(o)) {
    CheckOptions(options);
    const double h = options.time_step;
    const double denominator = h * options.contact_stiffness + options.contact_damping;
    contact_erp = h * options.contact_stiffness / denominator;
    contact_cfm = 1.0 / denominator;
    BuildInitial();
  }

  ~Impl() { Destroy(); }

  void Destroy() {
    if (world == nullptr) return;
    EnsureOdeForThisThread();
    dJointGroupDestroy(contacts);
    dSpaceDestroy(space);  // destroys the geoms (cleanup mode is on)
    dWorldDestroy(world);  // destroys bodies and joints
    if (poisoned) {
      // ODE threw out of the middle of a step and left jobs in the world's
      // threading object; freeing it trips an assertion in a destructor. Keep
      // it, reachable, for the life of the process (a few kB per event).
      Log().warn("retiring the ODE threading object of a world that failed inside ODE");
      static std::vector<dThreadingImplementationID>* const retired =
          new std::vector<dThreadingImplementationID>();
      static std::mutex retired_mutex;
      const std::lock_guard<std::mutex> lock(retired_mutex);
      retired->push_back(threading);
      poisoned = false;
    } else {
      dThreadingFreeImplementation(threading);
    }
    world = nullptr;
    threading = nullptr;
    space = nullptr;
    contacts = nullptr;
    ground = nullptr;
    groups.clear();
    for (ModuleState& m : modules) {
      m.hinge = nullptr;
      m.group[0] = m.group[1] = -1;
    }
  }

  ModuleState& State(int id) {
    const auto it = index.find(id);
    if (it == index.end()) {
      throw Error(StatusCode::kNotFound, "no module " + std::to_string(id) + " in the world");
    }
    return modules[it->second];
  }
  const ModuleState& State(int id) const { return const_cast<Impl*>(this)->State(id); }

  // A module that has bodies in the world (part of the robot or loose).
  const ModuleState& SimulatedState(int id) const {
    const ModuleState& m = State(id);
    if (!m.simulated()) {
      throw Error(StatusCode::kFailedPrecondition,
                  "module " + std::to_string(id) + " is put away (not in the world)");
    }
    return m;
  }

  // Robot = simulated modules reachable from the central one through the
  // current connections; other simulated modules are loose.
  void UpdatePresence() {
    std::vector<bool> reached(modules.size(), false);
    std::vector<size_t> stack{index.at(morphology.central())};
    reached[stack.back()] = true;
    while (!stack.empty()) {
      const int current = modules[stack.back()].id;
      stack.pop_back();
      for (const MorphologyConnection& c : connections) {
        if (c.from != current && c.to != current) continue;
        const size_t other = index.at(c.from == current ? c.to : c.from);
        if (!reached[other]) {
          reached[other] = true;
          stack.push_back(other);
        }
      }
    }
    for (size_t i = 0; i < modules.size(); ++i) {
      if (!modules[i].simulated()) continue;
      modules[i].presence = reached[i] ? ModulePresence::kInRobot : ModulePresence::kLoose;
    }
  }

  // Fresh state from the morphology: every module at its placed pose, at rest.
  void BuildInitial() {
    EnsureOdeForThisThread();
    modules.clear();
    index.clear();
    std::vector<int> ids;
    for (const MorphologyModule& m : morphology.modules()) ids.push_back(m.id);
    std::sort(ids.begin(), ids.end());
    for (int id : ids) {
      index[id] = modules.size();
      ModuleState state;
      state.id = id;
      state.presence = morphology.Module(id).free ? ModulePresence::kPutAway
                                                  : ModulePresence::kInRobot;
      modules.push_back(state);
    }
    connections = morphology.connections();
    ground_friction = options.ground_friction;
    gravity = GravityVector(options.gravity, options.slope, options.slope_direction);
    steps = 0;
    random_state = OdeRandomState(options.seed);
    divergence.diverged = false;
    divergence.step = 0;
    divergence.module_id = -1;
    divergence.reason.clear();

    // Robot frame -> world: central above the origin, lowest point at drop_gap.
    std::vector<OrientedBox> boxes;
    for (const ModuleState& m : modules) {
      if (!m.simulated()) continue;
      const auto module_boxes =
          ModuleWorldBoxes(morphology.BodyPose(m.id), morphology.Module(m.id).StartAngle());
      boxes.insert(boxes.end(), module_boxes.begin(), module_boxes.end());
    }
    // Standing on the highest static box under the central module, if any.
    const Eigen::Vector3d central = morphology.BodyPose(morphology.central()).translation();
    const double support = SupportHeight(morphology.boxes(), 0.0, 0.0);
    const Eigen::Translation3d shift(-central.x(), -central.y(),
                                     support + options.drop_gap - physics::LowestPoint(boxes));
    CheckStaticBoxesClear(shift);
    std::vector<std::array<PartMotion, 2>> motion(modules.size());
    // Every servo starts at its morphology angle and holds it (set-point).
    std::vector<double> servo(modules.size(), 0.0);
    for (size_t i = 0; i < modules.size(); ++i) {
      const double start = morphology.Module(modules[i].id).StartAngle();
      modules[i].target = start;
      if (!modules[i].simulated()) continue;
      servo[i] = start;
      const Eigen::Isometry3d body = shift * morphology.BodyPose(modules[i].id);
      motion[i][0].pose = body;
      motion[i][1].pose = PartPose(body, Part::kHandle, start);
    }
    Build(motion, servo);
  }

  // Refuses a world whose robot, placed by `shift` (robot frame -> world),
  // starts inside a static box: ODE would push the two apart violently.
  void CheckStaticBoxesClear(const Eigen::Translation3d& shift) const {
    for (const StaticBox& box : morphology.boxes()) {
      const OrientedBox obstacle = ToOriented(box);
      for (const ModuleState& m : modules) {
        if (!m.simulated()) continue;
        const auto module_boxes = ModuleWorldBoxes(shift * morphology.BodyPose(m.id),
                                                   morphology.Module(m.id).StartAngle());
        for (size_t b = 0; b < module_boxes.size(); ++b) {
          if (BoxesOverlap(obstacle, module_boxes[b], kRoomTolerance)) {
            const std::string where =
                box.line > 0 ? morphology.source() + ":" + std::to_string(box.line)
                             : morphology.source();
            throw Error(StatusCode::kInvalidArgument,
                        where + ": box \"" + box.name + "\" (size " + FormatVector(box.size) +
                            " at " + FormatVector(box.position) + ") overlaps module " +
                            std::to_string(m.id) + " (" + std::string(ModuleBoxes()[b].name) +
                            ") where the robot starts (central module above the origin, on "
                            "the highest box under it or the ground)");
          }
        }
      }
    }
  }

  // Creates the ODE world with the current connection graph; every simulated
  // module's parts are at `motion`, their hinges at `servo`.
  void Build(const std::vector<std::array<PartMotion, 2>>& motion,
             const std::vector<double>& servo) {
    EnsureOdeForThisThread();
    world = dWorldCreate();
    threading = dThreadingAllocateSelfThreadedImplementation();
    if (threading == nullptr) {
      throw Error(StatusCode::kResourceExhausted, "ODE could not allocate a threading context");
    }
    dWorldSetStepThreadingImplementation(world, dThreadingImplementationGetFunctions(threading),
                                         threading);
    dWorldSetGravity(world, gravity.x(), gravity.y(), gravity.z());
    dWorldSetERP(world, kJointErp);
    dWorldSetCFM(world, kJointCfm);
    dWorldSetQuickStepW(world, options.over_relaxation);
    dWorldSetAutoDisableFlag(world, 0);
    dWorldSetQuickStepNumIterations(world, options.iterations);
    space = dSimpleSpaceCreate(nullptr);
    contacts = dJointGroupCreate(0);
    ground = dCreatePlane(space, 0, 0, 1, 0);
    dGeomSetData(ground, nullptr);
    // Static boxes: geoms without a body, tagged like the ground (its friction).
    for (const StaticBox& box : morphology.boxes()) {
      dGeomID geom = dCreateBox(space, box.size.x(), box.size.y(), box.size.z());
      dGeomSetPosition(geom, box.position.x(), box.position.y(), box.position.z());
      dMatrix3 rotation;
      ToOde(box.Pose().linear(), rotation);
      dGeomSetRotation(geom, rotation);
      dGeomSetData(geom, nullptr);
    }

    // Rigid groups: union-find over parts, merged through every connection.
    DisjointSets sets(modules.size() * 2);
    auto part_index = [&](int id, ConnectorId connector) {
      return index.at(id) * 2 + static_cast<size_t>(ConnectorFrameOf(connector).part);
    };
    for (const MorphologyConnection& c : connections) {
      sets.Union(part_index(c.from, c.from_connector), part_index(c.to, c.to_connector));
    }
    std::map<size_t, int> group_of_root;
    groups.clear();
    for (size_t i = 0; i < modules.size(); ++i) {
      if (!modules[i].simulated()) continue;
      for (int p = 0; p < 2; ++p) {
        const size_t root = sets.Find(i * 2 + static_cast<size_t>(p));
        auto [it, inserted] = group_of_root.emplace(root, static_cast<int>(groups.size()));
        if (inserted) groups.emplace_back();
        groups[static_cast<size_t>(it->second)].parts.emplace_back(i, static_cast<Part>(p));
        modules[i].group[p] = it->second;
      }
    }

    for (size_t g = 0; g < groups.size(); ++g) {
      Group& group = groups[g];
      dMass total;
      dMassSetZero(&total);
      for (const auto& [mi, part] : group.parts) {
        const Eigen::Isometry3d& part_pose = motion[mi][static_cast<size_t>(part)].pose;
        for (const ModuleBox& box : ModuleBoxes()) {
          if (box.part != part) continue;
          dMass mass;
          dMassSetBoxTotal(&mass, box.mass, box.size.x(), box.size.y(), box.size.z());
          dMatrix3 rotation;
          ToOde(part_pose.linear(), rotation);
          dMassRotate(&mass, rotation);
          const Eigen::Vector3d centre = part_pose * box.center;
          dMassTranslate(&mass, centre.x(), centre.y(), centre.z());
          dMassAdd(&total, &mass);
        }
      }
      const Eigen::Vector3d com(total.c[0], total.c[1], total.c[2]);
      dMassTranslate(&total, -com.x(), -com.y(), -com.z());
      group.mass = total.mass;
      group.body = dBodyCreate(world);
      dBodySetMass(group.body, &total);
      dBodySetPosition(group.body, com.x(), com.y(), com.z());
      for (const auto& [mi, part] : group.parts) {
        const PartMotion& pm = motion[mi][static_cast<size_t>(part)];
        Eigen::Isometry3d body_pose = Eigen::Isometry3d::Identity();
        body_pose.translation() = com;
        modules[mi].offset[static_cast<int>(part)] = body_pose.inverse() * pm.pose;
        for (const ModuleBox& box : ModuleBoxes()) {
          if (box.part != part) continue;
          dGeomID geom = dCreateBox(space, box.size.x(), box.size.y(), box.size.z());
          dGeomSetBody(geom, group.body);
          const Eigen::Vector3d centre = pm.pose * box.center;
          dGeomSetOffsetWorldPosition(geom, centre.x(), centre.y(), centre.z());
          dMatrix3 rotation;
          ToOde(pm.pose.linear(), rotation);
          dGeomSetOffsetWorldRotation(geom, rotation);
          dGeomSetData(geom, reinterpret_cast<void*>(
                                 static_cast<uintptr_t>(mi * 2 + static_cast<size_t>(part) + 1)));
        }
      }
      // Velocity of the group from its first part (all parts move rigidly).
      const auto& [mi0, part0] = group.parts.front();
      const PartMotion& first = motion[mi0][static_cast<size_t>(part0)];
      const Eigen::Vector3d linear =
          first.linear + first.angular.cross(com - first.pose.translation());
      dBodySetLinearVel(group.body, linear.x(), linear.y(), linear.z());
      dBodySetAngularVel(group.body, first.angular.x(), first.angular.y(), first.angular.z());
    }

    for (size_t i = 0; i < modules.size(); ++i) {
      ModuleState& m = modules[i];
      m.hinge = nullptr;
      m.hinge_offset = servo[i];
      if (!m.simulated()) continue;
      if (m.group[0] == m.group[1]) {
        Log().warn("module {}: body and handle are rigidly connected; its servo cannot move", m.id);
        continue;
      }
      const Eigen::Isometry3d& body = motion[i][0].pose;
      const Eigen::Vector3d anchor = body * HingePivot();
      // ODE measures the angle of body1 relative to body2 about the axis; with
      // body1 = body and the axis reversed, it is the handle's angle relative
      // to the body about HingeAxis(), as HandleInBody() defines it.
      const Eigen::Vector3d axis = -(body.linear() * HingeAxis());
      m.hinge = dJointCreateHinge(world, nullptr);
      dJointAttach(m.hinge, groups[static_cast<size_t>(m.group[0])].body,
                   groups[static_cast<size_t>(m.group[1])].body);
      dJointSetHingeAnchor(m.hinge, anchor.x(), anchor.y(), anchor.z());
      dJointSetHingeAxis(m.hinge, axis.x(), axis.y(), axis.z());
      // Stops in the joint's own angle (zero at creation); ODE wants [-π, π].
      dJointSetHingeParam(m.hinge, dParamLoStop,
                          std::max(-kPi, -module::kServoLimit - m.hinge_offset));
      dJointSetHingeParam(m.hinge, dParamHiStop,
                          std::min(kPi, module::kServoLimit - m.hinge_offset));
      dJointSetHingeParam(m.hinge, dParamFMax, 0);
    }
    active_method = options.step_method;
    if (active_method == StepMethod::kAuto) {
      active_method = static_cast<int>(groups.size()) <= options.auto_max_exact_bodies
                          ? StepMethod::kExact
                          : StepMethod::kIterative;
    }
    RecordSensorVelocities();
  }

  Eigen::Isometry3d BodyPoseOfGroup(int g) const {
    const dBodyID body = groups[static_cast<size_t>(g)].body;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = ToEigen(dBodyGetRotation(body));
    pose.translation() = ToEigen3(dBodyGetPosition(body));
    return pose;
  }

  Eigen::Isometry3d PartWorldPose(const ModuleState& m, Part part) const {
    const int p = static_cast<int>(part);
    return BodyPoseOfGroup(m.group[p]) * m.offset[p];
  }

  double ServoAngleOf(const ModuleState& m) const {
    if (m.hinge == nullptr) return m.simulated() ? m.hinge_offset : 0.0;
    return dJointGetHingeAngle(m.hinge) + m.hinge_offset;
  }

  Eigen::Vector3d SensorVelocity(const ModuleState& m) const {
    const Eigen::Vector3d point = PartWorldPose(m, Part::kBody) * module::kSensorPosition;
    dVector3 velocity;
    dBodyGetPointVel(groups[static_cast<size_t>(m.group[0])].body, point.x(), point.y(), point.z(),
                     velocity);
    return ToEigen3(velocity);
  }

  void RecordSensorVelocities() {
    for (ModuleState& m : modules) {
      if (m.simulated()) m.sensor_velocity_before_step = SensorVelocity(m);
    }
  }

  void ApplyServos() {
    const ServoSpec& s = options.servo;
    for (ModuleState& m : modules) {
      if (m.hinge == nullptr) continue;
      const double angle = ServoAngleOf(m);
      double velocity = 0;
      double torque = s.limp_friction;
      if (m.fault == MotorFault::kStuck) {
        // A jammed gearbox holds with or without power (the driver switches a
        // defective motor off, and a dead module's gears stay jammed too).
        velocity = s.lock_gain * (m.stuck_angle - angle);
        torque = s.lock_torque;
      } else if (m.defect || !m.motor_on || m.fault == MotorFault::kLimp) {
        // Unpowered: only the gearbox friction resists.
      } else {
        velocity = std::clamp(s.gain * (m.target - angle), -s.max_speed, s.max_speed);
        torque = s.stall_torque;
      }
      dJointSetHingeParam(m.hinge, dParamVel, velocity);
      dJointSetHingeParam(m.hinge, dParamFMax, torque);
    }
  }

  static void NearCallback(void* data, dGeomID a, dGeomID b) {
    auto* self = static_cast<Impl*>(data);
    const auto tag_a = reinterpret_cast<uintptr_t>(dGeomGetData(a));
    const auto tag_b = reinterpret_cast<uintptr_t>(dGeomGetData(b));
    // A module's handle turns about its own body: never collide the two.
    if (tag_a != 0 && tag_b != 0 && (tag_a - 1) / 2 == (tag_b - 1) / 2) return;
    // The ground and static boxes never move: nothing to solve between them.
    if (dGeomGetBody(a) == nullptr && dGeomGetBody(b) == nullptr) return;
    const bool with_ground = tag_a == 0 || tag_b == 0;
    AddContactJoints(self->world, self->contacts, a, b,
                     with_ground ? self->ground_friction : self->options.module_friction,
                     self->contact_erp, self->contact_cfm);
  }

  void MarkDiverged(int module_id, const std::string& reason) {
    divergence.diverged = true;
    ++divergence.count;
    divergence.step = steps;
    divergence.module_id = module_id;
    divergence.reason = reason;
    Log().warn("world diverged at step {} (module {}): {}", steps, module_id, reason);
  }

  // The module whose body box belongs to the group (a group holds at most a
  // few handles besides), else the module of its first part.
  int RepresentativeModule(const Group& group) const {
    for (const auto& [mi, part] : group.parts) {
      if (part == Part::kBody) return modules[mi].id;
    }
    return modules[group.parts.front().first].id;
  }

  // Checks every body after a step (or before one, for non-finite values that
  // must never reach ODE); marks the world diverged on the first bad body.
  void CheckDivergence(bool finite_only = false) {
    for (const Group& group : groups) {
      const Eigen::Vector3d p = ToEigen3(dBodyGetPosition(group.body));
      const Eigen::Vector3d v = ToEigen3(dBodyGetLinearVel(group.body));
      const Eigen::Vector3d w = ToEigen3(dBodyGetAngularVel(group.body));
      const dReal* q = dBodyGetQuaternion(group.body);
      const bool finite = p.allFinite() && v.allFinite() && w.allFinite() &&
                          std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) &&
                          std::isfinite(q[3]);
      std::string reason;
      if (!finite) {
        reason = "non-finite body state";
      } else if (finite_only) {
        continue;
      } else if (v.norm() > options.max_linear_speed) {
        reason = "linear speed " + std::to_string(v.norm()) + " m/s";
      } else if (w.norm() > options.max_angular_speed) {
        reason = "angular speed " + std::to_string(w.norm()) + " rad/s";
      } else if (p.cwiseAbs().maxCoeff() > kMaxPosition) {
        reason = "body beyond " + std::to_string(kMaxPosition) + " m";
      }
      if (!reason.empty()) {
        MarkDiverged(RepresentativeModule(group), reason);
        return;
      }
    }
  }

  void Step() {
    EnsureOdeForThisThread();
    if (divergence.diverged) {
      throw Error(StatusCode::kFailedPrecondition,
                  "world diverged at step " + std::to_string(divergence.step) + " (" +
                      divergence.reason + "); Reset() it first");
    }
    if (!skip_pre_step_check) {
      CheckDivergence(/*finite_only=*/true);
      if (divergence.diverged) return;
    }
    skip_pre_step_check = false;
    ApplyServos();
    RecordSensorVelocities();
    try {
      dSpaceCollide(space, this, &NearCallback);
      if (active_method == StepMethod::kExact) {
        dWorldStep(world, options.time_step);
      } else {
        std::lock_guard<std::mutex> lock(quick_step_mutex);
        dRandSetSeed(random_state);
        dWorldQuickStep(world, options.time_step);
        random_state = dRandGetSeed();
      }
    } catch (const OdeFailure& failure) {
      poisoned = true;
      ++steps;
      MarkDiverged(-1, failure.what());
      return;
    }
    dJointGroupEmpty(contacts);
    ++steps;
    CheckDivergence();
  }

  // Current pose and velocity of every simulated part and every servo angle.
  void Snapshot(std::vector<std::array<PartMotion, 2>>* motion, std::vector<double>* servo) const {
    motion->assign(modules.size(), {});
    servo->assign(modules.size(), 0.0);
    for (size_t i = 0; i < modules.size(); ++i) {
      const ModuleState& m = modules[i];
      if (!m.simulated()) continue;
      (*servo)[i] = ServoAngleOf(m);
      for (int p = 0; p < 2; ++p) {
        (*motion)[i][static_cast<size_t>(p)] = MotionOf(m.group[p], PartWorldPose(m, Part(p)));
      }
    }
  }

  // Rigid motion of group `g` expressed at a frame `pose` moving with it.
  PartMotion MotionOf(int g, const Eigen::Isometry3d& pose) const {
    const dBodyID body = groups[static_cast<size_t>(g)].body;
    PartMotion motion;
    motion.pose = pose;
    dVector3 velocity;
    const Eigen::Vector3d origin = pose.translation();
    dBodyGetPointVel(body, origin.x(), origin.y(), origin.z(), velocity);
    motion.linear = ToEigen3(velocity);
    motion.angular = ToEigen3(dBodyGetAngularVel(body));
    return motion;
  }

  void Rebuild(const std::vector<std::array<PartMotion, 2>>& motion,
               const std::vector<double>& servo) {
    Destroy();
    Build(motion, servo);
  }

  void CheckCanReconfigure() const {
    if (divergence.diverged) {
      throw Error(StatusCode::kFailedPrecondition,
                  "world diverged at step " + std::to_string(divergence.step) +
                      "; Reset() it before reconfiguring");
    }
  }

  bool ConnectorUsed(int id, ConnectorId connector) const {
    for (const MorphologyConnection& c : connections) {
      if ((c.from == id && c.from_connector == connector) ||
          (c.to == id && c.to_connector == connector)) {
        return true;
      }
    }
    return false;
  }

  void Connect(int from, ConnectorId from_connector, int to, ConnectorId to_connector,
               int angle_steps) {
    EnsureOdeForThisThread();
    const std::string what = "connect " + std::to_string(from) + "." +
                             std::string(ConnectorName(from_connector)) + " to " +
                             std::to_string(to) + "." + std::string(ConnectorName(to_connector));
    const ModuleState& source = State(from);
    const ModuleState& target = State(to);
    if (from == to) {
      throw Error(StatusCode::kInvalidArgument, what + ": a module cannot connect to itself");
    }
    CheckCanReconfigure();
    if (target.presence != ModulePresence::kInRobot) {
      throw Error(StatusCode::kFailedPrecondition,
                  what + ": module " + std::to_string(to) + " is not part of the robot");
    }
    if (source.presence == ModulePresence::kInRobot) {
      throw Error(StatusCode::kFailedPrecondition,
                  what + ": module " + std::to_string(from) +
                      " is part of the robot; disconnect it first");
    }
    for (const MorphologyConnection& c : connections) {
      if (c.from == from || c.to == from) {
        throw Error(StatusCode::kFailedPrecondition,
                    what + ": module " + std::to_string(from) +
                        " is still connected to another loose module; disconnect it first");
      }
    }
    if (ConnectorUsed(to, to_connector)) {
      throw Error(StatusCode::kFailedPrecondition,
                  what + ": connector " + std::string(ConnectorName(to_connector)) +
                      " of module " + std::to_string(to) + " is already used");
    }
    const int steps_normalised = ((angle_steps % module::kConnectionAngleSteps) +
                                  module::kConnectionAngleSteps) %
                                 module::kConnectionAngleSteps;

    // Frozen world: read the state, place the module exactly on the target
    // connector as it is now (servo at its current angle), the new module's
    // servo at 0 (thesis 5.4.2).
    std::vector<std::array<PartMotion, 2>> motion;
    std::vector<double> servo;
    Snapshot(&motion, &servo);
    const size_t si = index.at(from);
    const size_t ti = index.at(to);
    const Eigen::Isometry3d body = MateBodyPose(motion[ti][0].pose, servo[ti], to_connector,
                                                from_connector, 0.0, steps_normalised);
    const int carrier = target.group[static_cast<int>(ConnectorFrameOf(to_connector).part)];
    motion[si][0] = MotionOf(carrier, body);
    motion[si][1] = MotionOf(carrier, PartPose(body, Part::kHandle, 0.0));
    servo[si] = 0.0;

    // Only the ground in the way: lift the whole robot (and the newcomer).
    std::vector<OrientedBox> newcomer = ModuleWorldBoxes(body, 0.0);
    const double lowest = physics::LowestPoint(newcomer);
    double lift = 0;
    if (lowest < 0) {
      lift = options.drop_gap - lowest;
      for (size_t i = 0; i < modules.size(); ++i) {
        if (modules[i].presence != ModulePresence::kInRobot && i != si) continue;
        for (PartMotion& part : motion[i]) part.pose.translation().z() += lift;
      }
      newcomer = ModuleWorldBoxes(motion[si][0].pose, 0.0);
    }
    // Room: the newcomer against every static box, every simulated module;
    // after a lift, the robot against loose modules too.
    for (const StaticBox& obstacle : morphology.boxes()) {
      for (size_t a = 0; a < newcomer.size(); ++a) {
        if (BoxesOverlap(newcomer[a], ToOriented(obstacle), kRoomTolerance)) {
          throw Error(StatusCode::kFailedPrecondition,
                      what + ": no room, module " + std::to_string(from) + " (" +
                          std::string(ModuleBoxes()[a].name) + ") would overlap box \"" +
                          obstacle.name + "\"");
        }
      }
    }
    for (size_t i = 0; i < modules.size(); ++i) {
      if (i == si || !modules[i].simulated()) continue;
      const auto boxes = ModuleWorldBoxes(motion[i][0].pose, servo[i]);
      for (size_t a = 0; a < newcomer.size(); ++a) {
        for (size_t b = 0; b < boxes.size(); ++b) {
          if (BoxesOverlap(newcomer[a], boxes[b], kRoomTolerance)) {
            throw Error(StatusCode::kFailedPrecondition,
                        what + ": no room, module " + std::to_string(from) + " (" +
                            std::string(ModuleBoxes()[a].name) + ") would overlap module " +
                            std::to_string(modules[i].id) + " (" +
                            std::string(ModuleBoxes()[b].name) + ")");
          }
        }
      }
      if (lift > 0 && modules[i].presence == ModulePresence::kLoose) {
        for (size_t j = 0; j < modules.size(); ++j) {
          if (modules[j].presence != ModulePresence::kInRobot) continue;
          for (const OrientedBox& r : ModuleWorldBoxes(motion[j][0].pose, servo[j])) {
            for (const OrientedBox& l : boxes) {
              if (BoxesOverlap(r, l, kRoomTolerance)) {
                throw Error(StatusCode::kFailedPrecondition,
                            what + ": no room to lift the robot, module " +
                                std::to_string(modules[j].id) + " would hit loose module " +
                                std::to_string(modules[i].id));
              }
            }
          }
        }
      }
    }

    MorphologyConnection connection;
    connection.from = from;
    connection.from_connector = from_connector;
    connection.to = to;
    connection.to_connector = to_connector;
    connection.angle_steps = steps_normalised;
    connections.push_back(connection);
    modules[si].presence = ModulePresence::kLoose;  // simulated from now on
    // Placed at servo 0, it holds 0 until told otherwise: a set-point left
    // from before it was put away would swing it round on arrival.
    modules[si].target = 0.0;
    UpdatePresence();
    Rebuild(motion, servo);
    Log().info("connected module {} ({}) to module {} ({}) at {} deg{}", from,
               ConnectorName(from_connector), to, ConnectorName(to_connector),
               steps_normalised * 15, lift > 0 ? " after lifting the robot" : "");
  }

  void Disconnect(int id, bool put_away) {
    EnsureOdeForThisThread();
    ModuleState& m = State(id);
    if (id == morphology.central()) {
      throw Error(StatusCode::kFailedPrecondition,
                  "module " + std::to_string(id) + " is the central module and cannot be removed");
    }
    CheckCanReconfigure();
    if (!m.simulated()) {
      throw Error(StatusCode::kFailedPrecondition,
                  "module " + std::to_string(id) + " is already put away");
    }
    std::vector<std::array<PartMotion, 2>> motion;
    std::vector<double> servo;
    Snapshot(&motion, &servo);
    std::erase_if(connections,
                  [id](const MorphologyConnection& c) { return c.from == id || c.to == id; });
    m.presence = put_away ? ModulePresence::kPutAway : ModulePresence::kLoose;
    UpdatePresence();
    Rebuild(motion, servo);
    Log().info("disconnected module {}{}", id, put_away ? " and put it away" : "");
  }

  double LowestPoint() const {
    double lowest = std::numeric_limits<double>::infinity();
    for (const Group& group : groups) {
      for (dGeomID geom = dBodyGetFirstGeom(group.body); geom != nullptr;
           geom = dBodyGetNextGeom(geom)) {
        dVector3 lengths;
        dGeomBoxGetLengths(geom, lengths);
        OrientedBox box;
        box.pose = Eigen::Isometry3d::Identity();
        box.pose.linear() = ToEigen(dGeomGetRotation(geom));
        box.pose.translation() = ToEigen3(dGeomGetPosition(geom));
        box.half_size = ToEigen3(lengths) / 2;
        lowest = std::min(lowest, physics::LowestPoint({box}));
      }
    }
    return lowest;
  }
};

World::World(Morphology morphology, WorldOptions options)
    : impl_(std::make_unique<Impl>(std::move(morphology), std::move(options))) {}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

const Morphology& World::morphology() const { return impl_->morphology; }

Morphology World::CurrentMorphology() const {
  const Impl& w = *impl_;
  const Morphology& initial = w.morphology;
  auto in_robot = [&w](int id) { return w.State(id).presence == ModulePresence::kInRobot; };
  auto same_link = [](const MorphologyConnection& a, const MorphologyConnection& b) {
    return a.from == b.from && a.from_connector == b.from_connector && a.to == b.to &&
           a.to_connector == b.to_connector && a.angle_steps == b.angle_steps;
  };
  bool unchanged = w.connections.size() == initial.connections().size();
  for (size_t i = 0; unchanged && i < w.connections.size(); ++i) {
    unchanged = same_link(w.connections[i], initial.connections()[i]);
  }
  for (const MorphologyModule& m : initial.modules()) {
    unchanged = unchanged && m.free == !in_robot(m.id);
  }
  if (unchanged) return initial;

  std::vector<MorphologyModule> modules;
  modules.reserve(initial.modules().size());
  for (const MorphologyModule& m : initial.modules()) {
    MorphologyModule current = m;
    current.line = 0;
    current.free = !in_robot(m.id);
    if (current.free) current.angle_degrees = 0.0;  // a spare takes no angle
    modules.push_back(current);
  }
  // A link with one end in the robot has both there; links among loose
  // modules are not part of the robot.
  std::vector<MorphologyConnection> connections;
  for (const MorphologyConnection& c : w.connections) {
    if (!in_robot(c.from)) continue;
    MorphologyConnection current = c;
    current.line = 0;
    connections.push_back(current);
  }
  try {
    return Morphology::Build(initial.central(), std::move(modules), std::move(connections),
                             initial.orientation_degrees(), initial.source() + ", reconfigured",
                             initial.boxes());
  } catch (const Error& e) {
    throw Error(StatusCode::kFailedPrecondition,
                std::string("the robot as it is now has no valid morphology at its starting "
                            "angles: ") +
                    e.what());
  }
}

const WorldOptions& World::options() const { return impl_->options; }

const std::vector<StaticBox>& World::StaticBoxes() const { return impl_->morphology.boxes(); }
StepMethod World::ActiveStepMethod() const { return impl_->active_method; }

void World::Step() { impl_->Step(); }

void World::Step(int count) {
  for (int i = 0; i < count && !impl_->divergence.diverged; ++i) impl_->Step();
}

double World::Time() const { return static_cast<double>(impl_->steps) * impl_->options.time_step; }
std::uint64_t World::StepCount() const { return impl_->steps; }

void World::Reset() {
  impl_->Destroy();
  impl_->BuildInitial();
}

std::vector<int> World::ModuleIds() const {
  std::vector<int> ids;
  for (const auto& m : impl_->modules) ids.push_back(m.id);
  return ids;
}

bool World::IsConnected(int id) const {
  return impl_->State(id).presence == ModulePresence::kInRobot;
}

ModulePresence World::Presence(int id) const { return impl_->State(id).presence; }

std::vector<MorphologyConnection> World::Connections() const { return impl_->connections; }

void World::Connect(int from, ConnectorId from_connector, int to, ConnectorId to_connector,
                    int angle_steps) {
  impl_->Connect(from, from_connector, to, to_connector, angle_steps);
}

void World::Disconnect(int id, bool put_away) { impl_->Disconnect(id, put_away); }
int World::CentralModule() const { return impl_->morphology.central(); }

Eigen::Vector3d World::CentralPosition() const { return ModulePose(CentralModule()).translation(); }

Eigen::Quaterniond World::CentralOrientation() const {
  return Eigen::Quaterniond(ModulePose(CentralModule()).linear());
}

Eigen::Isometry3d World::ModulePose(int id) const {
  return impl_->PartWorldPose(impl_->SimulatedState(id), Part::kBody);
}

Eigen::Isometry3d World::HandlePose(int id) const {
  return impl_->PartWorldPose(impl_->SimulatedState(id), Part::kHandle);
}

void World::SetServoTarget(int id, double angle) {
  Impl::ModuleState& m = impl_->State(id);
  if (!std::isfinite(angle)) {
    throw Error(StatusCode::kInvalidArgument,
                "servo target of module " + std::to_string(id) + " must be finite, got " +
                    std::to_string(angle));
  }
  m.target = std::clamp(angle, -module::kServoLimit, module::kServoLimit);
}

double World::ServoTarget(int id) const { return impl_->State(id).target; }

double World::ServoAngle(int id) const {
  EnsureOdeForThisThread();
  return impl_->ServoAngleOf(impl_->State(id));
}

void World::SetMotorEnabled(int id, bool enabled) { impl_->State(id).motor_on = enabled; }
bool World::MotorEnabled(int id) const { return impl_->State(id).motor_on; }

void World::SetMotorFault(int id, MotorFault fault) {
  EnsureOdeForThisThread();
  Impl::ModuleState& m = impl_->State(id);
  m.fault = fault;
  if (fault == MotorFault::kStuck) m.stuck_angle = impl_->ServoAngleOf(m);
}

MotorFault World::GetMotorFault(int id) const { return impl_->State(id).fault; }

void World::SetModuleDefect(int id, bool defective) { impl_->State(id).defect = defective; }
bool World::ModuleDefective(int id) const { return impl_->State(id).defect; }

void World::SetGroundFriction(double mu) {
  if (!std::isfinite(mu) || mu < 0) {
    throw Error(StatusCode::kInvalidArgument,
                "ground friction must be finite and >= 0, got " + std::to_string(mu));
  }
  impl_->ground_friction = mu;
}

double World::GroundFriction() const { return impl_->ground_friction; }

void World::SetSlope(double slope, double direction) {
  if (!std::isfinite(slope) || !std::isfinite(direction)) {
    throw Error(StatusCode::kInvalidArgument, "slope and direction must be finite");
  }
  if (slope < 0 || slope >= kPi / 2) {
    throw Error(StatusCode::kOutOfRange,
                "slope " + std::to_string(slope) + " rad is outside [0, pi/2)");
  }
  EnsureOdeForThisThread();
  impl_->gravity = GravityVector(impl_->options.gravity, slope, direction);
  dWorldSetGravity(impl_->world, impl_->gravity.x(), impl_->gravity.y(), impl_->gravity.z());
}

Eigen::Vector3d World::Gravity() const { return impl_->gravity; }

void World::TurnUpsideDown() {
  EnsureOdeForThisThread();
  const Eigen::Vector3d pivot = CentralPosition();
  const Eigen::Matrix3d flip = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (const Impl::Group& group : impl_->groups) {
    const Eigen::Vector3d p = ToEigen3(dBodyGetPosition(group.body));
    const Eigen::Vector3d moved = pivot + flip * (p - pivot);
    dMatrix3 rotation;
    ToOde(flip * ToEigen(dBodyGetRotation(group.body)), rotation);
    dBodySetPosition(group.body, moved.x(), moved.y(), moved.z());
    dBodySetRotation(group.body, rotation);
    dBodySetLinearVel(group.body, 0, 0, 0);
    dBodySetAngularVel(group.body, 0, 0, 0);
  }
  // Back at rest on what is under the central module: a static box or the ground.
  const double support = SupportHeight(impl_->morphology.boxes(), pivot.x(), pivot.y());
  const double lift = support + impl_->options.drop_gap - impl_->LowestPoint();
  for (const Impl::Group& group : impl_->groups) {
    const dReal* p = dBodyGetPosition(group.body);
    dBodySetPosition(group.body, p[0], p[1], p[2] + lift);
  }
  impl_->RecordSensorVelocities();
}

AccelerometerReading World::Accelerometer(int id) const {
  EnsureOdeForThisThread();
  const Impl::ModuleState& m = impl_->SimulatedState(id);
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();
  if (impl_->steps > 0) {
    acceleration = (impl_->SensorVelocity(m) - m.sensor_velocity_before_step) /
                   impl_->options.time_step;
  }
  const Eigen::Matrix3d rotation = impl_->PartWorldPose(m, Part::kBody).linear();
  const Eigen::Vector3d specific_force = rotation.transpose() * (acceleration - impl_->gravity);
  return SampleAccelerometer(specific_force, impl_->options.seed, id, impl_->steps,
                             impl_->options.accelerometer);
}

bool World::Diverged() const { return impl_->divergence.diverged; }
const DivergenceInfo& World::Divergence() const { return impl_->divergence; }

int World::BodyCount() const { return static_cast<int>(impl_->groups.size()); }

double World::TotalMass() const {
  double total = 0;
  for (const auto& group : impl_->groups) total += group.mass;
  return total;
}

double World::GroupMass(int id, Part part) const {
  const Impl::ModuleState& m = impl_->SimulatedState(id);
  return impl_->groups[static_cast<size_t>(m.group[static_cast<int>(part)])].mass;
}

double World::LowestPoint() const {
  EnsureOdeForThisThread();
  return impl_->LowestPoint();
}

void World::InjectNonFiniteForTesting(int id, bool reach_ode) {
  EnsureOdeForThisThread();
  const Impl::ModuleState& m = impl_->SimulatedState(id);
  const dBodyID body = impl_->groups[static_cast<size_t>(m.group[0])].body;
  dBodySetLinearVel(body, std::nan(""), 0, 0);
  dBodySetAngularVel(body, 0, std::nan(""), 0);
  impl_->skip_pre_step_check = reach_ode;
}

}  // namespace yamor::physics
