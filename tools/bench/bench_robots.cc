#include "tools/bench/bench_robots.h"

#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace yamor::bench {

cpg::RobotConfig Table61Gait(const cpg::RobotConfig& base, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  constexpr double kPi = std::numbers::pi;
  const double hip_amplitude = unit(rng) * kPi / 4;
  const double knee_amplitude = unit(rng) * kPi / 2;
  const double knee_offset = -unit(rng) * kPi / 2;
  const double inside_out = unit(rng) * 2 * kPi;
  double lag[4];
  for (int i = 0; i < 3; ++i) lag[i] = unit(rng) * 2 * kPi;
  lag[3] = std::remainder(-(lag[0] + lag[1] + lag[2]), 2 * kPi);  // closes the hip ring
  cpg::RobotConfig config = base;
  for (auto& m : config.modules) {
    if (m.id < 4) m.amplitude = hip_amplitude;
    if (m.id > 4) {
      m.amplitude = knee_amplitude;
      m.offset = knee_offset;
    }
  }
  for (auto& c : config.couplings) {
    if (c.from < 4 && c.to < 4) {
      c.phase = c.to == (c.from + 1) % 4 ? lag[c.from] : -lag[c.to];
    } else {
      c.phase = c.from < 4 ? inside_out : -inside_out;  // hip -> knee, knee -> hip
    }
  }
  return config;
}

physics::Morphology SnakeMorphology(int n) {
  std::vector<physics::MorphologyModule> modules;
  std::vector<physics::MorphologyConnection> connections;
  for (int id = 0; id < n; ++id) {
    modules.push_back({.id = id});
    if (id > 0) {
      connections.push_back({.from = id,
                             .from_connector = physics::ConnectorId::kFront,
                             .to = id - 1,
                             .to_connector = physics::ConnectorId::kRear});
    }
  }
  return physics::Morphology::Build(0, std::move(modules), std::move(connections),
                                    Eigen::Vector3d::Zero(), "snake" + std::to_string(n));
}

cpg::RobotConfig SnakeConfig(int n) {
  cpg::RobotConfig config;
  config.master_id = 0;
  for (int id = 0; id < n; ++id) {
    const bool active = id > 0;
    config.modules.push_back(
        {.id = id, .amplitude = active ? 0.6 : 0.0, .speed = active ? 0.6 : 0.0});
    if (id > 0) config.bluetooth_parent[id] = id - 1;
  }
  for (int id = 1; id < n; ++id) {
    if (id + 1 < n) {
      config.couplings.push_back({.from = id, .to = id + 1, .phase = std::numbers::pi / 2});
    }
    if (id > 1) {
      config.couplings.push_back({.from = id, .to = id - 1, .phase = -std::numbers::pi / 2});
    }
  }
  return config;
}

}  // namespace yamor::bench
