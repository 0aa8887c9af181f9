#include "physics/module_graph.h"

#include <map>

#include "common/status.h"

namespace yamor::physics {
namespace {

cpg::Connector ToCpg(ConnectorId c) {
  // Both enums list the connectors in docs/module.md's order.
  return static_cast<cpg::Connector>(static_cast<int>(c));
}

}  // namespace

cpg::ModuleGraph ModuleGraphOf(const Morphology& morphology,
                               const std::vector<std::pair<int, bool>>& activity) {
  static_assert(static_cast<int>(ConnectorId::kBottom) == static_cast<int>(cpg::Connector::kBottom));
  std::map<int, bool> active;
  for (const auto& [id, on] : activity) active[id] = on;  // a later entry overrides an earlier one
  std::vector<cpg::GraphModule> modules;
  for (const MorphologyModule& m : morphology.modules()) {
    if (m.free) continue;
    auto it = active.find(m.id);
    modules.push_back({.id = m.id,
                       .active = it == active.end() ? true : it->second,
                       .orientation = Eigen::Matrix3d(morphology.BodyPose(m.id).linear())});
  }
  std::vector<cpg::GraphEdge> edges;
  for (const MorphologyConnection& c : morphology.connections()) {
    edges.push_back({.a = c.from, .a_connector = ToCpg(c.from_connector), .b = c.to,
                     .b_connector = ToCpg(c.to_connector), .angle_steps = c.angle_steps});
  }
  return cpg::ModuleGraph(morphology.central(), std::move(modules), std::move(edges),
                          Eigen::Vector3d::UnitZ());
}

}  // namespace yamor::physics
