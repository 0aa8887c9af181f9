#include "tools/mjcf/mjcf_export.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <tinyxml2.h>

#include "common/status.h"
#include "physics/module.h"

namespace yamor::mjcf {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;

const std::string kWorlds = std::string(YAMOR_SOURCE_DIR) + "/configs/worlds/";

physics::Morphology Load(const std::string& name) {
  return physics::Morphology::LoadFile(kWorlds + name + ".xml");
}

std::vector<double> Numbers(const char* text) {
  std::vector<double> values;
  if (text == nullptr) return values;
  std::istringstream in(text);
  double v;
  while (in >> v) values.push_back(v);
  return values;
}

Vector3d Vec(const tinyxml2::XMLElement* e, const char* attribute) {
  const std::vector<double> v = Numbers(e->Attribute(attribute));
  if (v.size() != 3) return Vector3d::Zero();
  return Vector3d(v[0], v[1], v[2]);
}

Isometry3d PoseOf(const tinyxml2::XMLElement* e) {
  Isometry3d pose = Isometry3d::Identity();
  pose.translation() = Vec(e, "pos");
  const std::vector<double> q = Numbers(e->Attribute("quat"));
  if (q.size() == 4) {
    pose.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  }
  return pose;
}

// What the exported kinematic tree says, composed into world frames with
// chosen hinge angles.
struct Model {
  std::map<std::string, Isometry3d> geoms;  // world pose of each geom
  std::map<std::string, double> geom_mass;
  std::map<std::string, Vector3d> geom_half_size;
  std::map<std::string, std::string> geom_body;  // geom -> body carrying it
  std::map<int, std::string> hinge_child;   // module id -> body carrying the joint
  std::map<std::string, Isometry3d> bodies;
  std::set<std::string> actuated_joints;
  std::map<std::string, double> actuator_kp;
  int free_joints = 0;
  double timestep = 0;
  Isometry3d central = Isometry3d::Identity();
};

Model Parse(const std::string& xml, const std::map<int, double>& angles = {}) {
  tinyxml2::XMLDocument doc;
  EXPECT_EQ(doc.Parse(xml.c_str()), tinyxml2::XML_SUCCESS);
  Model model;
  const tinyxml2::XMLElement* root = doc.FirstChildElement("mujoco");
  model.timestep = root->FirstChildElement("option")->DoubleAttribute("timestep");
  std::function<void(const tinyxml2::XMLElement*, const Isometry3d&)> walk =
      [&](const tinyxml2::XMLElement* body, const Isometry3d& parent) {
        Isometry3d frame = parent * PoseOf(body);
        const std::string name = body->Attribute("name");
        for (const auto* j = body->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint")) {
          const std::string joint = j->Attribute("name");
          const int id = std::stoi(joint.substr(std::string("hinge").size()));
          model.hinge_child[id] = name;
          const auto it = angles.find(id);
          if (it == angles.end()) continue;
          // Rotate the body about the joint axis through the joint position.
          const Vector3d pos = Vec(j, "pos");
          const Vector3d axis = Vec(j, "axis").normalized();
          Isometry3d turn = Isometry3d::Identity();
          turn.translate(pos);
          turn.rotate(Eigen::AngleAxisd(it->second, axis));
          turn.translate(-pos);
          frame = frame * turn;
        }
        if (body->FirstChildElement("freejoint") != nullptr) ++model.free_joints;
        model.bodies[name] = frame;
        for (const auto* g = body->FirstChildElement("geom"); g; g = g->NextSiblingElement("geom")) {
          const std::string geom = g->Attribute("name");
          model.geoms[geom] = frame * PoseOf(g);
          model.geom_mass[geom] = g->DoubleAttribute("mass");
          model.geom_half_size[geom] = Vec(g, "size");
          model.geom_body[geom] = name;
        }
        if (const auto* s = body->FirstChildElement("site")) model.central = frame * PoseOf(s);
        for (const auto* c = body->FirstChildElement("body"); c; c = c->NextSiblingElement("body")) {
          walk(c, frame);
        }
      };
  const auto* world = root->FirstChildElement("worldbody");
  for (const auto* b = world->FirstChildElement("body"); b; b = b->NextSiblingElement("body")) {
    walk(b, Isometry3d::Identity());
  }
  for (const auto* a = root->FirstChildElement("actuator")->FirstChildElement("position"); a;
       a = a->NextSiblingElement("position")) {
    model.actuated_joints.insert(a->Attribute("joint"));
    model.actuator_kp[a->Attribute("joint")] = a->DoubleAttribute("kp");
  }
  return model;
}

void ExpectPose(const Isometry3d& actual, const Isometry3d& expected, const std::string& what) {
  EXPECT_LT((actual.translation() - expected.translation()).norm(), 1e-9) << what;
  EXPECT_LT((actual.linear() - expected.linear()).norm(), 1e-9) << what;
}

// Every geom sits where physics::World puts the same box.
void ExpectMatchesWorld(const std::string& robot) {
  const physics::Morphology morphology = Load(robot);
  ExportOptions options;
  options.world.time_step = 0.002;
  ExportSummary summary;
  const Model model = Parse(ExportMjcf(morphology, options, &summary));
  const physics::World world(morphology, options.world);
  EXPECT_EQ(summary.bodies, world.BodyCount()) << robot;
  EXPECT_EQ(static_cast<int>(model.bodies.size()), world.BodyCount()) << robot;
  EXPECT_EQ(model.free_joints, 1) << robot;
  EXPECT_DOUBLE_EQ(model.timestep, 0.002);
  double mass = 0;
  for (const auto& [name, m] : model.geom_mass) mass += m;
  EXPECT_NEAR(mass, world.TotalMass(), 1e-12) << robot;
  for (int id : world.ModuleIds()) {
    for (const physics::ModuleBox& box : physics::ModuleBoxes()) {
      const std::string name = "m" + std::to_string(id) + "_" + std::string(box.name);
      ASSERT_TRUE(model.geoms.count(name)) << name;
      const Isometry3d part =
          box.part == physics::Part::kBody ? world.ModulePose(id) : world.HandlePose(id);
      Isometry3d expected = part;
      expected.translate(box.center);
      ExpectPose(model.geoms.at(name), expected, robot + " " + name);
      EXPECT_LT((model.geom_half_size.at(name) - box.size / 2).norm(), 1e-15) << name;
      EXPECT_EQ(model.geom_mass.at(name), box.mass) << name;
    }
  }
  ExpectPose(model.central, world.ModulePose(world.CentralModule()), robot + " central site");
}

TEST(MjcfExportTest, QuadrupedGeomsMassesAndPlacementMatchTheWorld) { ExpectMatchesWorld("quadruped"); }
TEST(MjcfExportTest, SnakeGeomsMassesAndPlacementMatchTheWorld) { ExpectMatchesWorld("snake"); }
TEST(MjcfExportTest, TripodGeomsMassesAndPlacementMatchTheWorld) { ExpectMatchesWorld("tripod"); }

TEST(MjcfExportTest, EveryServoIsAnActuatedHingeWithTheServoGain) {
  ExportOptions options;
  options.actuator_damping = 0.5;
  ExportSummary summary;
  const Model model = Parse(ExportMjcf(Load("quadruped"), options, &summary));
  EXPECT_EQ(summary.hinges, 9);
  EXPECT_TRUE(summary.skipped_hinges.empty());
  EXPECT_EQ(model.hinge_child.size(), 9u);
  for (int id = 0; id <= 8; ++id) {
    const std::string joint = "hinge" + std::to_string(id);
    EXPECT_TRUE(model.actuated_joints.count(joint)) << joint;
    EXPECT_DOUBLE_EQ(model.actuator_kp.at(joint), options.world.servo.gain * 0.5) << joint;
  }
}

// A positive joint angle turns each handle relative to its own body exactly
// as HandleInBody() does, whichever side of the hinge is the child.
TEST(MjcfExportTest, JointAngleIsTheServoAngle) {
  const physics::Morphology morphology = Load("quadruped");
  std::map<int, double> angles;
  for (int id = 0; id <= 8; ++id) angles[id] = 0.1 * (id + 1) * (id % 2 == 0 ? 1 : -1);
  const Model model = Parse(ExportMjcf(morphology, ExportOptions()), angles);
  std::set<bool> child_is_handle;
  for (int id = 0; id <= 8; ++id) {
    const std::string m = "m" + std::to_string(id);
    const Isometry3d body = model.geoms.at(m + "_body");  // body box centre = body frame
    const Isometry3d crossbar = model.geoms.at(m + "_crossbar");
    Isometry3d expected = physics::PartPose(body, physics::Part::kHandle, angles.at(id));
    for (const physics::ModuleBox& box : physics::ModuleBoxes()) {
      if (box.name == "crossbar") expected.translate(box.center);
    }
    ExpectPose(crossbar, expected, m);
    child_is_handle.insert(model.geom_body.at(m + "_crossbar") == model.hinge_child.at(id));
  }
  // The quadruped has both kinds: a hip's body hangs from its handle (screwed
  // into the central module), the central module's handle from its body.
  EXPECT_EQ(child_is_handle.size(), 2u);
}

TEST(MjcfExportTest, WheelLoopHingeIsLeftOutAndItsSidesDoNotCollide) {
  ExportSummary summary;
  const std::string xml = ExportMjcf(Load("wheel"), ExportOptions(), &summary);
  const physics::World world(Load("wheel"));
  ASSERT_EQ(summary.skipped_hinges.size(), 1u);
  EXPECT_EQ(summary.bodies, world.BodyCount());
  EXPECT_EQ(summary.hinges + static_cast<int>(summary.skipped_hinges.size()) +
                static_cast<int>(summary.locked_servos.size()),
            static_cast<int>(world.ModuleIds().size()));
  EXPECT_NE(xml.find("<exclude"), std::string::npos);
  EXPECT_EQ(xml.find("hinge" + std::to_string(summary.skipped_hinges[0]) + "\""), std::string::npos);
  // Every wheel hinge starts bent (configs/worlds/wheel.xml): the exported
  // joints read their starting angles in the initial configuration.
  int refs = 0;
  for (size_t at = xml.find(" ref=\""); at != std::string::npos; at = xml.find(" ref=\"", at + 1)) {
    ++refs;
  }
  EXPECT_EQ(refs, summary.hinges);
  EXPECT_EQ(ExportMjcf(Load("quadruped"), ExportOptions()).find(" ref=\""), std::string::npos);
}

TEST(MjcfExportTest, UnpoweredServosGetGearboxFrictionAndNoActuator) {
  ExportOptions options;
  options.unpowered_modules = {4};
  const std::string xml = ExportMjcf(Load("quadruped"), options);
  const size_t hinge = xml.find("<joint name=\"hinge4\"");
  ASSERT_NE(hinge, std::string::npos);
  const std::string joint = xml.substr(hinge, xml.find('>', hinge) - hinge);
  EXPECT_NE(joint.find(" frictionloss=\"0.002\""), std::string::npos) << joint;
  EXPECT_EQ(xml.find("joint=\"hinge4\""), std::string::npos);
  EXPECT_NE(xml.find("joint=\"hinge0\""), std::string::npos);
  EXPECT_EQ(xml.find("frictionloss"), xml.rfind("frictionloss")) << "only module 4 is unpowered";
  // Powered by default.
  EXPECT_NE(ExportMjcf(Load("quadruped"), ExportOptions()).find("joint=\"hinge4\""),
            std::string::npos);

  options.unpowered_modules = {99};
  try {
    ExportMjcf(Load("quadruped"), options);
    FAIL() << "an unknown unpowered module was accepted";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(error.what()).find("99"), std::string::npos) << error.what();
  }
}

TEST(MjcfExportTest, StaticBoxesAreFixedGeomsAndTheRobotStandsOnThem) {
  std::string xml = Load("quadruped").ToXml();
  xml.insert(xml.rfind("</morphology>"),
             "  <box name=\"table\" size=\"1 0.8 0.4\" position=\"0 0 0.2\" orientation=\"0 0 90\"/>\n");
  const std::string mjcf = ExportMjcf(physics::Morphology::Parse(xml, "table"), ExportOptions());
  tinyxml2::XMLDocument document;
  ASSERT_EQ(document.Parse(mjcf.c_str()), tinyxml2::XML_SUCCESS);
  const tinyxml2::XMLElement* world = document.RootElement()->FirstChildElement("worldbody");
  ASSERT_NE(world, nullptr);
  const tinyxml2::XMLElement* table = nullptr;
  for (const tinyxml2::XMLElement* g = world->FirstChildElement("geom"); g; g = g->NextSiblingElement("geom")) {
    if (std::string(g->Attribute("name")) == "static1") table = g;
  }
  ASSERT_NE(table, nullptr) << mjcf;
  EXPECT_STREQ(table->Attribute("type"), "box");
  EXPECT_TRUE(Vec(table, "size").isApprox(Vector3d(0.5, 0.4, 0.2)));
  EXPECT_TRUE(Vec(table, "pos").isApprox(Vector3d(0, 0, 0.2)));
  const Isometry3d pose = PoseOf(table);
  EXPECT_NEAR(pose.linear().col(0).y(), 1.0, 1e-9) << "yawed by 90 degrees";
  // The robot's root body stands on the table, not on the floor.
  const tinyxml2::XMLElement* body = world->FirstChildElement("body");
  ASSERT_NE(body, nullptr);
  EXPECT_GT(Vec(body, "pos").z(), 0.4);
  EXPECT_EQ(ExportMjcf(Load("quadruped"), ExportOptions()).find("static1"), std::string::npos);
}

TEST(MjcfExportTest, BadOptionsAreRejected) {
  ExportOptions options;
  options.actuator_damping = 0;
  EXPECT_THROW(ExportMjcf(Load("snake"), options), Error);
  options = ExportOptions();
  options.contact_time_constant = std::nan("");
  EXPECT_THROW(ExportMjcf(Load("snake"), options), Error);
  options = ExportOptions();
  options.world.time_step = -1;
  EXPECT_THROW(ExportMjcf(Load("snake"), options), Error);
}

}  // namespace
}  // namespace yamor::mjcf
