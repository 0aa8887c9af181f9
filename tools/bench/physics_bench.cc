// Simulation cost and accuracy for issue 3 (docs/benchmarks.md, "Simulation").
//
//   physics_quadruped_eval/<step>           one 20-s quadruped evaluation (8 s
//                                           warm-up + 12 s) through the real
//                                           bridge path: SNP configuration
//                                           frames, bridge::Robot::Advance.
//   physics_quadruped_eval_baseline/<step>  the same robot and gait in the
//                                           naive world (tools/bench/naive_world.h).
//   physics_quadruped_eval_iterative/<step> the evaluation with our world's
//                                           iterative solver (StepMethod::kIterative).
//   physics_snake_step/<n>                  one step (CPG + world) of an n-module
//   physics_snake_step_baseline/<n>         snake: ours, naive, ours iterative.
//   physics_snake_step_iterative/<n>
//   physics_step_sweep/<step>/gait<k>       the quadruped evaluation at several
//                                           steps, for accuracy against the
//                                           finest: gait0 is the configured
//                                           gait, gait1.. random Table 6.1 gaits.
//   physics_step_sweep_iterative/<step>/gait0  the same, iterative solver.
//
// The quadruped walks its configured gait (configs/robots/quadruped.xml). Items
// are simulation steps, so items/s is steps/s and tools/bench/run.sh's "vs
// baseline" column is ours/naive. Counters: distance_m (central module,
// horizontal, t = 8 s to 20 s), velocity_mps, diverged (1 when the world blew
// up), bodies, joints (non-contact). Evaluations use manual timing: world
// construction, configuration and the 20 s of simulation.
//
// Extra flags (after Google Benchmark's): --step=S (default: WorldOptions'),
// --iterations=N and --sor=W (the iterative engine's solver; default:
// WorldOptions'),
// --sweep=S1,S2,... (default 0.00025,0.0005,0.001,0.002,0.004),
// --sweep_gaits=K (random gaits besides the configured one, default 6),
// --snakes=8,16,32,64, --snake_warmup=S (simulated seconds before timing),
// --gait=FILE (robot config of the quadruped).
// Export mode, for the MuJoCo side (tools/bench/physics_compare.py):
// --export=quadruped|snake<N> --export_dir=DIR [--export_duration=S] writes
// DIR/<robot>.world.xml (the morphology), DIR/<robot>.unpowered (comma-separated
// ids of the inactive modules, whose servos stay off) and DIR/<robot>.setpoints.csv (the
// set-point of every servo for each step k = 1..N at --step, exactly what the
// naive world is fed) and runs no benchmark.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "bridge/robot.h"
#include "host/config_frames.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/network.h"
#include "physics/morphology.h"
#include "physics/world.h"
#include "tools/bench/bench_robots.h"
#include "tools/bench/naive_world.h"

#ifndef YAMOR_SOURCE_DIR
#error "YAMOR_SOURCE_DIR must name the repository root"
#endif

namespace {

using yamor::bench::NaiveWorld;
using yamor::bench::SnakeConfig;
using yamor::bench::SnakeMorphology;
using yamor::bench::Table61Gait;
using yamor::cpg::RobotConfig;
using yamor::physics::Morphology;
using yamor::physics::StepMethod;
using yamor::physics::World;
using yamor::physics::WorldOptions;
using Clock = std::chrono::steady_clock;

// CPU time of the calling thread, s.
double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

constexpr double kWarmUp = 8.0;     // s, DESIGN.md "Velocity of a gait"
constexpr double kDuration = 12.0;  // s
constexpr std::uint64_t kPhaseSeed = 1;  // bridge::RobotOptions' default

struct Settings {
  double step = WorldOptions().time_step;
  int iterations = WorldOptions().iterations;          // of the iterative engine
  double over_relaxation = WorldOptions().over_relaxation;
  std::vector<double> sweep = {0.00025, 0.0005, 0.001, 0.002, 0.004};
  int sweep_gaits = 6;
  std::vector<int> snakes = {8, 16, 32, 64};
  double snake_warmup = 0.1;
  std::string gait = std::string(YAMOR_SOURCE_DIR) + "/configs/robots/quadruped.xml";
  std::string export_robot;
  std::string export_dir = ".";
  double export_duration = kWarmUp + kDuration;
};

std::string Root() { return YAMOR_SOURCE_DIR; }

// The iterative engine's solver settings (--iterations, --sor), set once in
// main() before any benchmark runs.
WorldOptions& IterativeTuning() {
  static WorldOptions options;
  return options;
}

// Options of our world for `method` at `step` (the iterative engine tuned).
WorldOptions OursOptions(double step, StepMethod method) {
  WorldOptions options;
  options.time_step = step;
  options.step_method = method;
  if (method != StepMethod::kExact) {
    options.iterations = IterativeTuning().iterations;
    options.over_relaxation = IterativeTuning().over_relaxation;
  }
  return options;
}

// "1000us", "250us": step in whole microseconds for benchmark names.
std::string StepName(double step) {
  return std::to_string(static_cast<long>(std::lround(step * 1e6))) + "us";
}

// ------------------------------------------------------------- robots --

const Morphology& QuadrupedMorphology() {
  static const Morphology m = Morphology::LoadFile(Root() + "/configs/worlds/quadruped.xml");
  return m;
}

// ---------------------------------------------------------------- gait --

// The CPG exactly as bridge::Robot runs it: parameters rounded to the
// firmware's floats, modules and couplings in id order, phases seeded, one
// RK4 step before each world step; inactive modules (host::IsInactive)
// unpowered, as ConfigurationFrames leaves them.
class Gait {
 public:
  explicit Gait(const RobotConfig& config) {
    RobotConfig firmware;
    std::map<int, const yamor::cpg::ModuleParams*> by_id;
    for (const auto& m : config.modules) by_id[m.id] = &m;
    for (const auto& [id, m] : by_id) {
      if (yamor::host::IsInactive(*m)) inactive_.push_back(id);
      firmware.modules.push_back({.id = id,
                                  .amplitude = static_cast<float>(m->amplitude),
                                  .offset = static_cast<float>(m->offset),
                                  .speed = static_cast<float>(m->speed),
                                  .min_angle = static_cast<float>(m->min_angle),
                                  .max_angle = static_cast<float>(m->max_angle)});
    }
    std::map<std::pair<int, int>, yamor::cpg::Coupling> couplings;
    for (const auto& c : config.couplings) couplings[{c.from, c.to}] = c;
    for (const auto& [key, c] : couplings) {
      firmware.couplings.push_back({.from = c.from,
                                    .to = c.to,
                                    .phase = static_cast<float>(c.phase),
                                    .weight = static_cast<float>(c.weight)});
    }
    network_ = yamor::cpg::Network::Compile(firmware);
    state_ = network_.InitialState(kPhaseSeed);
  }

  // Switches the inactive modules' servos off in `world` (once, at the start).
  template <typename W>
  void PowerDownInactive(W& world) const {
    for (int id : inactive_) world.SetMotorEnabled(id, false);
  }

  // Ids of the inactive modules.
  const std::vector<int>& inactive() const { return inactive_; }

  // Advances the oscillators by dt and hands every set-point to `world`.
  template <typename W>
  void Drive(W& world, double dt) {
    yamor::cpg::Step(network_, state_, dt);
    yamor::cpg::SetPoints(network_, state_, set_points_);
    for (std::size_t i = 0; i < set_points_.size(); ++i) {
      if (set_points_[i]) world.SetServoTarget(network_.IdAt(i), *set_points_[i]);
    }
  }

 private:
  yamor::cpg::Network network_;
  yamor::cpg::NetworkState state_;
  std::vector<std::optional<double>> set_points_;
  std::vector<int> inactive_;
};

// ---------------------------------------------------------- evaluations --

struct Evaluation {
  double wall = 0;       // s
  double cpu = 0;        // s, this thread's CPU time (robust when the machine is shared)
  double distance = 0;   // m, horizontal, t = warm-up .. warm-up + duration
  bool diverged = false;
  int bodies = 0;
  int joints = 0;
  std::int64_t steps = 0;
};

double Horizontal(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (b - a).head<2>().norm();
}

std::int64_t StepsFor(double seconds, double step) {
  return static_cast<std::int64_t>(std::llround(seconds / step));
}

// The real path: SNP configuration frames into bridge::Robot, then Advance.
Evaluation EvaluateBridge(const Morphology& morphology, const RobotConfig& config, double step,
                          StepMethod method) {
  Evaluation e;
  const auto start = Clock::now();
  const double cpu_start = ThreadCpuSeconds();
  yamor::bridge::RobotOptions options;
  options.world = OursOptions(step, method);
  options.phase_seed = kPhaseSeed;
  yamor::bridge::Robot robot(morphology, options);
  std::vector<yamor::snp::Frame> out;
  for (const yamor::snp::Frame& frame : yamor::host::ConfigurationFrames(config)) {
    robot.HandleFrame(frame, out);
  }
  try {
    robot.Advance(kWarmUp, out);
    const Eigen::Vector3d from = robot.world().CentralPosition();
    robot.Advance(kDuration, out);
    e.distance = Horizontal(from, robot.world().CentralPosition());
  } catch (const yamor::Error&) {
    e.diverged = true;
  }
  e.diverged = e.diverged || robot.world().Diverged();
  e.wall = std::chrono::duration<double>(Clock::now() - start).count();
  e.cpu = ThreadCpuSeconds() - cpu_start;
  e.bodies = robot.world().BodyCount();
  e.joints = 0;
  for (int id : robot.world().ModuleIds()) {
    if (robot.world().IsConnected(id)) ++e.joints;  // one hinge per module
  }
  e.steps = StepsFor(kWarmUp, step) + StepsFor(kDuration, step);
  return e;
}

// The same robot and gait in the naive world.
Evaluation EvaluateNaive(const Morphology& morphology, const RobotConfig& config, double step) {
  Evaluation e;
  const auto start = Clock::now();
  const double cpu_start = ThreadCpuSeconds();
  WorldOptions options;
  options.time_step = step;
  NaiveWorld world(morphology, options);
  Gait gait(config);
  gait.PowerDownInactive(world);
  auto advance = [&](double seconds) {
    for (std::int64_t i = StepsFor(seconds, step); i > 0 && !world.Diverged(); --i) {
      gait.Drive(world, step);
      world.Step();
    }
  };
  advance(kWarmUp);
  const Eigen::Vector3d from = world.CentralPosition();
  advance(kDuration);
  e.distance = Horizontal(from, world.CentralPosition());
  e.diverged = world.Diverged();
  e.wall = std::chrono::duration<double>(Clock::now() - start).count();
  e.cpu = ThreadCpuSeconds() - cpu_start;
  e.bodies = world.BodyCount();
  e.joints = world.JointCount();
  e.steps = StepsFor(kWarmUp, step) + StepsFor(kDuration, step);
  return e;
}

void Report(benchmark::State& state, const Evaluation& e, double step) {
  state.SetIterationTime(e.wall);
  state.SetItemsProcessed(e.steps);
  state.counters["step_s"] = step;
  state.counters["eval_wall_s"] = e.wall;
  state.counters["eval_cpu_s"] = e.cpu;
  state.counters["distance_m"] = e.distance;
  state.counters["velocity_mps"] = e.distance / kDuration;
  state.counters["diverged"] = e.diverged ? 1 : 0;
  state.counters["bodies"] = e.bodies;
  state.counters["joints"] = e.joints;
}

// Which world runs an evaluation.
enum class Engine { kOurs, kOursIterative, kNaive };

void QuadrupedEval(benchmark::State& state, const RobotConfig& config, double step,
                   Engine engine) {
  for (auto _ : state) {
    const Evaluation e =
        engine == Engine::kNaive
            ? EvaluateNaive(QuadrupedMorphology(), config, step)
            : EvaluateBridge(QuadrupedMorphology(), config, step,
                             engine == Engine::kOurs ? StepMethod::kExact : StepMethod::kIterative);
    Report(state, e, step);
  }
}

// One step (CPG + world) of an n-module snake. The world and its gait live
// across Google Benchmark's calls (which grow the iteration count), so the
// setup and the `warmup` simulated seconds that bring the gait's contacts in
// are paid once, not per call: the big naive snakes cost ~0.25 s per step.
template <typename W>
struct SnakeRun {
  SnakeRun(int n, const WorldOptions& options, double warmup)
      : world(SnakeMorphology(n), options), gait(SnakeConfig(n)), step(options.time_step) {
    gait.PowerDownInactive(world);
    for (std::int64_t i = StepsFor(warmup, step); i > 0 && !world.Diverged(); --i) Step();
  }
  void Step() {
    gait.Drive(world, step);
    world.Step();
  }
  W world;
  Gait gait;
  double step;
};

template <typename W>
void SnakeStep(benchmark::State& state, int n, const WorldOptions& options, double warmup) {
  static std::map<std::tuple<int, double, StepMethod>, std::unique_ptr<SnakeRun<W>>> runs;
  auto& run = runs[{n, options.time_step, options.step_method}];
  if (!run) run = std::make_unique<SnakeRun<W>>(n, options, warmup);
  for (auto _ : state) {
    if (run->world.Diverged()) break;
    run->Step();
  }
  if (run->world.Diverged()) state.SkipWithError("world diverged");
  state.SetItemsProcessed(state.iterations());
  state.counters["bodies"] = run->world.BodyCount();
  state.counters["step_s"] = options.time_step;
}

void SnakeOurs(benchmark::State& state, int n, double step, double warmup, StepMethod method) {
  SnakeStep<World>(state, n, OursOptions(step, method), warmup);
  state.counters["joints"] = n;  // one servo hinge per module
}

void SnakeNaive(benchmark::State& state, int n, double step, double warmup) {
  WorldOptions options;
  options.time_step = step;
  SnakeStep<NaiveWorld>(state, n, options, warmup);
  state.counters["joints"] = 2 * n - 1;  // n hinges, n - 1 fixed joints
}

// --------------------------------------------------------------- export --

// Writes the morphology and the per-step set-points of `robot` for MuJoCo.
void Export(const Settings& s) {
  std::optional<Morphology> morphology;
  RobotConfig config;
  if (s.export_robot == "quadruped") {
    morphology = QuadrupedMorphology();
    config = yamor::cpg::LoadConfigFile(s.gait);
  } else if (s.export_robot.rfind("snake", 0) == 0) {
    const int n = std::atoi(s.export_robot.c_str() + 5);
    if (n < 2) {
      throw yamor::Error(yamor::StatusCode::kInvalidArgument,
                         "--export: bad snake '" + s.export_robot + "'");
    }
    morphology = SnakeMorphology(n);
    config = SnakeConfig(n);
  } else {
    throw yamor::Error(yamor::StatusCode::kInvalidArgument,
                       "--export: unknown robot '" + s.export_robot +
                           "' (quadruped or snake<N>)");
  }
  const std::filesystem::path dir(s.export_dir);
  std::filesystem::create_directories(dir);
  std::ofstream world(dir / (s.export_robot + ".world.xml"));
  world << morphology->ToXml();
  // Records what the gait hands to each servo, step by step.
  struct Recorder {
    std::map<int, double> targets;
    void SetServoTarget(int id, double angle) { targets[id] = angle; }
  } recorder;
  Gait gait(config);
  std::ofstream unpowered(dir / (s.export_robot + ".unpowered"));
  for (size_t i = 0; i < gait.inactive().size(); ++i) {
    unpowered << (i > 0 ? "," : "") << gait.inactive()[i];
  }
  unpowered << "\n";
  unpowered.close();
  std::ofstream csv(dir / (s.export_robot + ".setpoints.csv"));
  const std::int64_t steps = StepsFor(s.export_duration, s.step);
  char buffer[64];
  for (std::int64_t k = 1; k <= steps; ++k) {
    gait.Drive(recorder, s.step);
    if (k == 1) {
      csv << "step";
      for (const auto& [id, angle] : recorder.targets) csv << "," << id;
      csv << "\n";
    }
    csv << k;
    for (const auto& [id, angle] : recorder.targets) {
      std::snprintf(buffer, sizeof buffer, ",%.17g", angle);
      csv << buffer;
    }
    csv << "\n";
  }
  world.close();
  csv.close();
  if (!world || !csv || !unpowered) {
    throw yamor::Error(yamor::StatusCode::kDataLoss, "writing to " + dir.string() + " failed");
  }
}

// ---------------------------------------------------------------- flags --

std::vector<double> ParseList(std::string_view text, std::string_view flag) {
  std::vector<double> values;
  std::stringstream in{std::string(text)};
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v) || v <= 0) {
      throw yamor::Error(yamor::StatusCode::kInvalidArgument,
                         std::string(flag) + ": bad value '" + item + "'");
    }
    values.push_back(v);
  }
  return values;
}

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
    if (auto v = value("--step")) {
      s.step = ParseList(*v, "--step").at(0);
    } else if (auto v = value("--iterations")) {
      s.iterations = static_cast<int>(ParseList(*v, "--iterations").at(0));
    } else if (auto v = value("--sor")) {
      s.over_relaxation = ParseList(*v, "--sor").at(0);
    } else if (auto v = value("--sweep")) {
      s.sweep = ParseList(*v, "--sweep");
    } else if (auto v = value("--snakes")) {
      s.snakes.clear();
      for (double n : ParseList(*v, "--snakes")) s.snakes.push_back(static_cast<int>(n));
    } else if (auto v = value("--snake_warmup")) {
      s.snake_warmup = ParseList(*v, "--snake_warmup").at(0);
    } else if (auto v = value("--sweep_gaits")) {
      s.sweep_gaits = std::atoi(std::string(*v).c_str());
    } else if (auto v = value("--gait")) {
      s.gait = *v;
    } else if (auto v = value("--export")) {
      s.export_robot = *v;
    } else if (auto v = value("--export_dir")) {
      s.export_dir = *v;
    } else if (auto v = value("--export_duration")) {
      s.export_duration = ParseList(*v, "--export_duration").at(0);
    } else {
      throw yamor::Error(yamor::StatusCode::kInvalidArgument,
                         "unknown argument '" + std::string(arg) +
                             "' (extra flags: --step=S --iterations=N --sor=W --sweep=S,... --sweep_gaits=K "
                             "--snakes=N,... --snake_warmup=S --gait=FILE --export=ROBOT "
                             "--export_dir=DIR --export_duration=S)");
    }
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  yamor::Log().set_level(spdlog::level::err);  // divergence warnings are counted, not printed
  Settings settings;
  RobotConfig gait;
  try {
    settings = ParseSettings(argc, argv);
    if (!settings.export_robot.empty()) {
      Export(settings);
      return 0;
    }
    gait = yamor::cpg::LoadConfigFile(settings.gait);
    IterativeTuning().iterations = settings.iterations;
    IterativeTuning().over_relaxation = settings.over_relaxation;
    IterativeTuning().step_method = StepMethod::kIterative;
    IterativeTuning().time_step = settings.step;
    // Refuses bad values before any benchmark starts.
    (void)World(QuadrupedMorphology(), IterativeTuning());
  } catch (const yamor::Error& error) {
    std::fprintf(stderr, "physics_bench: %s\n", error.what());
    return 2;
  }

  const double step = settings.step;
  std::string eval = "/";  // not "/" + ...: g++ 12 -Wrestrict false positive
  eval += StepName(step);
  benchmark::RegisterBenchmark(
      ("physics_quadruped_eval" + eval).c_str(),
      [=](benchmark::State& s) { QuadrupedEval(s, gait, step, Engine::kOurs); })
      ->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark(
      ("physics_quadruped_eval_baseline" + eval).c_str(),
      [=](benchmark::State& s) { QuadrupedEval(s, gait, step, Engine::kNaive); })
      ->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark(
      ("physics_quadruped_eval_iterative" + eval).c_str(),
      [=](benchmark::State& s) { QuadrupedEval(s, gait, step, Engine::kOursIterative); })
      ->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);
  const double warmup = settings.snake_warmup;
  for (int n : settings.snakes) {
    std::string name = "/";  // not "/" + ...: g++ 12 -Wrestrict false positive
    name += std::to_string(n);
    benchmark::RegisterBenchmark(
        ("physics_snake_step" + name).c_str(),
        [=](benchmark::State& s) { SnakeOurs(s, n, step, warmup, StepMethod::kExact); })
        ->MinTime(0.2)->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(("physics_snake_step_baseline" + name).c_str(),
                                 [=](benchmark::State& s) { SnakeNaive(s, n, step, warmup); })
        ->MinTime(0.2)->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(
        ("physics_snake_step_iterative" + name).c_str(),
        [=](benchmark::State& s) { SnakeOurs(s, n, step, warmup, StepMethod::kIterative); })
        ->MinTime(0.2)->Unit(benchmark::kMicrosecond);
  }
  // Accuracy, not speed: one run per step and gait is enough (the result is
  // deterministic), whatever --benchmark_repetitions says. The iterative
  // solver's accuracy is checked on the configured gait only.
  for (int k = 0; k <= settings.sweep_gaits; ++k) {
    const RobotConfig config = k == 0 ? gait : Table61Gait(gait, static_cast<std::uint64_t>(k));
    for (double h : settings.sweep) {
      benchmark::RegisterBenchmark(
          ("physics_step_sweep/" + StepName(h) + "/gait" + std::to_string(k)).c_str(),
          [=](benchmark::State& s) { QuadrupedEval(s, config, h, Engine::kOurs); })
          ->Iterations(1)->Repetitions(1)->UseManualTime()->Unit(benchmark::kMillisecond);
    }
  }
  for (double h : settings.sweep) {
    benchmark::RegisterBenchmark(
        ("physics_step_sweep_iterative/" + StepName(h) + "/gait0").c_str(),
        [=](benchmark::State& s) { QuadrupedEval(s, gait, h, Engine::kOursIterative); })
        ->Iterations(1)->Repetitions(1)->UseManualTime()->Unit(benchmark::kMillisecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
