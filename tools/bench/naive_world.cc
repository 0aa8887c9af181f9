#include "tools/bench/naive_world.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <vector>

#include <ode/ode.h>

#include "common/status.h"
#include "physics/module.h"
#include "physics/ode_contact.h"
#include "physics/ode_runtime.h"

namespace yamor::bench {
namespace {

using physics::ModuleBox;
using physics::kJointCfm;
using physics::kJointErp;
using physics::Part;

// Same frame conversion as physics/world.cc.

void ToOde(const Eigen::Matrix3d& m, dMatrix3 r) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[i * 4 + j] = m(i, j);
    r[i * 4 + 3] = 0;
  }
}

Eigen::Matrix3d FromOde(const dReal* r) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m(i, j) = r[i * 4 + j];
  }
  return m;
}

}  // namespace

struct NaiveWorld::Impl {
  struct Module {
    int id = 0;
    dBodyID part[2] = {nullptr, nullptr};       // body, handle
    Eigen::Vector3d com[2];                      // centre of mass in the part frame
    dJointID hinge = nullptr;
    double start = 0;   // servo angle at creation (the hinge's own angle is 0 there)
    double target = 0;
    bool motor_on = true;
  };

  physics::WorldOptions options;
  int central = 0;
  dWorldID world = nullptr;
  dSpaceID space = nullptr;
  dJointGroupID contacts = nullptr;
  std::vector<Module> modules;
  std::map<int, size_t> index;
  int joints = 0;
  bool diverged = false;
  double contact_erp = 0;
  double contact_cfm = 0;

  Impl(const physics::Morphology& morphology, const physics::WorldOptions& o) : options(o) {
    // Start exactly where the real world starts (same placement code).
    const physics::World reference(morphology, options);
    physics::EnsureOdeForThisThread();
    central = morphology.central();
    const double h = options.time_step;
    const double denominator = h * options.contact_stiffness + options.contact_damping;
    contact_erp = h * options.contact_stiffness / denominator;
    contact_cfm = 1.0 / denominator;

    world = dWorldCreate();
    const Eigen::Vector3d g = reference.Gravity();
    dWorldSetGravity(world, g.x(), g.y(), g.z());
    dWorldSetERP(world, kJointErp);
    dWorldSetCFM(world, kJointCfm);
    dWorldSetAutoDisableFlag(world, 0);
    space = dHashSpaceCreate(nullptr);
    dHashSpaceSetLevels(space, -5, 1);
    contacts = dJointGroupCreate(0);
    dGeomSetData(dCreatePlane(space, 0, 0, 1, 0), nullptr);

    for (const physics::MorphologyModule& mm : morphology.modules()) {
      if (mm.free) continue;
      Module m;
      m.id = mm.id;
      const size_t mi = modules.size();
      for (int p = 0; p < 2; ++p) {
        const Part part = static_cast<Part>(p);
        const Eigen::Isometry3d pose =
            part == Part::kBody ? reference.ModulePose(mm.id) : reference.HandlePose(mm.id);
        dMass total;
        dMassSetZero(&total);
        for (const ModuleBox& box : physics::ModuleBoxes()) {
          if (box.part != part) continue;
          dMass mass;
          dMassSetBoxTotal(&mass, box.mass, box.size.x(), box.size.y(), box.size.z());
          dMassTranslate(&mass, box.center.x(), box.center.y(), box.center.z());
          dMassAdd(&total, &mass);
        }
        m.com[p] = Eigen::Vector3d(total.c[0], total.c[1], total.c[2]);
        dMassTranslate(&total, -m.com[p].x(), -m.com[p].y(), -m.com[p].z());
        dBodyID body = dBodyCreate(world);
        dBodySetMass(body, &total);
        const Eigen::Vector3d origin = pose * m.com[p];
        dBodySetPosition(body, origin.x(), origin.y(), origin.z());
        dMatrix3 rotation;
        ToOde(pose.linear(), rotation);
        dBodySetRotation(body, rotation);
        for (const ModuleBox& box : physics::ModuleBoxes()) {
          if (box.part != part) continue;
          dGeomID geom = dCreateBox(space, box.size.x(), box.size.y(), box.size.z());
          dGeomSetBody(geom, body);
          const Eigen::Vector3d offset = box.center - m.com[p];
          dGeomSetOffsetPosition(geom, offset.x(), offset.y(), offset.z());
          // Same tag scheme as world.cc: module index * 2 + part + 1 (0 = ground).
          dGeomSetData(geom, reinterpret_cast<void*>(static_cast<uintptr_t>(mi * 2 + p + 1)));
        }
        m.part[p] = body;
      }
      // The servo hinge, set up exactly as world.cc does.
      const Eigen::Isometry3d body_pose = reference.ModulePose(mm.id);
      const Eigen::Vector3d anchor = body_pose * physics::HingePivot();
      const Eigen::Vector3d axis = -(body_pose.linear() * physics::HingeAxis());
      m.hinge = dJointCreateHinge(world, nullptr);
      dJointAttach(m.hinge, m.part[0], m.part[1]);
      dJointSetHingeAnchor(m.hinge, anchor.x(), anchor.y(), anchor.z());
      dJointSetHingeAxis(m.hinge, axis.x(), axis.y(), axis.z());
      // Parts start at the module's starting angle, as in world.cc: servo
      // angle = hinge angle + start, stops and set-point shifted alike.
      m.start = mm.StartAngle();
      m.target = m.start;
      dJointSetHingeParam(m.hinge, dParamLoStop, -physics::module::kServoLimit - m.start);
      dJointSetHingeParam(m.hinge, dParamHiStop, physics::module::kServoLimit - m.start);
      dJointSetHingeParam(m.hinge, dParamFMax, 0);
      ++joints;
      index[m.id] = mi;
      modules.push_back(m);
    }
    // One fixed joint per connection, between the two mated parts.
    for (const physics::MorphologyConnection& c : morphology.connections()) {
      const Module& from = modules[index.at(c.from)];
      const Module& to = modules[index.at(c.to)];
      const auto from_part = static_cast<int>(physics::ConnectorFrameOf(c.from_connector).part);
      const auto to_part = static_cast<int>(physics::ConnectorFrameOf(c.to_connector).part);
      dJointID fixed = dJointCreateFixed(world, nullptr);
      dJointAttach(fixed, from.part[from_part], to.part[to_part]);
      dJointSetFixed(fixed);
      ++joints;
    }
  }

  ~Impl() {
    physics::EnsureOdeForThisThread();
    dJointGroupDestroy(contacts);
    dSpaceDestroy(space);
    dWorldDestroy(world);
  }

  // The module with real id `id`; kNotFound when absent.
  Module& ModuleOf(int id) {
    const auto it = index.find(id);
    if (it == index.end()) {
      throw Error(StatusCode::kNotFound, "no module " + std::to_string(id) + " in the naive world");
    }
    return modules[it->second];
  }

  void ApplyServos() {
    const physics::ServoSpec& s = options.servo;
    for (Module& m : modules) {
      if (!m.motor_on) {  // unpowered: only the gearbox friction resists
        dJointSetHingeParam(m.hinge, dParamVel, 0);
        dJointSetHingeParam(m.hinge, dParamFMax, s.limp_friction);
        continue;
      }
      const double angle = dJointGetHingeAngle(m.hinge) + m.start;
      const double velocity = std::clamp(s.gain * (m.target - angle), -s.max_speed, s.max_speed);
      dJointSetHingeParam(m.hinge, dParamVel, velocity);
      dJointSetHingeParam(m.hinge, dParamFMax, s.stall_torque);
    }
  }

  static void NearCallback(void* data, dGeomID a, dGeomID b) {
    auto* self = static_cast<Impl*>(data);
    const auto tag_a = reinterpret_cast<uintptr_t>(dGeomGetData(a));
    const auto tag_b = reinterpret_cast<uintptr_t>(dGeomGetData(b));
    if (tag_a != 0 && tag_b != 0 && (tag_a - 1) / 2 == (tag_b - 1) / 2) return;
    // Parts held together by a fixed joint touch at their connectors: the
    // usual ODE idiom skips jointed pairs.
    const dBodyID body_a = dGeomGetBody(a);
    const dBodyID body_b = dGeomGetBody(b);
    if (body_a != nullptr && body_b != nullptr &&
        dAreConnectedExcluding(body_a, body_b, dJointTypeContact)) {
      return;
    }
    const bool with_ground = tag_a == 0 || tag_b == 0;
    physics::AddContactJoints(self->world, self->contacts, a, b,
                              with_ground ? self->options.ground_friction
                                          : self->options.module_friction,
                              self->contact_erp, self->contact_cfm);
  }

  void Step() {
    if (diverged) {
      throw Error(StatusCode::kFailedPrecondition, "naive world diverged");
    }
    ApplyServos();
    try {
      dSpaceCollide(space, this, &NearCallback);
      dWorldStep(world, options.time_step);
    } catch (const physics::OdeFailure&) {
      diverged = true;
    }
    dJointGroupEmpty(contacts);
    for (const Module& m : modules) {
      for (dBodyID body : m.part) {
        const dReal* v = dBodyGetLinearVel(body);
        const dReal* w = dBodyGetAngularVel(body);
        const double speed = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        const double spin = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        if (!std::isfinite(speed) || !std::isfinite(spin) || speed > options.max_linear_speed ||
            spin > options.max_angular_speed) {
          diverged = true;
        }
      }
    }
  }
};

NaiveWorld::NaiveWorld(const physics::Morphology& morphology, const physics::WorldOptions& options)
    : impl_(std::make_unique<Impl>(morphology, options)) {}

NaiveWorld::~NaiveWorld() = default;

void NaiveWorld::SetServoTarget(int id, double angle) {
  impl_->ModuleOf(id).target =
      std::clamp(angle, -physics::module::kServoLimit, physics::module::kServoLimit);
}

void NaiveWorld::SetMotorEnabled(int id, bool enabled) { impl_->ModuleOf(id).motor_on = enabled; }

void NaiveWorld::Step() { impl_->Step(); }

Eigen::Vector3d NaiveWorld::CentralPosition() const {
  const Impl::Module& m = impl_->modules[impl_->index.at(impl_->central)];
  const dBodyID body = m.part[0];
  const dReal* p = dBodyGetPosition(body);
  const Eigen::Matrix3d r = FromOde(dBodyGetRotation(body));
  return Eigen::Vector3d(p[0], p[1], p[2]) - r * m.com[0];
}

int NaiveWorld::BodyCount() const { return static_cast<int>(impl_->modules.size() * 2); }

int NaiveWorld::JointCount() const { return impl_->joints; }

bool NaiveWorld::Diverged() const { return impl_->diverged; }

}  // namespace yamor::bench
