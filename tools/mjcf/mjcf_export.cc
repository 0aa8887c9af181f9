#include "tools/mjcf/mjcf_export.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <deque>
#include <filesystem>
#include <map>
#include <set>
#include <string_view>

#include "common/status.h"
#include "physics/disjoint_sets.h"
#include "physics/module.h"

namespace yamor::mjcf {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;
using physics::DisjointSets;
using physics::Part;

// A part of a module: index into the connected module list and which part.
struct PartRef {
  size_t module = 0;
  Part part = Part::kBody;
};

struct Group {
  std::vector<PartRef> parts;
  Isometry3d frame = Isometry3d::Identity();  // world pose of the MuJoCo body frame
  std::string name;
  int parent = -1;
  int joint_module = -1;  // index of the module whose hinge joins it to its parent
  std::vector<int> children;
};


std::string Num(double value) {
  // Round-off below a femtometre / 1e-15 rad is noise: print it as 0 (no "-0").
  if (std::abs(value) < 1e-15) value = 0;
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

std::string Vec(const Vector3d& v) { return Num(v.x()) + " " + Num(v.y()) + " " + Num(v.z()); }

// MuJoCo quaternions are w x y z.
std::string Quat(const Eigen::Matrix3d& rotation) {
  Eigen::Quaterniond q(rotation);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;
  return Num(q.w()) + " " + Num(q.x()) + " " + Num(q.y()) + " " + Num(q.z());
}

std::string PosQuat(const Isometry3d& pose) {
  std::string text = "pos=\"" + Vec(pose.translation()) + "\"";
  if (!pose.linear().isIdentity(1e-15)) text += " quat=\"" + Quat(pose.linear()) + "\"";
  return text;
}

std::string PartName(int id, Part part) {
  std::string name = "m";  // not "m" + ...: g++ 12 -Wrestrict false positive
  name += std::to_string(id);
  name += part == Part::kBody ? "_body" : "_handle";
  return name;
}

std::string ModelName(const physics::Morphology& morphology, const ExportOptions& options) {
  std::string name = options.model_name;
  if (name.empty()) name = std::filesystem::path(morphology.source()).stem().string();
  if (name.empty()) name = "yamor";
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return name;
}

class Exporter {
 public:
  Exporter(const physics::Morphology& morphology, const ExportOptions& options)
      : morphology_(morphology), options_(options), world_(morphology, options.world) {
    if (!(options.actuator_damping > 0) || !std::isfinite(options.actuator_damping)) {
      throw Error(StatusCode::kInvalidArgument,
                  "actuator_damping must be finite and > 0, got " +
                      Num(options.actuator_damping));
    }
    if (!(options.contact_time_constant > 0) || !std::isfinite(options.contact_time_constant)) {
      throw Error(StatusCode::kInvalidArgument,
                  "contact_time_constant must be finite and > 0, got " +
                      Num(options.contact_time_constant));
    }
    for (const physics::MorphologyModule& m : morphology.modules()) {
      if (m.free) continue;
      index_[m.id] = ids_.size();
      ids_.push_back(m.id);
      body_pose_.push_back(world_.ModulePose(m.id));
      handle_pose_.push_back(world_.HandlePose(m.id));
    }
    for (int id : options.unpowered_modules) {
      if (index_.count(id) == 0) {
        throw Error(StatusCode::kInvalidArgument,
                    "unpowered module " + std::to_string(id) + " is not a connected module of " +
                        morphology.source());
      }
      unpowered_.insert(id);
    }
    BuildGroups();
    BuildTree();
  }

  std::string Write(ExportSummary* summary) {
    const double h = options_.world.time_step;
    const physics::ServoSpec& servo = options_.world.servo;
    out_ += "<mujoco model=\"" + ModelName(morphology_, options_) + "\">\n";
    out_ += "  <!-- Exported by yamor-mjcf-export from " + morphology_.source() +
            " (tools/mjcf). One body per rigid group of parts; servos are hinges with "
            "position actuators. -->\n";
    out_ += "  <compiler angle=\"radian\" autolimits=\"true\" inertiafromgeom=\"true\"/>\n";
    const Vector3d g = world_.Gravity();
    out_ += "  <option timestep=\"" + Num(h) + "\" gravity=\"" + Vec(g) +
            "\" integrator=\"implicitfast\" cone=\"pyramidal\"/>\n";
    // Soft contacts with a fixed time constant (see ExportOptions); sliding
    // friction only, pyramid cone, as ODE's dContactApprox1.
    out_ += "  <default>\n";
    out_ += "    <geom type=\"box\" condim=\"3\" friction=\"" + Num(options_.world.module_friction) +
            " 0 0\" solref=\"" + Num(options_.contact_time_constant) + " 1\"/>\n";
    out_ += "  </default>\n";
    out_ += "  <worldbody>\n";
    // priority: the ground's friction is the contact's, as in physics::World.
    out_ += "    <geom name=\"ground\" type=\"plane\" size=\"0 0 1\" priority=\"1\" friction=\"" +
            Num(options_.world.ground_friction) + " 0 0\"/>\n";
    // Static boxes (tables, platforms): fixed geoms with the ground's friction.
    const std::vector<physics::StaticBox>& boxes = world_.StaticBoxes();
    for (size_t i = 0; i < boxes.size(); ++i) {
      out_ += "    <geom name=\"static" + std::to_string(i + 1) + "\" type=\"box\" size=\"" +
              Vec(boxes[i].size / 2) + "\" pos=\"" + Vec(boxes[i].position) + "\" quat=\"" +
              Quat(boxes[i].Pose().linear()) + "\" priority=\"1\" friction=\"" +
              Num(options_.world.ground_friction) + " 0 0\"/>\n";
    }
    for (size_t g_index = 0; g_index < groups_.size(); ++g_index) {
      if (groups_[g_index].parent < 0) WriteBody(static_cast<int>(g_index), 2);
    }
    out_ += "  </worldbody>\n";
    if (!excluded_.empty()) {
      out_ += "  <contact>\n";
      for (const auto& [a, b] : excluded_) {
        out_ += "    <exclude body1=\"" + groups_[static_cast<size_t>(a)].name + "\" body2=\"" +
                groups_[static_cast<size_t>(b)].name + "\"/>\n";
      }
      out_ += "  </contact>\n";
    }
    out_ += "  <actuator>\n";
    const double kv = options_.actuator_damping;
    for (size_t g_index = 0; g_index < groups_.size(); ++g_index) {
      const int mi = groups_[g_index].joint_module;
      if (mi < 0 || unpowered_.count(ids_[static_cast<size_t>(mi)]) != 0) continue;
      const std::string id = std::to_string(ids_[static_cast<size_t>(mi)]);
      out_ += "    <position name=\"servo" + id + "\" joint=\"hinge" + id + "\" kp=\"" +
              Num(servo.gain * kv) + "\" kv=\"" + Num(kv) + "\" forcerange=\"" +
              Num(-servo.stall_torque) + " " + Num(servo.stall_torque) + "\" ctrlrange=\"" +
              Num(-physics::module::kServoLimit) + " " + Num(physics::module::kServoLimit) +
              "\"/>\n";
    }
    out_ += "  </actuator>\n";
    out_ += "</mujoco>\n";
    if (summary != nullptr) {
      summary->bodies = static_cast<int>(groups_.size());
      summary->hinges = 0;
      for (const Group& group : groups_) summary->hinges += group.joint_module >= 0;
      summary->skipped_hinges = skipped_;
      summary->locked_servos = locked_;
    }
    return out_;
  }

 private:
  const Isometry3d& PartPose(const PartRef& p) const {
    return p.part == Part::kBody ? body_pose_[p.module] : handle_pose_[p.module];
  }

  void BuildGroups() {
    DisjointSets sets(ids_.size() * 2);
    auto part_index = [&](int id, physics::ConnectorId connector) {
      return index_.at(id) * 2 + static_cast<size_t>(physics::ConnectorFrameOf(connector).part);
    };
    for (const physics::MorphologyConnection& c : morphology_.connections()) {
      sets.Union(part_index(c.from, c.from_connector), part_index(c.to, c.to_connector));
    }
    std::map<size_t, int> group_of_root;
    group_of_.assign(ids_.size() * 2, -1);
    for (size_t mi = 0; mi < ids_.size(); ++mi) {
      for (int p = 0; p < 2; ++p) {
        const size_t root = sets.Find(mi * 2 + static_cast<size_t>(p));
        auto [it, inserted] = group_of_root.emplace(root, static_cast<int>(groups_.size()));
        if (inserted) groups_.emplace_back();
        groups_[static_cast<size_t>(it->second)].parts.push_back({mi, static_cast<Part>(p)});
        group_of_[mi * 2 + static_cast<size_t>(p)] = it->second;
      }
    }
    // The body frame of a group: the central module's body frame for the
    // root (so the free joint's position is the tracked position), else the
    // first module body in the group, else its first handle.
    const size_t central = index_.at(morphology_.central());
    for (Group& group : groups_) {
      const PartRef* chosen = &group.parts.front();
      for (const PartRef& p : group.parts) {
        if (p.part == Part::kBody) {
          chosen = &p;
          break;
        }
      }
      for (const PartRef& p : group.parts) {
        if (p.module == central && p.part == Part::kBody) chosen = &p;
      }
      group.frame = PartPose(*chosen);
      group.name = PartName(ids_[chosen->module], chosen->part);
    }
  }

  int GroupOf(size_t mi, Part part) const {
    return group_of_[mi * 2 + static_cast<size_t>(part)];
  }

  void BuildTree() {
    const size_t central = index_.at(morphology_.central());
    std::vector<bool> visited(groups_.size(), false);
    std::vector<bool> used(ids_.size(), false);
    auto bfs = [&](int start) {
      std::deque<int> queue{start};
      visited[static_cast<size_t>(start)] = true;
      while (!queue.empty()) {
        const int g = queue.front();
        queue.pop_front();
        for (size_t mi = 0; mi < ids_.size(); ++mi) {
          const int gb = GroupOf(mi, Part::kBody);
          const int gh = GroupOf(mi, Part::kHandle);
          if (gb == gh || used[mi] || (gb != g && gh != g)) continue;
          const int other = gb == g ? gh : gb;
          if (visited[static_cast<size_t>(other)]) continue;  // a loop: decided below
          used[mi] = true;
          visited[static_cast<size_t>(other)] = true;
          Group& child = groups_[static_cast<size_t>(other)];
          child.parent = g;
          child.joint_module = static_cast<int>(mi);
          groups_[static_cast<size_t>(g)].children.push_back(other);
          queue.push_back(other);
        }
      }
    };
    bfs(GroupOf(central, Part::kBody));
    // Pieces not reachable through hinges (none in a valid robot) float free.
    for (size_t g = 0; g < groups_.size(); ++g) {
      if (!visited[g]) bfs(static_cast<int>(g));
    }
    for (size_t mi = 0; mi < ids_.size(); ++mi) {
      const int gb = GroupOf(mi, Part::kBody);
      const int gh = GroupOf(mi, Part::kHandle);
      if (gb == gh) {
        locked_.push_back(ids_[mi]);
      } else if (!used[mi]) {
        // Closes a loop: no tree joint; its two sides must not collide either.
        skipped_.push_back(ids_[mi]);
        excluded_.emplace_back(gb, gh);
      }
    }
  }

  void WriteBody(int g_index, int depth) {
    const Group& group = groups_[static_cast<size_t>(g_index)];
    const std::string indent(static_cast<size_t>(depth) * 2, ' ');
    const Isometry3d relative = group.parent < 0
                                    ? group.frame
                                    : groups_[static_cast<size_t>(group.parent)].frame.inverse() *
                                          group.frame;
    out_ += indent + "<body name=\"" + group.name + "\" " + PosQuat(relative) + ">\n";
    if (group.parent < 0) {
      out_ += indent + "  <freejoint name=\"" + group.name + "_free\"/>\n";
    } else {
      const size_t mi = static_cast<size_t>(group.joint_module);
      const Isometry3d& body = body_pose_[mi];
      const Vector3d pivot = body * physics::HingePivot();
      Vector3d axis = body.linear() * physics::HingeAxis();
      // The joint angle is the child's rotation about the axis relative to
      // its parent: the servo angle when the handle is the child, minus it
      // when the module's body is.
      if (GroupOf(mi, Part::kBody) == g_index) axis = -axis;
      const Isometry3d to_local = group.frame.inverse();
      // The parts are placed at the module's starting angle: MuJoCo's ref
      // makes that configuration read as that angle (qpos0 = ref).
      const double start = morphology_.Module(ids_[mi]).StartAngle();
      const std::string ref = start == 0.0 ? "" : "\" ref=\"" + Num(start);
      // An unpowered servo is back-driven against the gearbox's friction only.
      const std::string friction =
          unpowered_.count(ids_[mi]) == 0
              ? ""
              : "\" frictionloss=\"" + Num(options_.world.servo.limp_friction);
      out_ += indent + "  <joint name=\"hinge" + std::to_string(ids_[mi]) +
              "\" type=\"hinge\" pos=\"" + Vec(to_local * pivot) + "\" axis=\"" +
              Vec(to_local.linear() * axis) + ref + friction + "\" range=\"" +
              Num(-physics::module::kServoLimit) + " " + Num(physics::module::kServoLimit) +
              "\"/>\n";
    }
    const Isometry3d to_local = group.frame.inverse();
    for (const PartRef& p : group.parts) {
      for (const physics::ModuleBox& box : physics::ModuleBoxes()) {
        if (box.part != p.part) continue;
        Isometry3d pose = Isometry3d::Identity();
        pose.translation() = box.center;
        const Isometry3d local = to_local * PartPose(p) * pose;
        out_ += indent + "  <geom name=\"m" + std::to_string(ids_[p.module]) + "_" +
                std::string(box.name) + "\" size=\"" + Vec(box.size / 2) + "\" " +
                PosQuat(local) + " mass=\"" + Num(box.mass) + "\"/>\n";
      }
      if (ids_[p.module] == morphology_.central() && p.part == Part::kBody) {
        out_ += indent + "  <site name=\"central\" " + PosQuat(to_local * PartPose(p)) + "/>\n";
      }
    }
    for (int child : group.children) WriteBody(child, depth + 1);
    out_ += indent + "</body>\n";
  }

  const physics::Morphology& morphology_;
  ExportOptions options_;
  physics::World world_;  // places the robot exactly as the simulation does
  std::map<int, size_t> index_;
  std::set<int> unpowered_;  // ids of modules whose servo is unpowered
  std::vector<int> ids_;
  std::vector<Isometry3d> body_pose_;
  std::vector<Isometry3d> handle_pose_;
  std::vector<Group> groups_;
  std::vector<int> group_of_;
  std::vector<int> skipped_;
  std::vector<int> locked_;
  std::vector<std::pair<int, int>> excluded_;
  std::string out_;
};

}  // namespace

std::string ExportMjcf(const physics::Morphology& morphology, const ExportOptions& options,
                       ExportSummary* summary) {
  Exporter exporter(morphology, options);
  return exporter.Write(summary);
}

}  // namespace yamor::mjcf
