#include "optimizer-plugins/lifelong/adaptation.h"

#include <sstream>
#include <utility>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/problem.h"
#include "cpg/symmetry.h"
#include "optimizer-plugins/framework/optimization_config.h"

namespace yamor::lifelong {
namespace {

std::string XmlAttribute(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// Fills the start point and the free list of `plan` from its problem.
void Complete(AdaptationPlan& plan) {
  const optimizer::OptimizationConfig config =
      optimizer::OptimizationConfig::Parse(plan.problem_xml, "lifelong problem");
  plan.start_config_xml = cpg::WriteConfigXml(config.Apply(config.StartValues()));
  plan.free.clear();
  for (const auto& rule : config.optimized()) plan.free.push_back(rule.param);
}

}  // namespace

cpg::ModuleGraph WithKnownActivity(const cpg::ModuleGraph& body, const std::set<int>& driven,
                                   const std::set<int>& dead) {
  std::vector<std::pair<cpg::ModuleId, bool>> activity;
  for (const cpg::GraphModule& m : body.modules()) {
    activity.emplace_back(m.id, driven.count(m.id) > 0 && dead.count(m.id) == 0);
  }
  return body.WithActivity(activity);
}

std::string RulesOver(const std::string& problem_xml, const std::string& robot_xml) {
  const optimizer::OptimizationConfig rules =
      optimizer::OptimizationConfig::Parse(problem_xml, "the current gait's problem");
  std::string xml = cpg::WriteConfigXml(cpg::ParseConfigXml(robot_xml, "the current gait"));
  const std::string close = "</yamorconfig>";
  const auto at = xml.rfind(close);
  YAMOR_CHECK(at != std::string::npos, "robot XML without </yamorconfig>");
  std::ostringstream out;
  for (const auto& r : rules.optimized()) {
    out << "  <optimize param=\"" << XmlAttribute(r.param) << "\" min=\"" << FormatDouble(r.min) << "\" max=\""
        << FormatDouble(r.max) << "\"/>\n";
  }
  for (const auto& r : rules.constrained()) {
    out << "  <constrain param=\"" << XmlAttribute(r.param) << "\" expr=\"" << XmlAttribute(r.expr) << "\"/>\n";
  }
  xml = xml.substr(0, at) + out.str() + xml.substr(at);
  // Parsing checks every rule against the new robot (kInvalidArgument).
  optimizer::OptimizationConfig::Parse(xml, "the current gait's problem over the current gait");
  return xml;
}

AdaptationPlan PlanAdaptation(const cpg::ModuleGraph& graph, const std::string& current_config_xml,
                              const std::string& current_problem_xml, bool body_changed,
                              const AdaptationOptions& options) {
  AdaptationPlan plan;
  if (!body_changed && !current_problem_xml.empty()) {
    try {
      plan.how = "same parameters";
      plan.problem_xml = RulesOver(current_problem_xml, current_config_xml);
      Complete(plan);
      plan.explanation = "body unchanged: relearning the current gait's " + std::to_string(plan.free.size()) +
                         " free parameters from the current gait";
      return plan;
    } catch (const Error& e) {
      Log().warn("lifelong: the current gait's rules do not fit it any more ({}); generating a problem", e.what());
    }
  }
  const cpg::RobotConfig base = cpg::ParseConfigXml(current_config_xml, "the current gait");
  cpg::ProblemOptions problem_options;
  problem_options.max_free = options.max_free;
  problem_options.seed = options.seed;
  problem_options.use_symmetry = options.use_symmetry;
  // Only a body change imposes the new body's ties: a gait without rules on
  // an unchanged body is the start point as it is.
  problem_options.impose_symmetry = body_changed && options.impose_symmetry;
  problem_options.network.couple_across_passive = options.couple_across_passive;
  const cpg::GeneratedProblem generated = cpg::GenerateProblem(graph, &base, problem_options);
  plan.how = body_changed ? "rebuilt" : "generated";
  plan.problem_xml = generated.OptimizationXml();
  Complete(plan);
  std::ostringstream why;
  why << (body_changed ? "body changed: CPG network rebuilt from the current body"
                       : "no usable rules: problem generated from the current body")
      << " (key " << generated.key << ", " << generated.network.oscillators.size() << " oscillators, "
      << generated.network.edges.size() << " couplings, " << generated.free.size() << " free, "
      << generated.tied.size() << " tied, " << generated.fixed.size() << " fixed), warm start from the current gait"
      << (problem_options.impose_symmetry ? " projected onto the body's symmetry ties" : "");
  plan.explanation = why.str();
  return plan;
}

}  // namespace yamor::lifelong
