// CPG integration cost: one classic RK4 step of the whole network per
// iteration, reported as oscillator-steps/s (items = steps x modules).
//
// Each case runs twice: `cpg_rk4_step/<topology>/<n>` uses yamor::cpg::Step
// (CSR couplings, structure-of-arrays state, preallocated scratch), and
// `cpg_rk4_step_baseline/<topology>/<n>` a deliberately naive version of the
// same equations written the obvious way: per-module records in a std::map
// keyed by id, a dense N x N coupling matrix evaluated term by term (zero
// weights included), and fresh vectors for every RK4 stage. tools/bench/run.sh
// pairs `X_baseline/...` with `X/...` and prints the ratio.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "cpg/network.h"

namespace {

using yamor::cpg::Coupling;
using yamor::cpg::ModuleId;
using yamor::cpg::ModuleParams;
using yamor::cpg::Network;
using yamor::cpg::NetworkState;
using yamor::cpg::RobotConfig;

constexpr double kDt = 0.001;

enum class Topology { kRing, kChain };

const char* Name(Topology topology) {
  return topology == Topology::kRing ? "ring" : "chain";
}

// n modules (ids 1..n) with bidirectional nearest-neighbour couplings; the
// ring closes the loop. Parameters vary per module so no work is trivial.
RobotConfig MakeConfig(Topology topology, int n) {
  RobotConfig config;
  for (int k = 0; k < n; ++k) {
    ModuleParams module;
    module.id = k + 1;
    module.amplitude = 0.3 + 0.01 * k;
    module.offset = 0.05 * ((k % 3) - 1);
    module.speed = 0.8 + 0.002 * k;
    module.min_angle = -1.2;
    module.max_angle = 1.2;
    config.modules.push_back(module);
  }
  const int links = topology == Topology::kRing ? n : n - 1;
  for (int k = 0; k < links; ++k) {
    const ModuleId a = k + 1;
    const ModuleId b = (k + 1) % n + 1;
    const double bias = 2.0 * std::numbers::pi / n;
    config.couplings.push_back(Coupling{a, b, bias, 1.0});
    config.couplings.push_back(Coupling{b, a, -bias, 1.0});
  }
  return config;
}

// ---------------------------------------------------------------- baseline --

class NaiveCpg {
 public:
  struct Oscillator {
    double phase = 0, r = 0, dr = 0, x = 0, dx = 0;
  };

  explicit NaiveCpg(const RobotConfig& config) {
    const std::size_t n = config.modules.size();
    weight_.assign(n, std::vector<double>(n, 0.0));
    bias_.assign(n, std::vector<double>(n, 0.0));
    for (std::size_t i = 0; i < n; ++i) {
      ids_.push_back(config.modules[i].id);
      params_[config.modules[i].id] = config.modules[i];
      state_[config.modules[i].id] = Oscillator{};
    }
    for (const Coupling& c : config.couplings) {
      const std::size_t i = Position(c.from), j = Position(c.to);
      weight_[i][j] += c.weight;
      bias_[i][j] = c.phase;
    }
  }

  void SetPhases(const std::vector<double>& phases) {
    for (std::size_t i = 0; i < ids_.size(); ++i) state_[ids_[i]].phase = phases[i];
  }

  void Step(double dt) {
    const std::map<ModuleId, Oscillator> k1 = Slopes(state_);
    const std::map<ModuleId, Oscillator> k2 = Slopes(Advance(state_, k1, dt / 2));
    const std::map<ModuleId, Oscillator> k3 = Slopes(Advance(state_, k2, dt / 2));
    const std::map<ModuleId, Oscillator> k4 = Slopes(Advance(state_, k3, dt));
    for (ModuleId id : ids_) {
      Oscillator& s = state_[id];
      s.phase += dt / 6 * (k1.at(id).phase + 2 * k2.at(id).phase + 2 * k3.at(id).phase + k4.at(id).phase);
      s.r += dt / 6 * (k1.at(id).r + 2 * k2.at(id).r + 2 * k3.at(id).r + k4.at(id).r);
      s.dr += dt / 6 * (k1.at(id).dr + 2 * k2.at(id).dr + 2 * k3.at(id).dr + k4.at(id).dr);
      s.x += dt / 6 * (k1.at(id).x + 2 * k2.at(id).x + 2 * k3.at(id).x + k4.at(id).x);
      s.dx += dt / 6 * (k1.at(id).dx + 2 * k2.at(id).dx + 2 * k3.at(id).dx + k4.at(id).dx);
    }
  }

  const Oscillator& state(ModuleId id) const { return state_.at(id); }

 private:
  std::size_t Position(ModuleId id) const {
    for (std::size_t i = 0; i < ids_.size(); ++i) {
      if (ids_[i] == id) return i;
    }
    return 0;
  }

  std::map<ModuleId, Oscillator> Advance(const std::map<ModuleId, Oscillator>& y,
                                         const std::map<ModuleId, Oscillator>& k,
                                         double h) const {
    std::map<ModuleId, Oscillator> out;
    for (const auto& [id, s] : y) {
      const Oscillator& d = k.at(id);
      out[id] = Oscillator{s.phase + h * d.phase, s.r + h * d.r, s.dr + h * d.dr,
                           s.x + h * d.x, s.dx + h * d.dx};
    }
    return out;
  }

  std::map<ModuleId, Oscillator> Slopes(const std::map<ModuleId, Oscillator>& y) const {
    std::map<ModuleId, Oscillator> out;
    for (std::size_t i = 0; i < ids_.size(); ++i) {
      const ModuleParams& p = params_.at(ids_[i]);
      const Oscillator& s = y.at(ids_[i]);
      double phase_rate = 2 * std::numbers::pi * p.speed;
      for (std::size_t j = 0; j < ids_.size(); ++j) {
        const Oscillator& other = y.at(ids_[j]);
        phase_rate += weight_[i][j] * other.r * std::sin(other.phase - s.phase - bias_[i][j]);
      }
      out[ids_[i]] = Oscillator{phase_rate, s.dr, 4 * (1 * (p.amplitude - s.r) - s.dr), s.dx,
                                4 * (1 * (p.offset - s.x) - s.dx)};
    }
    return out;
  }

  std::vector<ModuleId> ids_;
  std::map<ModuleId, ModuleParams> params_;
  std::map<ModuleId, Oscillator> state_;
  std::vector<std::vector<double>> weight_;
  std::vector<std::vector<double>> bias_;
};

// ------------------------------------------------------------------ cases --

void BenchNetwork(benchmark::State& bench, Topology topology, int n) {
  const Network network = Network::Compile(MakeConfig(topology, n));
  NetworkState state = network.InitialState(1);
  for (auto _ : bench) {
    yamor::cpg::Step(network, state, kDt);
    benchmark::DoNotOptimize(state.phase.data());
    benchmark::ClobberMemory();
  }
  bench.SetItemsProcessed(bench.iterations() * n);
}

void BenchBaseline(benchmark::State& bench, Topology topology, int n) {
  const RobotConfig config = MakeConfig(topology, n);
  const Network network = Network::Compile(config);
  NetworkState reference = network.InitialState(1);
  NaiveCpg naive(config);
  naive.SetPhases(reference.phase);
  // Guard the comparison: both must compute the same dynamics.
  for (int k = 0; k < 100; ++k) {
    yamor::cpg::Step(network, reference, kDt);
    naive.Step(kDt);
  }
  for (int i = 0; i < n; ++i) {
    const NaiveCpg::Oscillator& s = naive.state(i + 1);
    if (std::abs(s.phase - reference.phase[i]) > 1e-9 || std::abs(s.r - reference.r[i]) > 1e-9 ||
        std::abs(s.x - reference.x[i]) > 1e-9) {
      bench.SkipWithError("baseline disagrees with yamor::cpg::Step");
      return;
    }
  }
  for (auto _ : bench) {
    naive.Step(kDt);
    benchmark::ClobberMemory();
  }
  bench.SetItemsProcessed(bench.iterations() * n);
}

}  // namespace

int main(int argc, char** argv) {
  for (const Topology topology : {Topology::kRing, Topology::kChain}) {
    for (const int n : {8, 64}) {
      const std::string suffix = std::string("/") + Name(topology) + "/" + std::to_string(n);
      benchmark::RegisterBenchmark(("cpg_rk4_step" + suffix).c_str(), BenchNetwork, topology, n);
      benchmark::RegisterBenchmark(("cpg_rk4_step_baseline" + suffix).c_str(), BenchBaseline,
                                   topology, n);
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
