// yamor-cpg-build: from body to brain (thesis 7.4, 7.8.1). Turns a
// morphology (a file, a built-in world, or a daemon's current robot) and an
// optional base configuration into a robot configuration and an optimization
// configuration that yamor-optimize runs. See docs/cpg_build.md.
#include <chrono>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/problem.h"
#include "host/worlds.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "physics/module_graph.h"
#include "physics/morphology.h"
#include "yamor/v1/host.grpc.pb.h"

namespace {

using yamor::Error;
using yamor::StatusCode;

struct Source {
  std::optional<yamor::physics::Morphology> morphology;
  std::optional<yamor::cpg::RobotConfig> config;
};

Source FromDaemon(const std::string& address, double timeout_s) {
  yamor::client::HostClient host(address, timeout_s);
  Source out;
  const google::protobuf::Empty empty;
  out.morphology = yamor::physics::Morphology::Parse(
      host.Call(&yamor::v1::Host::Stub::GetMorphology, empty, "GetMorphology").morphology_xml(), address);
  try {
    const yamor::v1::SaveConfigResponse saved =
        host.Call(&yamor::v1::Host::Stub::SaveConfig, empty, "SaveConfig");
    if (!saved.config_xml().empty()) out.config = yamor::cpg::ParseConfigXml(saved.config_xml(), address);
  } catch (const Error& e) {
    if (e.code() != StatusCode::kFailedPrecondition) throw;  // no configuration loaded: none to keep
  }
  return out;
}

std::vector<int> ParseIds(const std::string& text, const std::string& what) {
  std::vector<int> ids;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      size_t used = 0;
      const int id = std::stoi(item, &used);
      if (used != item.size()) throw std::invalid_argument(item);
      ids.push_back(id);
    } catch (const std::exception&) {
      throw Error(StatusCode::kInvalidArgument, what + ": \"" + item + "\" is not a module id");
    }
  }
  return ids;
}

std::vector<std::pair<int, int>> ParseEdges(const std::vector<std::string>& items) {
  std::vector<std::pair<int, int>> out;
  for (const std::string& item : items) {
    const auto dash = item.find('-');
    if (dash == std::string::npos) {
      throw Error(StatusCode::kInvalidArgument, "--keep-free: \"" + item + "\" is not A-B");
    }
    const auto a = ParseIds(item.substr(0, dash), "--keep-free");
    const auto b = ParseIds(item.substr(dash + 1), "--keep-free");
    if (a.size() != 1 || b.size() != 1) {
      throw Error(StatusCode::kInvalidArgument, "--keep-free: \"" + item + "\" is not A-B");
    }
    out.push_back({a[0], b[0]});
  }
  return out;
}

void Write(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw Error(StatusCode::kUnavailable, "cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"yamor-cpg-build: generate a CPG network and an optimization problem from a morphology"};
  std::string world, morphology_file, daemon, base_file, passive, driven, output, robot_output;
  std::vector<std::string> keep_free;
  bool explain = false, key_only = false, keep_inactive = false, no_symmetry = false, impose_symmetry = false,
       no_mirrors = false, ignore_gravity = false;
  int max_free = 7;
  uint64_t seed = 1;
  double timeout = 10;
  auto* source = app.add_option_group("source", "where the morphology comes from (one of)");
  source->add_option("--world", world, "a built-in world (quadruped, snake, ...) or a world file");
  source->add_option("--morphology", morphology_file, "a morphology XML file (docs/module.md)");
  source->add_option("--daemon", daemon, "HOST:PORT of a yamord: its robot as it is now");
  source->require_option(1);
  app.add_option("--base", base_file,
                 "robot configuration to warm-start from and take limit angles and passive modules "
                 "from (default: the world's or the daemon's own)");
  app.add_option("--passive", passive, "comma-separated module ids that are passive (no oscillator)");
  app.add_option("--driven", driven,
                 "comma-separated module ids that are driven even where the base configuration "
                 "leaves them out or all zero (a module just added)");
  app.add_flag("--keep-inactive", keep_inactive,
               "thesis-literal network: passive modules keep an oscillator, couple physical edges only");
  app.add_flag("--no-symmetry", no_symmetry, "do not tie parameters across symmetries");
  app.add_flag("--impose-symmetry", impose_symmetry,
               "tie symmetric parameters even where --base contradicts the tie (start: the base projected)");
  app.add_flag("--no-mirrors", no_mirrors, "rotations only: ignore mirror images");
  app.add_flag("--ignore-gravity", ignore_gravity, "also use symmetries that turn the robot over");
  app.add_option("--max-free", max_free, "budget of free parameters")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "seed of the budget rule");
  app.add_option("--keep-free", keep_free, "coupling A-B whose phase must stay free (repeatable)");
  app.add_option("-o,--output", output, "write the optimization configuration here (default: stdout)");
  app.add_option("--robot-output", robot_output, "also write the plain robot configuration here");
  app.add_flag("--explain", explain, "print the graph, orbits, loops, constraints and the free set");
  app.add_flag("--key", key_only, "print the morphology key only");
  app.add_option("--timeout", timeout, "seconds per daemon call")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    Source src;
    if (!daemon.empty()) {
      src = FromDaemon(daemon, timeout);
    } else if (!morphology_file.empty()) {
      src.morphology = yamor::physics::Morphology::LoadFile(morphology_file);
    } else {
      auto resolved = yamor::host::ResolveWorld({.world = world}, "", /*allow_files=*/true);
      src.morphology = std::move(resolved.morphology);
      src.config = std::move(resolved.config);
    }
    if (!base_file.empty()) src.config = yamor::cpg::LoadConfigFile(base_file);
    std::vector<std::pair<int, bool>> activity;
    if (src.config) {
      std::vector<int> ids;
      for (const auto& m : src.morphology->modules()) ids.push_back(m.id);
      activity = yamor::cpg::ActivityFromConfig(*src.config, ids);
    }
    if (!driven.empty()) {
      for (int id : ParseIds(driven, "--driven")) {
        if (!src.morphology->Contains(id)) {
          throw Error(StatusCode::kNotFound, "--driven: module " + std::to_string(id) + " is not in the morphology");
        }
        activity.emplace_back(id, true);
      }
    }
    if (!passive.empty()) {
      for (int id : ParseIds(passive, "--passive")) {
        if (!src.morphology->Contains(id)) {
          throw Error(StatusCode::kNotFound, "--passive: module " + std::to_string(id) + " is not in the morphology");
        }
        activity.emplace_back(id, false);
      }
    }
    const yamor::cpg::ModuleGraph graph = yamor::physics::ModuleGraphOf(*src.morphology, activity);
    if (key_only) {
      std::cout << yamor::cpg::MorphologyKey(graph) << "\n";
      return 0;
    }
    yamor::cpg::ProblemOptions options;
    options.network.couple_across_passive = !keep_inactive;
    options.use_symmetry = !no_symmetry;
    options.impose_symmetry = impose_symmetry;
    options.symmetry.mirrors = !no_mirrors;
    options.symmetry.respect_gravity = !ignore_gravity;
    options.max_free = max_free;
    options.seed = seed;
    options.keep_free = ParseEdges(keep_free);
    const auto problem = yamor::cpg::GenerateProblem(graph, src.config ? &*src.config : nullptr, options);
    const std::string xml = problem.OptimizationXml();
    if (!robot_output.empty()) Write(robot_output, yamor::cpg::WriteConfigXml(problem.robot));
    if (!output.empty()) {
      Write(output, xml);
    } else if (!explain) {
      std::cout << xml;
    }
    if (explain) std::cout << problem.Explain();
    return 0;
  } catch (const Error& e) {
    std::cerr << "yamor-cpg-build: " << yamor::StatusCodeName(e.code()) << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "yamor-cpg-build: " << e.what() << "\n";
    return 1;
  }
}
