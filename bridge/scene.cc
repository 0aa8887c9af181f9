#include "bridge/scene.h"

#include <algorithm>
#include <cmath>

#include "common/status.h"

namespace yamor::bridge {
namespace {

render::Pose ToPose(const Eigen::Isometry3d& pose) {
  return render::Pose{.position = pose.translation(),
                      .orientation = Eigen::Quaterniond(pose.linear()).normalized()};
}

}  // namespace

render::Scene SceneOf(const physics::World& world) {
  if (world.Diverged()) {
    throw Error(StatusCode::kFailedPrecondition,
                "the world is diverged (" + world.Divergence().reason +
                    "): nothing to render until it is reset");
  }
  render::Scene scene;
  scene.time = world.Time();
  const Eigen::Vector3d g = world.Gravity();
  if (g.norm() > 0.0) {
    scene.slope = std::acos(std::clamp(-g.z() / g.norm(), -1.0, 1.0));
    scene.slope_direction = scene.slope > 0.0 ? std::atan2(g.y(), g.x()) : 0.0;
  }
  for (const physics::ModuleBox& box : physics::ModuleBoxes()) {
    scene.shape.push_back(render::ShapeBox{
        .part = box.part == physics::Part::kBody ? render::ShapePart::kBody
                                                 : render::ShapePart::kHandle,
        .center = box.center,
        .size = box.size});
  }
  // In the middle of the face that is up when the robot stands as built:
  // where the tracked LED sits, looking at the ceiling camera.
  const Eigen::Vector3d up = physics::CentralUpAxis(world.morphology());
  double reach = 0.0;
  for (const physics::ModuleBox& box : physics::ModuleBoxes()) {
    if (box.part != physics::Part::kBody) continue;
    reach = std::max(reach, box.center.dot(up) + 0.5 * box.size.cwiseAbs().dot(up.cwiseAbs()));
  }
  scene.led = up * (reach + 0.003);
  const int central = world.CentralModule();
  for (int id : world.ModuleIds()) {
    const physics::ModulePresence presence = world.Presence(id);
    if (presence == physics::ModulePresence::kPutAway) continue;
    scene.modules.push_back(render::SceneModule{
        .id = id,
        .body = ToPose(world.ModulePose(id)),
        .handle = ToPose(world.HandlePose(id)),
        .central = id == central,
        .loose = presence == physics::ModulePresence::kLoose,
        .defective = world.ModuleDefective(id)});
  }
  for (const physics::StaticBox& box : world.StaticBoxes()) {
    scene.boxes.push_back(render::StaticBox{.pose = ToPose(box.Pose()), .size = box.size});
  }
  return scene;
}

}  // namespace yamor::bridge
