// The start point of a generated problem (docs/cpg_build.md §6 "Warm start"
// and "The base is the start point", rule 3): see cpg/problem_steps.h.
#include "cpg/problem_steps.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace yamor::cpg {
namespace {

constexpr double kPi = std::numbers::pi;

// Start values the base does not give are clamped into their module's
// limits; the base's own values are kept as they are.
void ClampNewAmplitude(ModuleParams& p, const RobotConfig& base) {
  if (!base.FindModule(p.id)) p.amplitude = std::clamp(p.amplitude, 0.0, AmplitudeMax(p));
}

void ClampNewOffset(ModuleParams& p, const RobotConfig& base) {
  if (!base.FindModule(p.id)) p.offset = std::clamp(p.offset, p.min_angle, p.max_angle);
}

}  // namespace

double AmplitudeMax(const ModuleParams& m) {
  return std::min(kPi / 2, std::max(0.0, (m.max_angle - m.min_angle) / 2));
}

double ParameterValue(const RobotConfig& robot, const std::string& param) {
  const auto dot = param.find('.');
  const std::string kind = param.substr(0, dot);
  const std::string rest = param.substr(dot + 1);
  if (kind == "phase") {
    const auto dot2 = rest.find('.');
    const Coupling* c = robot.FindCoupling(std::stoi(rest.substr(0, dot2)), std::stoi(rest.substr(dot2 + 1)));
    return c ? c->phase : 0.0;
  }
  const ModuleParams* p = robot.FindModule(std::stoi(rest));
  return kind == "amplitude" ? p->amplitude : p->offset;
}

RobotConfig WarmStart(const ModuleGraph& graph, const CpgNetwork& network, const RobotConfig& base,
                      const ProblemOptions& options) {
  double speed = options.default_speed;
  std::map<double, int> speeds;
  for (const ModuleParams& m : base.modules) {
    if (m.speed > 0) ++speeds[m.speed];
  }
  int most = 0;
  for (const auto& [s, count] : speeds) {
    if (count > most) {
      most = count;
      speed = s;
    }
  }
  RobotConfig config = NetworkConfig(graph, network, options.default_amplitude, speed,
                                     base.master_id);
  const std::set<ModuleId> oscillators(network.oscillators.begin(), network.oscillators.end());
  for (ModuleParams& m : config.modules) {
    if (!oscillators.count(m.id)) continue;
    if (const ModuleParams* old = base.FindModule(m.id)) {
      m = *old;
      continue;
    }
    for (ModuleId n : graph.Neighbours(m.id)) {
      const ModuleParams* near = base.FindModule(n);
      if (near && oscillators.count(n) && near->speed > 0) {
        m.amplitude = near->amplitude;
        m.min_angle = near->min_angle;
        m.max_angle = near->max_angle;
        break;
      }
    }
  }
  for (Coupling& c : config.couplings) {
    if (const Coupling* old = base.FindCoupling(c.from, c.to)) {
      c.phase = old->phase;
      c.weight = old->weight;
    }
  }
  return config;
}

RobotConfig WarmStartProblem(const ModuleGraph& graph, const CpgNetwork& network, const RobotConfig& base,
                             const std::set<ModuleId>& driven, const ParameterTies& ties,
                             const ProblemOptions& options) {
  RobotConfig robot = WarmStart(graph, network, base, options);
  for (ModuleParams& p : robot.modules) {
    if (!driven.count(p.id)) continue;
    ClampNewAmplitude(p, base);
    ClampNewOffset(p, base);
  }
  // New modules take their orbit's values (offset and limits mirrored by
  // the servo sign).
  for (const auto& [rep, members] : ties.offsets) {
    const ModuleParams* known = nullptr;
    int known_sign = 1;
    for (const auto& [id, sign] : members) {
      if ((known = base.FindModule(id))) {
        known_sign = sign;
        break;
      }
    }
    if (!known) continue;
    for (const auto& [id, sign] : members) {
      if (base.FindModule(id)) continue;
      ModuleParams* p = robot.FindModule(id);
      const int rel = sign * known_sign;
      p->amplitude = known->amplitude;
      p->offset = rel * known->offset;
      p->speed = known->speed;
      p->min_angle = rel > 0 ? known->min_angle : -known->max_angle;
      p->max_angle = rel > 0 ? known->max_angle : -known->min_angle;
    }
  }
  // New couplings take their class's phase.
  const std::vector<EdgeTie>& phase_ties = ties.phases;
  const int m = static_cast<int>(network.edges.size());
  for (int e = 0; e < m; ++e) {
    const NetworkEdge& ne = network.edges[e];
    if (base.FindCoupling(ne.u, ne.v)) continue;
    for (int k = 0; k < m; ++k) {
      const NetworkEdge& nk = network.edges[k];
      const Coupling* old = base.FindCoupling(nk.u, nk.v);
      if (!old || phase_ties[k].cls != phase_ties[e].cls) continue;
      // x_k = s_k·y + p_k·π → y = s_k·(x_k − p_k·π); x_e = s_e·y + p_e·π
      const double y = phase_ties[k].sign * (old->phase - phase_ties[k].pi * kPi);
      const double x = phase_ties[e].sign * y + phase_ties[e].pi * kPi;
      robot.FindCoupling(ne.u, ne.v)->phase = x;
      robot.FindCoupling(ne.v, ne.u)->phase = -x;
      break;
    }
  }
  // Phases are angles: start them in [0, 2π), the bounds of a free phase.
  for (Coupling& c : robot.couplings) {
    c.phase = std::fmod(c.phase, 2 * kPi);
    if (c.phase < 0) c.phase += 2 * kPi;
    if (c.phase >= 2 * kPi) c.phase = 0;
  }
  return robot;
}

BaseClasses StartTiedMembersTogether(RobotConfig& robot, const AmplitudeClasses& amplitudes,
                                     const OffsetClasses& offsets, const RobotConfig& base) {
  // Tied members start where their representative is, or where the base
  // puts the class (its configured members agree, SplitTiesTheBaseContradicts
  // made sure).
  BaseClasses out;
  for (const auto& [rep, members] : amplitudes) {
    const auto known = std::find_if(members.begin(), members.end(),
                                    [&](ModuleId id) { return base.FindModule(id) != nullptr; });
    const double a = robot.FindModule(known != members.end() ? *known : rep)->amplitude;
    if (known != members.end()) out.amplitudes.insert(rep);
    for (ModuleId id : members) robot.FindModule(id)->amplitude = a;
  }
  for (const auto& [rep, members] : offsets) {
    const auto known = std::find_if(members.begin(), members.end(),
                                    [&](const auto& x) { return base.FindModule(x.first) != nullptr; });
    const auto& [kid, ksign] = known != members.end() ? *known : members.front();
    const double o = ksign * robot.FindModule(kid)->offset;  // the representative's offset
    if (known != members.end()) out.offsets.insert(rep);
    for (const auto& [id, sign] : members) robot.FindModule(id)->offset = sign * o;
  }
  for (const auto& [rep, members] : amplitudes) {
    if (out.amplitudes.count(rep)) continue;
    for (ModuleId id : members) ClampNewAmplitude(*robot.FindModule(id), base);
  }
  for (const auto& [rep, members] : offsets) {
    if (out.offsets.count(rep)) continue;
    for (const auto& [id, sign] : members) ClampNewOffset(*robot.FindModule(id), base);
  }
  return out;
}

void WidenBoxesToBase(Candidates& free, const BaseClasses& base_classes, const RobotConfig& robot) {
  for (auto* group : {&free.amplitudes, &free.offsets}) {
    const std::set<ModuleId>& known = group == &free.amplitudes ? base_classes.amplitudes : base_classes.offsets;
    for (FreeParameter& c : *group) {
      if (!known.count(std::stoi(c.param.substr(c.param.find('.') + 1)))) continue;
      const double v = ParameterValue(robot, c.param);
      c.min = std::min(c.min, v);
      c.max = std::max(c.max, v);
    }
  }
}

}  // namespace yamor::cpg
