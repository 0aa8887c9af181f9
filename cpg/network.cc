#include "cpg/network.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include "common/status.h"

namespace yamor::cpg {
namespace {

constexpr std::size_t kComponents = 5;  // phase, r, dr, x, dx
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Integrate() refuses durations that would need more steps than this.
constexpr double kMaxIntegrateSteps = 1e12;

std::string Describe(double value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}

std::string ModuleContext(const RobotConfig& config, ModuleId id) {
  std::string prefix;
  if (auto it = config.module_locations.find(id);
      it != config.module_locations.end() && !it->second.file.empty()) {
    prefix = it->second.file + ":" + std::to_string(it->second.line) + ": ";
  }
  return prefix + "module " + std::to_string(id);
}

void RequireFinite(double value, const std::string& context,
                   const char* attribute) {
  if (!std::isfinite(value)) {
    throw Error(StatusCode::kInvalidArgument,
                context + ": " + attribute + " is " + Describe(value) +
                    " (must be finite)");
  }
}

void RequireMatchingState(const Network& network, const NetworkState& state) {
  const std::size_t n = network.size();
  if (state.phase.size() != n || state.r.size() != n || state.dr.size() != n ||
      state.x.size() != n || state.dx.size() != n || state.enabled.size() != n) {
    throw Error(StatusCode::kInvalidArgument,
                "network state holds " + std::to_string(state.phase.size()) +
                    " oscillators (or inconsistent vectors) but the network has " +
                    std::to_string(n));
  }
}

void RequireIndex(const Network& network, const NetworkState& state,
                  std::size_t index) {
  if (index >= network.size()) {
    throw Error(StatusCode::kOutOfRange,
                "oscillator index " + std::to_string(index) +
                    " out of range (network has " +
                    std::to_string(network.size()) + ")");
  }
  RequireMatchingState(network, state);
}

void RequireTimeStep(double dt) {
  if (!(std::isfinite(dt) && dt > 0.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "time step dt is " + Describe(dt) + " (must be finite and > 0)");
  }
}

// Slopes of all oscillators at `y` (component arrays phase, r, dr, x, dx)
// into `k`. Disabled oscillators have zero slopes but their `y` still enters
// the coupling terms of their neighbours.
void Slopes(const Network& network, const std::vector<bool>& enabled,
            const double* const* y, double* const* k) {
  const std::size_t n = network.size();
  const double a_r = network.options().amplitude_gain;
  const double a_x = network.options().offset_gain;
  const double* phase = y[0];
  const double* r = y[1];
  const double* dr = y[2];
  const double* x = y[3];
  const double* dx = y[4];
  for (std::size_t i = 0; i < n; ++i) {
    if (!enabled[i]) {
      for (std::size_t c = 0; c < kComponents; ++c) k[c][i] = 0.0;
      continue;
    }
    double phase_rate = network.omega(i);
    const double phase_i = phase[i];
    for (const CompiledLink& link : network.LinksOf(i)) {
      phase_rate += link.weight * r[link.source] *
                    std::sin(phase[link.source] - phase_i - link.phase);
    }
    k[0][i] = phase_rate;
    k[1][i] = dr[i];
    k[2][i] = a_r * (0.25 * a_r * (network.target_amplitude(i) - r[i]) - dr[i]);
    k[3][i] = dx[i];
    k[4][i] = a_x * (0.25 * a_x * (network.target_offset(i) - x[i]) - dx[i]);
  }
}

}  // namespace

// ---------------------------------------------------------------- Network --

Network Network::Compile(const RobotConfig& config, NetworkOptions options) {
  if (!(std::isfinite(options.amplitude_gain) && options.amplitude_gain > 0.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "network option amplitude_gain is " +
                    Describe(options.amplitude_gain) + " (must be finite and > 0)");
  }
  if (!(std::isfinite(options.offset_gain) && options.offset_gain > 0.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "network option offset_gain is " + Describe(options.offset_gain) +
                    " (must be finite and > 0)");
  }

  Network network;
  network.options_ = options;
  const std::size_t n = config.modules.size();
  network.ids_.reserve(n);
  network.params_.reserve(n);
  network.index_by_id_.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const ModuleParams& module = config.modules[i];
    const std::string context = ModuleContext(config, module.id);
    RequireFinite(module.amplitude, context, "amplitude");
    RequireFinite(module.offset, context, "offset");
    RequireFinite(module.speed, context, "speed");
    RequireFinite(module.min_angle, context, "minangle");
    RequireFinite(module.max_angle, context, "maxangle");
    const double omega = kTwoPi * module.speed;
    RequireFinite(omega, context, "2*pi*speed");
    if (module.min_angle > module.max_angle) {
      throw Error(StatusCode::kInvalidArgument,
                  context + ": minangle " + Describe(module.min_angle) +
                      " is above maxangle " + Describe(module.max_angle));
    }
    network.ids_.push_back(module.id);
    network.params_.push_back(module);
    network.index_by_id_.emplace_back(module.id, i);
    network.omega_.push_back(omega);
    network.amplitude_.push_back(module.amplitude);
    network.offset_.push_back(module.offset);
    network.min_angle_.push_back(module.min_angle);
    network.max_angle_.push_back(module.max_angle);
  }
  std::sort(network.index_by_id_.begin(), network.index_by_id_.end());
  for (std::size_t i = 1; i < network.index_by_id_.size(); ++i) {
    if (network.index_by_id_[i].first == network.index_by_id_[i - 1].first) {
      throw Error(StatusCode::kInvalidArgument,
                  "module id " + std::to_string(network.index_by_id_[i].first) +
                      " appears more than once");
    }
  }

  // Couplings into CSR rows keyed by the oscillator whose equation holds the
  // term (`from`); a stable counting sort keeps config order within a row.
  std::vector<std::size_t> from_index(config.couplings.size());
  std::vector<std::size_t> source_index(config.couplings.size());
  network.link_begin_.assign(n + 1, 0);
  for (std::size_t c = 0; c < config.couplings.size(); ++c) {
    const Coupling& coupling = config.couplings[c];
    const std::string context = "coupling " + std::to_string(coupling.from) +
                                " -> " + std::to_string(coupling.to);
    const auto from = network.FindIndex(coupling.from);
    if (!from) {
      throw Error(StatusCode::kNotFound,
                  context + ": module " + std::to_string(coupling.from) +
                      " is not in the configuration");
    }
    const auto to = network.FindIndex(coupling.to);
    if (!to) {
      throw Error(StatusCode::kNotFound,
                  context + ": module " + std::to_string(coupling.to) +
                      " is not in the configuration");
    }
    RequireFinite(coupling.phase, context, "phase");
    RequireFinite(coupling.weight, context, "weight");
    from_index[c] = *from;
    source_index[c] = *to;
    ++network.link_begin_[*from + 1];
  }
  for (std::size_t i = 0; i < n; ++i) {
    network.link_begin_[i + 1] += network.link_begin_[i];
  }
  network.links_.resize(config.couplings.size());
  std::vector<std::size_t> fill(network.link_begin_.begin(),
                                network.link_begin_.end() - 1);
  for (std::size_t c = 0; c < config.couplings.size(); ++c) {
    network.links_[fill[from_index[c]]++] = CompiledLink{
        source_index[c], config.couplings[c].weight, config.couplings[c].phase};
  }
  return network;
}

std::optional<std::size_t> Network::FindIndex(ModuleId id) const {
  const auto it = std::lower_bound(
      index_by_id_.begin(), index_by_id_.end(), id,
      [](const std::pair<ModuleId, std::size_t>& entry, ModuleId key) {
        return entry.first < key;
      });
  if (it == index_by_id_.end() || it->first != id) return std::nullopt;
  return it->second;
}

std::size_t Network::IndexOf(ModuleId id) const {
  if (auto index = FindIndex(id)) return *index;
  throw Error(StatusCode::kNotFound,
              "module " + std::to_string(id) + " is not in the CPG network");
}

ModuleId Network::IdAt(std::size_t index) const {
  if (index >= size()) {
    throw Error(StatusCode::kOutOfRange,
                "oscillator index " + std::to_string(index) +
                    " out of range (network has " + std::to_string(size()) + ")");
  }
  return ids_[index];
}

const ModuleParams& Network::params(std::size_t index) const {
  if (index >= size()) {
    throw Error(StatusCode::kOutOfRange,
                "oscillator index " + std::to_string(index) +
                    " out of range (network has " + std::to_string(size()) + ")");
  }
  return params_[index];
}

NetworkState Network::InitialState() const {
  NetworkState state;
  const std::size_t n = size();
  state.phase.assign(n, 0.0);
  state.r.assign(n, 0.0);
  state.dr.assign(n, 0.0);
  state.x.assign(n, 0.0);
  state.dx.assign(n, 0.0);
  state.enabled.assign(n, true);
  state.scratch.Reserve(n);
  return state;
}

NetworkState Network::InitialState(std::uint64_t seed) const {
  NetworkState state = InitialState();
  std::mt19937_64 rng(seed);
  for (double& phase : state.phase) {
    // 53 random bits -> [0, 1): exact and platform-independent, unlike
    // std::uniform_real_distribution.
    phase = static_cast<double>(rng() >> 11) * 0x1.0p-53 * kTwoPi;
  }
  return state;
}

// ------------------------------------------------------------ StepScratch --

void StepScratch::Reserve(std::size_t oscillators) {
  if (buffer_.size() < oscillators * kDoublesPerOscillator) {
    buffer_.resize(oscillators * kDoublesPerOscillator);
  }
}

// --------------------------------------------------------------- dynamics --

void Step(const Network& network, NetworkState& state, double dt) {
  RequireTimeStep(dt);
  RequireMatchingState(network, state);
  const std::size_t n = network.size();
  state.scratch.Reserve(n);

  double* const y[kComponents] = {state.phase.data(), state.r.data(),
                                  state.dr.data(), state.x.data(),
                                  state.dx.data()};
  double* const base = state.scratch.data();
  double* stage[kComponents];
  double* slope[kComponents];
  double* sum[kComponents];
  for (std::size_t c = 0; c < kComponents; ++c) {
    stage[c] = base + c * n;
    slope[c] = base + (kComponents + c) * n;
    sum[c] = base + (2 * kComponents + c) * n;
  }
  const double half = 0.5 * dt;

  // k1
  Slopes(network, state.enabled, y, slope);
  for (std::size_t c = 0; c < kComponents; ++c) {
    for (std::size_t i = 0; i < n; ++i) {
      sum[c][i] = slope[c][i];
      stage[c][i] = y[c][i] + half * slope[c][i];
    }
  }
  // k2
  Slopes(network, state.enabled, stage, slope);
  for (std::size_t c = 0; c < kComponents; ++c) {
    for (std::size_t i = 0; i < n; ++i) {
      sum[c][i] += 2.0 * slope[c][i];
      stage[c][i] = y[c][i] + half * slope[c][i];
    }
  }
  // k3
  Slopes(network, state.enabled, stage, slope);
  for (std::size_t c = 0; c < kComponents; ++c) {
    for (std::size_t i = 0; i < n; ++i) {
      sum[c][i] += 2.0 * slope[c][i];
      stage[c][i] = y[c][i] + dt * slope[c][i];
    }
  }
  // k4 and the update; disabled oscillators are left bit-for-bit untouched.
  Slopes(network, state.enabled, stage, slope);
  const double sixth = dt / 6.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!state.enabled[i]) continue;
    for (std::size_t c = 0; c < kComponents; ++c) {
      y[c][i] += sixth * (sum[c][i] + slope[c][i]);
    }
  }
  state.time += dt;
}

void Integrate(const Network& network, NetworkState& state, double duration,
               double dt) {
  RequireTimeStep(dt);
  if (!(std::isfinite(duration) && duration >= 0.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "duration is " + Describe(duration) + " (must be finite and >= 0)");
  }
  const double steps = std::floor(duration / dt);
  if (steps > kMaxIntegrateSteps) {
    throw Error(StatusCode::kInvalidArgument,
                "duration " + Describe(duration) + " at dt " + Describe(dt) +
                    " needs more than 1e12 steps");
  }
  const auto full_steps = static_cast<std::uint64_t>(steps);
  for (std::uint64_t s = 0; s < full_steps; ++s) Step(network, state, dt);
  const double remainder = duration - steps * dt;
  // Skip a remainder that is only round-off of duration/dt.
  if (remainder > 1e-9 * dt) Step(network, state, remainder);
}

double RawOutput(const Network& network, const NetworkState& state,
                 std::size_t index) {
  RequireIndex(network, state, index);
  return state.x[index] + state.r[index] * std::cos(state.phase[index]);
}

std::optional<double> SetPoint(const Network& network, const NetworkState& state,
                               std::size_t index) {
  const double raw = RawOutput(network, state, index);
  if (!state.enabled[index]) return std::nullopt;
  return std::clamp(raw, network.min_angle(index), network.max_angle(index));
}

void SetPoints(const Network& network, const NetworkState& state,
               std::vector<std::optional<double>>& out) {
  RequireMatchingState(network, state);
  const std::size_t n = network.size();
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!state.enabled[i]) {
      out[i].reset();
      continue;
    }
    const double raw = state.x[i] + state.r[i] * std::cos(state.phase[i]);
    out[i] = std::clamp(raw, network.min_angle(i), network.max_angle(i));
  }
}

NetworkState RemapState(const Network& from, const NetworkState& state,
                        const Network& to) {
  RequireMatchingState(from, state);
  NetworkState remapped = to.InitialState();
  remapped.time = state.time;
  for (std::size_t i = 0; i < to.size(); ++i) {
    const auto old = from.FindIndex(to.IdAt(i));
    if (!old) continue;
    remapped.phase[i] = state.phase[*old];
    remapped.r[i] = state.r[*old];
    remapped.dr[i] = state.dr[*old];
    remapped.x[i] = state.x[*old];
    remapped.dx[i] = state.dx[*old];
    remapped.enabled[i] = state.enabled[*old];
  }
  return remapped;
}

}  // namespace yamor::cpg
