#include "cpg/module_graph.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

#include "common/status.h"

namespace yamor::cpg {
namespace {

constexpr std::array<std::string_view, kConnectorCount> kNames = {"front", "rear", "left",
                                                                  "right", "top",  "bottom"};

// Index of `id` in the sorted module list, or -1.
int Find(const std::vector<GraphModule>& modules, ModuleId id) {
  auto it = std::lower_bound(modules.begin(), modules.end(), id,
                             [](const GraphModule& m, ModuleId v) { return m.id < v; });
  if (it == modules.end() || it->id != id) return -1;
  return static_cast<int>(it - modules.begin());
}

}  // namespace

std::string_view ConnectorName(Connector connector) {
  return kNames[static_cast<size_t>(connector)];
}

std::optional<Connector> ConnectorFromName(std::string_view name) {
  for (size_t i = 0; i < kNames.size(); ++i) {
    if (kNames[i] == name) return static_cast<Connector>(i);
  }
  return std::nullopt;
}

Connector OppositeConnector(Connector connector) {
  switch (connector) {
    case Connector::kFront: return Connector::kRear;
    case Connector::kRear: return Connector::kFront;
    case Connector::kLeft: return Connector::kRight;
    case Connector::kRight: return Connector::kLeft;
    case Connector::kTop: return Connector::kBottom;
    case Connector::kBottom: return Connector::kTop;
  }
  YAMOR_CHECK(false, "unknown connector");
  return Connector::kFront;
}

Eigen::Vector3i ConnectorNormal(Connector connector) {
  switch (connector) {
    case Connector::kFront: return {1, 0, 0};
    case Connector::kRear: return {-1, 0, 0};
    case Connector::kLeft: return {0, 1, 0};
    case Connector::kRight: return {0, -1, 0};
    case Connector::kTop: return {0, 0, 1};
    case Connector::kBottom: return {0, 0, -1};
  }
  YAMOR_CHECK(false, "unknown connector");
  return {};
}

Eigen::Vector3i ConnectorNorth(Connector connector) {
  switch (connector) {
    case Connector::kTop:
    case Connector::kBottom: return {1, 0, 0};
    default: return {0, 0, 1};
  }
}

ModuleGraph::ModuleGraph(ModuleId central, std::vector<GraphModule> modules,
                         std::vector<GraphEdge> edges, std::optional<Eigen::Vector3d> up)
    : central_(central), modules_(std::move(modules)), edges_(std::move(edges)), up_(up) {
  if (modules_.empty()) throw Error(StatusCode::kInvalidArgument, "module graph: no module");
  std::sort(modules_.begin(), modules_.end(),
            [](const GraphModule& x, const GraphModule& y) { return x.id < y.id; });
  const bool geometry = modules_.front().orientation.has_value();
  for (size_t i = 0; i < modules_.size(); ++i) {
    const GraphModule& m = modules_[i];
    if (m.id < 0 || m.id > kMaxModuleId) {
      throw Error(StatusCode::kInvalidArgument,
                  "module graph: module id " + std::to_string(m.id) + " outside 0..254");
    }
    if (i > 0 && modules_[i - 1].id == m.id) {
      throw Error(StatusCode::kInvalidArgument,
                  "module graph: module " + std::to_string(m.id) + " appears twice");
    }
    if (m.orientation.has_value() != geometry) {
      throw Error(StatusCode::kInvalidArgument,
                  "module graph: module " + std::to_string(m.id) +
                      (geometry ? " has no orientation" : " has an orientation") +
                      " while module " + std::to_string(modules_.front().id) +
                      (geometry ? " has one" : " has none"));
    }
    if (m.orientation && !m.orientation->allFinite()) {
      throw Error(StatusCode::kInvalidArgument,
                  "module graph: module " + std::to_string(m.id) + " has a non-finite orientation");
    }
  }
  if (Find(modules_, central_) < 0) {
    throw Error(StatusCode::kNotFound,
                "module graph: central module " + std::to_string(central_) + " is not in the graph");
  }
  if (up_ && (!up_->allFinite() || std::abs(up_->norm() - 1.0) > 1e-6)) {
    throw Error(StatusCode::kInvalidArgument, "module graph: the up direction is not a unit vector");
  }
  std::set<std::pair<ModuleId, Connector>> used;
  for (const GraphEdge& e : edges_) {
    const std::string name = "edge " + std::to_string(e.a) + "." +
                             std::string(ConnectorName(e.a_connector)) + " - " +
                             std::to_string(e.b) + "." + std::string(ConnectorName(e.b_connector));
    if (Find(modules_, e.a) < 0 || Find(modules_, e.b) < 0) {
      throw Error(StatusCode::kInvalidArgument,
                  "module graph: " + name + " names module " +
                      std::to_string(Find(modules_, e.a) < 0 ? e.a : e.b) +
                      ", which is not in the graph");
    }
    if (e.a == e.b) {
      throw Error(StatusCode::kInvalidArgument, "module graph: " + name + " joins a module to itself");
    }
    if (e.angle_steps < 0 || e.angle_steps >= kAngleSteps) {
      throw Error(StatusCode::kInvalidArgument,
                  "module graph: " + name + " has angle step " + std::to_string(e.angle_steps) +
                      " outside [0, 24)");
    }
    for (auto end : {std::pair{e.a, e.a_connector}, std::pair{e.b, e.b_connector}}) {
      if (!used.insert(end).second) {
        throw Error(StatusCode::kInvalidArgument,
                    "module graph: connector " + std::string(ConnectorName(end.second)) +
                        " of module " + std::to_string(end.first) + " is used twice");
      }
    }
  }
}

bool ModuleGraph::Contains(ModuleId id) const { return Find(modules_, id) >= 0; }

int ModuleGraph::IndexOf(ModuleId id) const {
  const int i = Find(modules_, id);
  if (i < 0) {
    throw Error(StatusCode::kNotFound, "module graph: no module " + std::to_string(id));
  }
  return i;
}

const GraphModule& ModuleGraph::Module(ModuleId id) const { return modules_[IndexOf(id)]; }

std::vector<ModuleId> ModuleGraph::Neighbours(ModuleId id) const {
  std::vector<ModuleId> out;
  for (const GraphEdge& e : edges_) {
    if (e.a == id) out.push_back(e.b);
    if (e.b == id) out.push_back(e.a);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::vector<ModuleId>> ModuleGraph::Components() const {
  const int n = static_cast<int>(modules_.size());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const GraphEdge& e : edges_) parent[root(Find(modules_, e.a))] = root(Find(modules_, e.b));
  std::map<int, std::vector<ModuleId>> pieces;
  for (int i = 0; i < n; ++i) pieces[root(i)].push_back(modules_[i].id);
  std::vector<std::vector<ModuleId>> out;
  for (auto& [r, ids] : pieces) out.push_back(std::move(ids));  // ids come sorted
  auto holds_central = [&](const std::vector<ModuleId>& ids) {
    return std::binary_search(ids.begin(), ids.end(), central_);
  };
  std::sort(out.begin(), out.end(), [&](const auto& x, const auto& y) {
    if (x.size() != y.size()) return x.size() > y.size();
    if (holds_central(x) != holds_central(y)) return holds_central(x);
    return x.front() < y.front();
  });
  return out;
}

ModuleGraph ModuleGraph::Subgraph(const std::vector<ModuleId>& ids) const {
  std::set<ModuleId> keep(ids.begin(), ids.end());
  std::vector<GraphModule> modules;
  for (const GraphModule& m : modules_) {
    if (keep.count(m.id)) modules.push_back(m);
  }
  std::vector<GraphEdge> edges;
  for (const GraphEdge& e : edges_) {
    if (keep.count(e.a) && keep.count(e.b)) edges.push_back(e);
  }
  if (modules.empty()) throw Error(StatusCode::kInvalidArgument, "module graph: empty subgraph");
  const ModuleId central = keep.count(central_) ? central_ : modules.front().id;
  return ModuleGraph(central, std::move(modules), std::move(edges), up_);
}

ModuleGraph ModuleGraph::WithActivity(const std::vector<std::pair<ModuleId, bool>>& active) const {
  std::vector<GraphModule> modules = modules_;
  for (const auto& [id, on] : active) {
    const int i = Find(modules, id);
    if (i >= 0) modules[i].active = on;
  }
  return ModuleGraph(central_, std::move(modules), edges_, up_);
}

std::string ModuleGraph::Describe() const {
  std::ostringstream out;
  out << "modules (" << modules_.size() << "):";
  for (const GraphModule& m : modules_) {
    out << ' ' << m.id << (m.active ? "" : "(passive)") << (m.id == central_ ? "*" : "");
  }
  out << "\nconnections (" << edges_.size() << "):\n";
  for (const GraphEdge& e : edges_) {
    out << "  " << e.a << '.' << ConnectorName(e.a_connector) << " - " << e.b << '.'
        << ConnectorName(e.b_connector) << " at " << e.angle_steps * 15 << " deg\n";
  }
  return out.str();
}

std::vector<std::pair<ModuleId, bool>> ActivityFromConfig(const RobotConfig& config,
                                                          const std::vector<ModuleId>& ids) {
  std::vector<std::pair<ModuleId, bool>> out;
  for (ModuleId id : ids) {
    const ModuleParams* m = config.FindModule(id);
    out.emplace_back(id, m && !(m->amplitude == 0.0 && m->offset == 0.0 && m->speed == 0.0));
  }
  return out;
}

}  // namespace yamor::cpg
