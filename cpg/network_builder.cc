#include "cpg/network_builder.h"

#include <algorithm>
#include <deque>
#include <map>
#include <numeric>
#include <set>

#include "common/status.h"

namespace yamor::cpg {
namespace {

// Union-find over a small id set.
class Joins {
 public:
  int Root(int v) {
    auto it = parent_.find(v);
    if (it == parent_.end()) return parent_[v] = v;
    if (it->second == v) return v;
    return it->second = Root(it->second);
  }
  void Join(int a, int b) { parent_[Root(a)] = Root(b); }

 private:
  std::map<int, int> parent_;
};

void AddEdge(std::set<std::pair<ModuleId, ModuleId>>& seen, std::vector<NetworkEdge>& edges,
             ModuleId a, ModuleId b, bool physical, ModuleId via) {
  if (a == b) return;
  const auto key = std::minmax(a, b);
  if (!seen.insert({key.first, key.second}).second) return;
  edges.push_back({.u = key.first, .v = key.second, .physical = physical, .via = via});
}

}  // namespace

const NetworkEdge* CpgNetwork::FindEdge(ModuleId a, ModuleId b) const {
  const auto key = std::minmax(a, b);
  for (const NetworkEdge& e : edges) {
    if (e.u == key.first && e.v == key.second) return &e;
  }
  return nullptr;
}

CpgNetwork BuildNetwork(const ModuleGraph& graph, const NetworkOptions& options) {
  const auto pieces = graph.Components();
  CpgNetwork net;
  net.piece = pieces.front();
  for (size_t i = 1; i < pieces.size(); ++i) {
    net.ignored.insert(net.ignored.end(), pieces[i].begin(), pieces[i].end());
  }
  std::sort(net.ignored.begin(), net.ignored.end());
  const std::set<ModuleId> in_piece(net.piece.begin(), net.piece.end());
  auto active = [&](ModuleId id) { return graph.Module(id).active; };

  bool any_active = false;
  for (ModuleId id : net.piece) any_active = any_active || active(id);
  if (!any_active) {
    std::string ids;
    for (ModuleId id : net.piece) {
      if (!ids.empty()) ids += ", ";
      ids += std::to_string(id);
    }
    throw Error(StatusCode::kInvalidArgument,
                "CPG network: the largest connected piece (modules " + ids +
                    ") has no driven module; nothing to oscillate");
  }

  std::set<std::pair<ModuleId, ModuleId>> seen;
  std::vector<GraphEdge> edges;  // edges inside the piece, sorted for determinism
  for (const GraphEdge& e : graph.edges()) {
    if (in_piece.count(e.a)) edges.push_back(e);
  }
  std::sort(edges.begin(), edges.end(), [](const GraphEdge& x, const GraphEdge& y) {
    return std::minmax(x.a, x.b) < std::minmax(y.a, y.b);
  });

  if (!options.couple_across_passive) {
    net.oscillators = net.piece;
    for (const GraphEdge& e : edges) AddEdge(seen, net.edges, e.a, e.b, true, -1);
  } else {
    for (ModuleId id : net.piece) (active(id) ? net.oscillators : net.passive).push_back(id);
    for (const GraphEdge& e : edges) {
      if (active(e.a) && active(e.b)) AddEdge(seen, net.edges, e.a, e.b, true, -1);
    }
    // Pieces of passive modules and the driven modules around each.
    Joins passive_pieces;
    for (ModuleId id : net.passive) passive_pieces.Root(id);
    for (const GraphEdge& e : edges) {
      if (!active(e.a) && !active(e.b)) passive_pieces.Join(e.a, e.b);
    }
    std::map<int, std::vector<ModuleId>> members;
    for (ModuleId id : net.passive) members[passive_pieces.Root(id)].push_back(id);
    for (auto& [root, ids] : members) {
      // (passive module, its connector, driven neighbour) around this piece.
      struct Attachment {
        ModuleId passive;
        Connector connector;
        ModuleId driven;
      };
      std::vector<Attachment> around;
      const std::set<ModuleId> piece_ids(ids.begin(), ids.end());
      for (const GraphEdge& e : edges) {
        if (piece_ids.count(e.a) && active(e.b)) around.push_back({e.a, e.a_connector, e.b});
        if (piece_ids.count(e.b) && active(e.a)) around.push_back({e.b, e.b_connector, e.a});
      }
      std::sort(around.begin(), around.end(), [](const Attachment& x, const Attachment& y) {
        return std::tie(x.driven, x.connector) < std::tie(y.driven, y.connector);
      });
      const ModuleId via = ids.front();
      if (ids.size() > 1) {
        for (size_t i = 0; i < around.size(); ++i) {
          for (size_t j = i + 1; j < around.size(); ++j) {
            AddEdge(seen, net.edges, around[i].driven, around[j].driven, false, via);
          }
        }
        continue;
      }
      // One passive module: adjacent faces first, opposite faces to join
      // what is still apart.
      Joins linked;
      for (const Attachment& x : around) linked.Root(x.driven);
      for (size_t i = 0; i < around.size(); ++i) {
        for (size_t j = i + 1; j < around.size(); ++j) {
          if (OppositeConnector(around[i].connector) == around[j].connector) continue;
          AddEdge(seen, net.edges, around[i].driven, around[j].driven, false, via);
          linked.Join(around[i].driven, around[j].driven);
        }
      }
      for (size_t i = 0; i < around.size(); ++i) {
        for (size_t j = i + 1; j < around.size(); ++j) {
          if (linked.Root(around[i].driven) == linked.Root(around[j].driven)) continue;
          AddEdge(seen, net.edges, around[i].driven, around[j].driven, false, via);
          linked.Join(around[i].driven, around[j].driven);
        }
      }
    }
  }
  std::sort(net.edges.begin(), net.edges.end(), [](const NetworkEdge& x, const NetworkEdge& y) {
    return std::tie(x.u, x.v) < std::tie(y.u, y.v);
  });
  return net;
}

RobotConfig NetworkConfig(const ModuleGraph& graph, const CpgNetwork& network, double amplitude,
                          double speed, ModuleId master) {
  RobotConfig config;
  const std::set<ModuleId> oscillators(network.oscillators.begin(), network.oscillators.end());
  for (ModuleId id : network.piece) {
    ModuleParams m{.id = id};
    if (oscillators.count(id)) {
      m.amplitude = amplitude;
      m.speed = speed;
    }
    config.modules.push_back(m);
  }
  for (const NetworkEdge& e : network.edges) {
    config.couplings.push_back({.from = e.u, .to = e.v, .phase = 0.0, .weight = 1.0});
    config.couplings.push_back({.from = e.v, .to = e.u, .phase = 0.0, .weight = 1.0});
  }
  std::sort(config.couplings.begin(), config.couplings.end(),
            [](const Coupling& x, const Coupling& y) {
              return std::tie(x.from, x.to) < std::tie(y.from, y.to);
            });
  const std::set<ModuleId> piece(network.piece.begin(), network.piece.end());
  if (!piece.count(master)) master = piece.count(graph.central()) ? graph.central() : network.piece.front();
  config.master_id = master;
  std::set<ModuleId> reached{master};
  std::deque<ModuleId> queue{master};
  while (!queue.empty()) {
    const ModuleId at = queue.front();
    queue.pop_front();
    for (ModuleId next : graph.Neighbours(at)) {
      if (!piece.count(next) || !reached.insert(next).second) continue;
      config.bluetooth_parent[next] = at;
      queue.push_back(next);
    }
  }
  return config;
}

}  // namespace yamor::cpg
