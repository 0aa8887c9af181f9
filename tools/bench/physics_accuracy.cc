// Accuracy and cost of world configurations against a fine-step reference
// (issue 18, docs/benchmarks.md "Faster worlds"). A plain program, not a
// Google Benchmark: it prints one table.
//
// For every candidate configuration (the cross product of --method, --step,
// --iterations and --sor) it runs the robot's gaits through the real bridge
// path (SNP configuration frames, bridge::Robot::StepOnce) and compares the
// horizontal distance of the central module over [warm-up, warm-up +
// duration] with the same gait in the reference world (by default the exact
// solver at 0.25 ms). Robots:
//   quadruped   configs/worlds/quadruped.xml; gait 0 is configs/robots/
//               quadruped.xml, gaits 1..K random Table 6.1 gaits (seeds 1..K),
//               8 s warm-up + 12 s (DESIGN.md's gait velocity);
//   snake<N>    an N-module snake (tools/bench/bench_robots.h), its one gait,
//               2 s warm-up + 8 s;
//   NAME        any other robot with configs/worlds/NAME.xml and
//               configs/robots/NAME.xml, its configured gait, 4 s + 16 s (as
//               the acceptance tests run them).
// Per configuration it prints: gait-0 distance and error, the median |error|
// over the gaits whose reference travels more than 5 cm, how many are within
// 15 %, divergences, the median CPU time per evaluation (this thread's) and
// the servo tracking error (RMS of set-point minus angle over the powered
// servos, sampled every 10 steps after the warm-up), which shows whether the
// solver delivers the motion the servos are asked for, and the mean depth of
// the robot's lowest point below the ground (sampled likewise), which shows
// whether the contacts carry the robot.
//
// Flags (lists are comma-separated):
//   --robot=quadruped|snake<N>|NAME (quadruped)
//   --method=exact,iterative,auto   (iterative)
//   --step=S,...                    (0.002)
//   --iterations=N,...              (WorldOptions' default)
//   --sor=W,...                     (WorldOptions' default)
//   --gaits=K                       random gaits besides gait 0 (quadruped: 6)
//   --reference_method=exact|iterative (exact)   --reference_step=S (0.00025)
//   --reference_iterations=N        (200; for an iterative reference)
//   --warmup=S --duration=S
//   --cache=FILE                    reuse/store reference distances (keyed by
//                                   robot, gait, method, step, iterations, SOR,
//                                   times); candidates are never cached
//   --compare_exact                 also run the exact solver at each step
//   --csv                           one line per gait and configuration too
//   --no_reference                  skip the reference (profiling)
//   --seeds=N                       also run gait 0 with world seeds 1..N-1 (the
//                                   iterative solver's constraint order) and print
//                                   the spread of its distance over the N seeds
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "bridge/robot.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "host/config_frames.h"
#include "physics/morphology.h"
#include "physics/world.h"
#include "tools/bench/bench_robots.h"

#ifndef YAMOR_SOURCE_DIR
#error "YAMOR_SOURCE_DIR must name the repository root"
#endif

namespace {

using yamor::Error;
using yamor::StatusCode;
using yamor::cpg::RobotConfig;
using yamor::physics::Morphology;
using yamor::physics::StepMethod;
using yamor::physics::WorldOptions;

double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// One world configuration.
struct Config {
  StepMethod method = StepMethod::kIterative;
  double step = 0.002;
  int iterations = WorldOptions().iterations;
  double sor = WorldOptions().over_relaxation;
  std::uint64_t seed = 0;  // WorldOptions::seed: the iterative solver's constraint order
};

std::string MethodName(StepMethod m) {
  switch (m) {
    case StepMethod::kExact: return "exact";
    case StepMethod::kIterative: return "iterative";
    case StepMethod::kAuto: return "auto";
  }
  return "?";
}

StepMethod ParseMethod(std::string_view text) {
  if (text == "exact") return StepMethod::kExact;
  if (text == "iterative") return StepMethod::kIterative;
  if (text == "auto") return StepMethod::kAuto;
  throw Error(StatusCode::kInvalidArgument,
              "--method: '" + std::string(text) + "' is not exact, iterative or auto");
}

struct Run {
  double distance = 0;  // m
  double cpu = 0;       // s
  double servo_rms = 0; // rad
  double sink = 0;      // m, mean depth of the lowest point below the ground
  bool diverged = false;
  std::string solver;   // the method the world used (auto resolved)
};

struct Robot {
  std::string name;
  Morphology morphology;
  std::vector<RobotConfig> gaits;
  double warmup = 0;
  double duration = 0;
};

Run Evaluate(const Robot& robot, const RobotConfig& gait, const Config& c) {
  Run run;
  const double cpu_start = ThreadCpuSeconds();
  yamor::bridge::RobotOptions options;
  options.world.time_step = c.step;
  options.world.step_method = c.method;
  options.world.iterations = c.iterations;
  options.world.over_relaxation = c.sor;
  options.world.seed = c.seed;
  options.phase_seed = 1;
  options.master = gait.master_id;
  yamor::bridge::Robot sim(robot.morphology, options);
  std::vector<yamor::snp::Frame> out;
  for (const yamor::snp::Frame& frame : yamor::host::ConfigurationFrames(gait)) {
    sim.HandleFrame(frame, out);
  }
  double squared = 0, sink = 0;
  long samples = 0, sink_samples = 0;
  try {
    sim.Advance(robot.warmup, out);
    const Eigen::Vector3d from = sim.world().CentralPosition();
    const long steps = std::lround(robot.duration / c.step);
    const std::vector<int> ids = sim.world().ModuleIds();
    for (long i = 0; i < steps && !sim.world().Diverged(); ++i) {
      sim.StepOnce(out);
      out.clear();
      if (i % 10 != 0) continue;
      sink -= sim.world().LowestPoint();
      ++sink_samples;
      for (int id : ids) {
        if (!sim.world().IsConnected(id) || !sim.world().MotorEnabled(id)) continue;
        const double e = sim.world().ServoTarget(id) - sim.world().ServoAngle(id);
        squared += e * e;
        ++samples;
      }
    }
    run.distance = (sim.world().CentralPosition() - from).head<2>().norm();
  } catch (const Error&) {
    run.diverged = true;
  }
  run.diverged = run.diverged || sim.world().Diverged();
  run.servo_rms = samples > 0 ? std::sqrt(squared / static_cast<double>(samples)) : 0.0;
  run.sink = sink_samples > 0 ? sink / static_cast<double>(sink_samples) : 0.0;
  run.solver = MethodName(sim.world().ActiveStepMethod());
  run.cpu = ThreadCpuSeconds() - cpu_start;
  return run;
}

// Reference and comparison runs, kept between invocations in a text file.
class Cache {
 public:
  explicit Cache(std::string path) : path_(std::move(path)) {
    if (path_.empty()) return;
    std::ifstream in(path_);
    std::string key;
    Run r;
    int diverged = 0;
    while (in >> key >> r.distance >> diverged >> r.cpu >> r.servo_rms >> r.sink >> r.solver) {
      r.diverged = diverged != 0;
      runs_[key] = r;
    }
  }
  std::optional<Run> Find(const std::string& key) const {
    const auto it = runs_.find(key);
    if (it == runs_.end()) return std::nullopt;
    return it->second;
  }
  void Store(const std::string& key, const Run& r) {
    runs_[key] = r;
    if (path_.empty()) return;
    std::ofstream out(path_, std::ios::app);
    char line[512];
    std::snprintf(line, sizeof line, "%s %.17g %d %.6g %.6g %.6g %s\n", key.c_str(), r.distance,
                  r.diverged ? 1 : 0, r.cpu, r.servo_rms, r.sink, r.solver.c_str());
    out << line;
  }

 private:
  std::string path_;
  std::map<std::string, Run> runs_;
};

std::string Key(const Robot& robot, size_t gait, const Config& c) {
  char text[256];
  std::snprintf(text, sizeof text, "%s/gait%zu/%s/%gs/it%d/w%g/%g+%g", robot.name.c_str(), gait,
                MethodName(c.method).c_str(), c.step, c.iterations, c.sor, robot.warmup,
                robot.duration);
  return text;
}

std::vector<std::string> Split(std::string_view text) {
  std::vector<std::string> items;
  std::stringstream in{std::string(text)};
  std::string item;
  while (std::getline(in, item, ',')) items.push_back(item);
  return items;
}

double ParsePositive(const std::string& item, std::string_view flag) {
  char* end = nullptr;
  const double v = std::strtod(item.c_str(), &end);
  if (item.empty() || *end != '\0' || !std::isfinite(v) || v <= 0) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(flag) + ": bad value '" + item + "'");
  }
  return v;
}

std::vector<double> ParseList(std::string_view text, std::string_view flag) {
  std::vector<double> values;
  for (const std::string& item : Split(text)) values.push_back(ParsePositive(item, flag));
  return values;
}

std::string Format(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Settings {
  std::string robot = "quadruped";
  std::vector<StepMethod> methods = {StepMethod::kIterative};
  std::vector<double> steps = {0.002};
  std::vector<int> iterations = {WorldOptions().iterations};
  std::vector<double> sors = {WorldOptions().over_relaxation};
  std::optional<int> gaits;
  Config reference{.method = StepMethod::kExact, .step = 0.00025, .iterations = 200};
  std::optional<double> warmup, duration;
  std::string cache;
  bool compare_exact = false;
  bool csv = false;
  bool no_reference = false;
  int seeds = 1;
};

Settings ParseSettings(int argc, char** argv) {
  Settings s;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    auto value = [&](std::string_view flag) -> std::optional<std::string_view> {
      if (arg.rfind(flag, 0) == 0 && arg.size() > flag.size() && arg[flag.size()] == '=') {
        return arg.substr(flag.size() + 1);
      }
      return std::nullopt;
    };
    if (auto v = value("--robot")) {
      s.robot = *v;
    } else if (auto v = value("--method")) {
      s.methods.clear();
      for (const std::string& m : Split(*v)) s.methods.push_back(ParseMethod(m));
    } else if (auto v = value("--step")) {
      s.steps = ParseList(*v, "--step");
    } else if (auto v = value("--iterations")) {
      s.iterations.clear();
      for (double n : ParseList(*v, "--iterations")) s.iterations.push_back(static_cast<int>(n));
    } else if (auto v = value("--sor")) {
      s.sors = ParseList(*v, "--sor");
    } else if (auto v = value("--gaits")) {
      s.gaits = std::atoi(std::string(*v).c_str());
    } else if (auto v = value("--reference_method")) {
      s.reference.method = ParseMethod(*v);
    } else if (auto v = value("--reference_step")) {
      s.reference.step = ParsePositive(std::string(*v), "--reference_step");
    } else if (auto v = value("--reference_iterations")) {
      s.reference.iterations =
          static_cast<int>(ParsePositive(std::string(*v), "--reference_iterations"));
    } else if (auto v = value("--warmup")) {
      s.warmup = ParsePositive(std::string(*v), "--warmup");
    } else if (auto v = value("--duration")) {
      s.duration = ParsePositive(std::string(*v), "--duration");
    } else if (auto v = value("--cache")) {
      s.cache = *v;
    } else if (auto v = value("--seeds")) {
      s.seeds = static_cast<int>(ParsePositive(std::string(*v), "--seeds"));
    } else if (arg == "--compare_exact") {
      s.compare_exact = true;
    } else if (arg == "--no_reference") {
      s.no_reference = true;
    } else if (arg == "--csv") {
      s.csv = true;
    } else {
      throw Error(StatusCode::kInvalidArgument,
                  "unknown argument '" + std::string(arg) +
                      "' (flags: --robot= --method= --step= --iterations= --sor= --gaits= "
                      "--reference_method= --reference_step= --reference_iterations= "
                      "--warmup= --duration= --cache= --seeds= --compare_exact --csv --no_reference)");
    }
  }
  return s;
}

Robot MakeRobot(const Settings& s) {
  const std::string root = YAMOR_SOURCE_DIR;
  if (s.robot == "quadruped") {
    Robot robot{.name = "quadruped",
                .morphology = Morphology::LoadFile(root + "/configs/worlds/quadruped.xml")};
    const RobotConfig base = yamor::cpg::LoadConfigFile(root + "/configs/robots/quadruped.xml");
    robot.gaits.push_back(base);
    for (int k = 1; k <= s.gaits.value_or(6); ++k) {
      robot.gaits.push_back(yamor::bench::Table61Gait(base, static_cast<std::uint64_t>(k)));
    }
    robot.warmup = s.warmup.value_or(8.0);
    robot.duration = s.duration.value_or(12.0);
    return robot;
  }
  if (s.robot.rfind("snake", 0) == 0 && s.robot.size() > 5) {
    const int n = std::atoi(s.robot.c_str() + 5);
    if (n < 2) throw Error(StatusCode::kInvalidArgument, "--robot: bad snake '" + s.robot + "'");
    Robot robot{.name = s.robot, .morphology = yamor::bench::SnakeMorphology(n)};
    robot.gaits.push_back(yamor::bench::SnakeConfig(n));
    robot.warmup = s.warmup.value_or(2.0);
    robot.duration = s.duration.value_or(8.0);
    return robot;
  }
  // Any other robot of configs/worlds/ with its configs/robots/ gait, timed
  // like the acceptance tests (4 s warm-up + 16 s).
  const std::string world = root + "/configs/worlds/" + s.robot + ".xml";
  const std::string config = root + "/configs/robots/" + s.robot + ".xml";
  if (s.robot.find('/') != std::string::npos || !std::ifstream(world) || !std::ifstream(config)) {
    throw Error(StatusCode::kInvalidArgument,
                "--robot: '" + s.robot +
                    "' is not quadruped, snake<N> or a robot of configs/worlds and configs/robots");
  }
  Robot robot{.name = s.robot, .morphology = Morphology::LoadFile(world)};
  robot.gaits.push_back(yamor::cpg::LoadConfigFile(config));
  robot.warmup = s.warmup.value_or(4.0);
  robot.duration = s.duration.value_or(16.0);
  return robot;
}

int Main(int argc, char** argv) {
  const Settings s = ParseSettings(argc, argv);
  const Robot robot = MakeRobot(s);
  Cache cache(s.cache);
  auto cached_run = [&](size_t gait, const Config& c) {
    const std::string key = Key(robot, gait, c);
    if (auto hit = cache.Find(key)) return *hit;
    const Run r = Evaluate(robot, robot.gaits[gait], c);
    cache.Store(key, r);
    return r;
  };

  // Refuses bad solver settings (naming them) before any run.
  auto check = [&](const Config& c) {
    WorldOptions options;
    options.time_step = c.step;
    options.step_method = c.method;
    options.iterations = c.iterations;
    options.over_relaxation = c.sor;
    (void)yamor::physics::World(robot.morphology, options);
  };
  if (!s.no_reference) check(s.reference);
  for (double step : s.steps) {
    for (StepMethod m : s.methods) {
      for (int n : s.iterations) {
        for (double w : s.sors) check({.method = m, .step = step, .iterations = n, .sor = w});
      }
    }
  }

  std::vector<Run> reference;
  for (size_t g = 0; g < robot.gaits.size(); ++g) {
    reference.push_back(s.no_reference ? Run{} : cached_run(g, s.reference));
  }

  std::vector<std::pair<Config, bool>> configs;  // (config, cached)
  for (double step : s.steps) {
    if (s.compare_exact) configs.push_back({{.method = StepMethod::kExact, .step = step}, true});
    for (StepMethod m : s.methods) {
      for (int n : s.iterations) {
        for (double w : s.sors) {
          configs.push_back({{.method = m, .step = step, .iterations = n, .sor = w}, false});
          if (m == StepMethod::kExact) break;  // iterations and SOR do not apply
        }
        if (m == StepMethod::kExact) break;
      }
    }
  }

  std::printf("robot %s (%d bodies), %zu gait(s), distance over t = %g..%g s; reference: %s at "
              "%g ms%s\n",
              robot.name.c_str(), yamor::physics::World(robot.morphology).BodyCount(),
              robot.gaits.size(), robot.warmup,
              robot.warmup + robot.duration, MethodName(s.reference.method).c_str(),
              s.reference.step * 1e3,
              s.reference.method == StepMethod::kExact
                  ? ""
                  : (", " + std::to_string(s.reference.iterations) + " iterations").c_str());
  std::printf("reference distances m:");
  for (const Run& r : reference) std::printf(" %.4f%s", r.distance, r.diverged ? "(div)" : "");
  std::printf("\n\n");
  std::printf("| %-9s | %-7s | %-5s | %-4s | %-10s | %-8s | %-6s | %-12s | %-9s | %-8s | %-7s | %-10s | %-7s |%s\n",
              "method", "step ms", "iter", "SOR", "solver", "gait 0 m", "gait 0", "median |err|",
              "within 15%", "diverged", "CPU ms", "servo mrad", "sink mm",
              s.seeds > 1 ? " gait 0 over seeds: min..max m | spread |" : "");
  std::printf("|-----------|---------|-------|------|------------|----------|--------|--------------|-----------|----------|---------|------------|---------|%s\n",
              s.seeds > 1 ? "-------------------------------|--------|" : "");
  for (const auto& [c, cached] : configs) {
    std::vector<double> errors, cpu, servo, sink;
    int within = 0, diverged = 0;
    std::vector<Run> runs;
    for (size_t g = 0; g < robot.gaits.size(); ++g) {
      const Run r = cached ? cached_run(g, c) : Evaluate(robot, robot.gaits[g], c);
      runs.push_back(r);
      cpu.push_back(r.cpu);
      servo.push_back(r.servo_rms);
      sink.push_back(r.sink);
      diverged += r.diverged ? 1 : 0;
      const double ref = reference[g].distance;
      if (ref > 0.05 && !reference[g].diverged) {
        const double e = std::fabs(r.distance - ref) / ref;
        errors.push_back(r.diverged ? 1.0 : e);
        within += (!r.diverged && e <= 0.15) ? 1 : 0;
      }
      if (s.csv) {
        std::printf("csv,%s,%s,%g,%d,%g,gait%zu,%.5f,%.5f,%d,%.4f,%.5f,%.6f\n",
                    robot.name.c_str(), MethodName(c.method).c_str(), c.step, c.iterations, c.sor,
                    g, r.distance, ref, r.diverged ? 1 : 0, r.cpu, r.servo_rms, r.sink);
      }
    }
    const double ref0 = reference[0].distance;
    const bool iterative_params = c.method != StepMethod::kExact;
    std::printf("| %-9s | %7.3g | %5s | %4s | %-10s | %8.4f | %+5.1f%% | %11.1f%% | %5d/%-3zu | %8d | %7.0f | %10.1f | %7.2f |",
                MethodName(c.method).c_str(), c.step * 1e3,
                iterative_params ? std::to_string(c.iterations).c_str() : "-",
                iterative_params ? Format(c.sor).c_str() : "-",
                runs[0].solver.c_str(), runs[0].distance,
                ref0 > 0 ? 100 * (runs[0].distance - ref0) / ref0 : 0.0, 100 * Median(errors),
                within, errors.size(), diverged, 1e3 * Median(cpu), 1e3 * Median(servo), 1e3 * Median(sink));
    if (s.seeds > 1) {
      // The same gait under other constraint orders: the exact solver ignores
      // the order, the iterative one converges differently for each.
      std::vector<double> distances = {runs[0].distance};
      for (int seed = 1; seed < s.seeds; ++seed) {
        Config seeded = c;
        seeded.seed = static_cast<std::uint64_t>(seed);
        distances.push_back(Evaluate(robot, robot.gaits[0], seeded).distance);
      }
      const auto [lo, hi] = std::minmax_element(distances.begin(), distances.end());
      const double median = Median(distances);
      std::printf(" %13.4f..%-15.4f | %5.1f%% |", *lo, *hi,
                  median > 0 ? 100 * (*hi - *lo) / median : 0.0);
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  yamor::Log().set_level(spdlog::level::err);  // divergences are counted, not printed
  try {
    return Main(argc, argv);
  } catch (const Error& error) {
    std::fprintf(stderr, "physics_accuracy: %s\n", error.what());
    return 2;
  }
}
