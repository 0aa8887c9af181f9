#include "physics/render/snapshot.h"

#include <algorithm>
#include <string>

#include "common/status.h"

namespace yamor::render {
namespace {

snp::ScenePose ToWire(const Pose& pose) {
  snp::ScenePose out;
  for (int i = 0; i < 3; ++i) out.position[i] = static_cast<float>(pose.position[i]);
  const Eigen::Quaterniond q = pose.orientation.normalized();
  out.orientation = {static_cast<float>(q.w()), static_cast<float>(q.x()),
                     static_cast<float>(q.y()), static_cast<float>(q.z())};
  return out;
}

Pose FromWire(const snp::ScenePose& pose) {
  Pose out;
  out.position = Eigen::Vector3d(pose.position[0], pose.position[1], pose.position[2]);
  out.orientation = Eigen::Quaterniond(pose.orientation[0], pose.orientation[1],
                                       pose.orientation[2], pose.orientation[3])
                        .normalized();
  return out;
}

std::array<float, 3> ToWire(const Eigen::Vector3d& v) {
  return {static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z())};
}

Eigen::Vector3d FromWire(const std::array<float, 3>& v) { return Eigen::Vector3d(v[0], v[1], v[2]); }

}  // namespace

snp::SceneSnapshot ToSnapshot(const Scene& scene) {
  snp::SceneSnapshot out;
  out.time = scene.time;
  out.slope = static_cast<float>(scene.slope);
  out.slope_direction = static_cast<float>(scene.slope_direction);
  out.led = ToWire(scene.led);
  for (const ShapeBox& box : scene.shape) {
    out.shape.push_back(snp::SceneShapeBox{.part = static_cast<uint8_t>(box.part == ShapePart::kBody ? 0 : 1),
                                           .center = ToWire(box.center),
                                           .size = ToWire(box.size)});
  }
  std::vector<const SceneModule*> modules;
  for (const SceneModule& m : scene.modules) {
    if (m.id < 0 || m.id > 254) {
      throw Error(StatusCode::kInvalidArgument,
                  "scene module id " + std::to_string(m.id) + " does not fit a snapshot (0..254)");
    }
    modules.push_back(&m);
  }
  std::sort(modules.begin(), modules.end(),
            [](const SceneModule* a, const SceneModule* b) { return a->id < b->id; });
  for (const SceneModule* m : modules) {
    if (!out.modules.empty() && out.modules.back().id == m->id) {
      throw Error(StatusCode::kInvalidArgument,
                  "scene module id " + std::to_string(m->id) + " appears twice");
    }
    uint8_t flags = 0;
    if (m->central) flags |= snp::kSceneModuleCentral;
    if (m->loose) flags |= snp::kSceneModuleLoose;
    if (m->defective) flags |= snp::kSceneModuleDefective;
    out.modules.push_back(snp::SceneModule{.id = static_cast<uint8_t>(m->id),
                                           .flags = flags,
                                           .body = ToWire(m->body),
                                           .handle = ToWire(m->handle)});
  }
  for (const StaticBox& box : scene.boxes) {
    out.boxes.push_back(snp::SceneStaticBox{.pose = ToWire(box.pose), .size = ToWire(box.size)});
  }
  return out;
}

Scene FromSnapshot(const snp::SceneSnapshot& snapshot, const std::function<int(int)>& module_id) {
  Scene scene;
  scene.time = snapshot.time;
  scene.slope = snapshot.slope;
  scene.slope_direction = snapshot.slope_direction;
  scene.led = FromWire(snapshot.led);
  for (const snp::SceneShapeBox& box : snapshot.shape) {
    scene.shape.push_back(ShapeBox{.part = box.part == 0 ? ShapePart::kBody : ShapePart::kHandle,
                                   .center = FromWire(box.center),
                                   .size = FromWire(box.size)});
  }
  for (const snp::SceneModule& m : snapshot.modules) {
    scene.modules.push_back(SceneModule{.id = module_id ? module_id(m.id) : m.id,
                                        .body = FromWire(m.body),
                                        .handle = FromWire(m.handle),
                                        .central = (m.flags & snp::kSceneModuleCentral) != 0,
                                        .loose = (m.flags & snp::kSceneModuleLoose) != 0,
                                        .defective = (m.flags & snp::kSceneModuleDefective) != 0});
  }
  for (const snp::SceneStaticBox& box : snapshot.boxes) {
    scene.boxes.push_back(StaticBox{.pose = FromWire(box.pose), .size = FromWire(box.size)});
  }
  return scene;
}

}  // namespace yamor::render
