#include "optimizer-plugins/lifelong/run.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "optimizer-plugins/framework/progress.h"
#include "optimizer-plugins/framework/run_setup.h"
#include "optimizer-plugins/lifelong/daemon_port.h"
#include "optimizer-plugins/lifelong/gait_database.h"
#include "optimizer-plugins/lifelong/life_cycle.h"
#include "optimizer-plugins/lifelong/scenario.h"
#include "optimizer-plugins/lifelong/session_relearner.h"
#include "optimizer-plugins/lifelong/status_service.h"
#include "optimizer-plugins/lifelong/timeline.h"

namespace yamor::lifelong {

namespace fs = std::filesystem;

namespace {

std::atomic<int> g_signals{0};

void OnSignal(int) { g_signals.fetch_add(1); }

std::string ReadText(const std::string& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) throw Error(StatusCode::kNotFound, "cannot read " + what + " " + path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The command line (without the program name) with the scenario's
// [options] put before the user's arguments for every option the user did
// not give.
std::vector<std::string> WithScenarioOptions(const std::vector<std::string>& args) {
  std::string scenario_path;
  std::set<std::string> given;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.rfind("--", 0) != 0) continue;
    const std::string name = a.substr(2, a.find('=') == std::string::npos ? std::string::npos : a.find('=') - 2);
    given.insert(name);
    if (name == "scenario") {
      scenario_path = a.find('=') != std::string::npos ? a.substr(a.find('=') + 1)
                                                       : (i + 1 < args.size() ? args[i + 1] : "");
    }
  }
  if (scenario_path.empty()) return args;
  const Scenario scenario = Scenario::Load(scenario_path);
  std::vector<std::string> out;
  for (const auto& [name, values] : scenario.options) {
    if (given.count(name)) continue;
    for (const std::string& v : values) {
      if (v == "false") continue;  // a flag left off
      out.push_back("--" + name);
      if (v != "true") out.push_back(v);  // a flag given
    }
  }
  out.insert(out.end(), args.begin(), args.end());
  return out;
}

std::string ProgressLine(const LifeStatus& s) {
  char text[256];
  std::snprintf(text, sizeof text, "t %s | %-12s | v %.2f cm/s | ema %.2f cm/s | gait %lld | anomalies %d "
                "(recalled %d, relearned %d) | trials %lld",
                optimizer::FormatDuration(s.time).c_str(), s.state.c_str(), s.velocity * 100, s.ema * 100,
                static_cast<long long>(s.gait), s.anomalies, s.recalls, s.relearns, s.trials);
  std::string line = text;
  if (s.gaps > 0) line += " | gaps " + std::to_string(s.gaps);
  if (!s.detail.empty()) line += " | " + s.detail;
  return line;
}

}  // namespace

int Run(const std::vector<std::string>& command_line, std::ostream& out, std::ostream& err,
        const std::string& program) {
  CLI::App app{
      "yamor-lifelong: keeps one robot walking for life (thesis chapter 7): measures its velocity, notices\n"
      "anomalies (EMA rule, physical-change events, accelerometers), recalls stored gaits, rebuilds the CPG\n"
      "network when the body changed and relearns with an optimizer plugin.\n"
      "Example: yamor-lifelong --host 127.0.0.1:2224 --scenario configs/lifelong/transform.toml --out life1"};
  std::string host = "127.0.0.1:2224", config_path, scenario_path, out_dir, db_path, morphology_path;
  std::string mode = "online", plugin = "powell", log_level = "info", model_hosts, listen;
  std::vector<std::string> sets, plugin_dirs;
  LifeOptions life;
  RelearnerOptions relearn;
  DaemonPortOptions port_options;
  double absolute_threshold = 0;
  bool no_plot = false, quiet = false;
  app.add_option("--host", host, "The robot's yamord (HOST:PORT)")->capture_default_str();
  app.add_option("--config", config_path,
                 "Starting gait: a robot configuration, or an optimization configuration whose rules are "
                 "the parameters relearned while the body stays the same");
  app.add_option("--scenario", scenario_path,
                 "A scenario (configs/lifelong/*.toml): world, starting gait, options, scheduled changes");
  app.add_option("--out", out_dir, "Output folder (timeline.csv, events.jsonl, gaits.sqlite, timeline.png)")
      ->required();
  app.add_option("--db", db_path, "Gait database (default OUT/gaits.sqlite)");
  app.add_option("--morphology", morphology_path, "The robot's body when the daemon cannot tell it (real robot)");
  app.add_option("--mode", mode, "Relearning: online (trials on the robot) or model (simulated, then verified)")
      ->check(CLI::IsMember({"online", "model"}))->capture_default_str();
  app.add_option("--plugin", plugin, "Optimizer plugin (name or .so path)")->capture_default_str();
  app.add_option("--plugin-dir", plugin_dirs, "Extra folder to look for plugins in");
  app.add_option("--set", sets,
                 "Plugin field KEY=VALUE (repeatable; max_evaluations: the relearning budget of both modes)");
  app.add_option("--online-budget", relearn.online_budget,
                 "Online: trials per relearning (unless --set max_evaluations=N)")
      ->capture_default_str();
  app.add_option("--model-budget", relearn.model_budget,
                 "Model mode: simulated evaluations per relearning (unless --set max_evaluations=N)")
      ->capture_default_str();
  app.add_option("--model-hosts", model_hosts, "Model mode: yamord hosts H:P,... (default: --host)");
  app.add_option("--verify", relearn.verify, "Model mode: best candidates verified on the robot")
      ->capture_default_str();
  app.add_option("--model-warmup", relearn.model_warmup, "Model mode: warm-up of an evaluation [s]")
      ->capture_default_str();
  app.add_option("--model-duration", relearn.model_duration, "Model mode: measured span [s]")
      ->capture_default_str();
  app.add_option("--threshold", life.anomaly.threshold, "Anomaly threshold t, relative to the stored velocity")
      ->capture_default_str();
  app.add_option("--absolute-threshold", absolute_threshold, "Anomaly threshold t in m/s (instead of relative)");
  app.add_flag("--relearn-on-increase", life.anomaly.increase_is_anomaly,
               "A velocity increase is an anomaly too (default: logged only)");
  app.add_option("--noise-factor", life.anomaly.noise_factor,
                 "Threshold at least this many times the window noise (0: the thesis's rule alone)")
      ->capture_default_str();
  app.add_option("--learn-windows", life.anomaly.learn_windows,
                 "Windows of a gait that only learn its velocity and noise")->capture_default_str();
  app.add_option("--increase-confirmations", life.anomaly.increase_confirmations,
                 "Consecutive faster windows before an increase counts")->capture_default_str();
  app.add_option("--confirmations", life.anomaly.confirmations,
                 "Consecutive out-of-band windows before an anomaly")->capture_default_str();
  app.add_option("--noisy-confirmations", life.anomaly.noisy_confirmations,
                 "Consecutive windows below the band before a drop while the window noise sets the band")
      ->capture_default_str();
  app.add_option("--window-periods", life.window_periods, "CPG periods per measurement window")
      ->capture_default_str();
  app.add_option("--settle-periods", life.settle_periods, "CPG periods after a gait change before measuring")
      ->capture_default_str();
  app.add_option("--trial-periods", life.trial_periods, "CPG periods of a recall trial")->capture_default_str();
  app.add_option("--max-recall", life.max_recall, "Stored gaits tried per anomaly")->capture_default_str();
  app.add_option("--recall-accept", life.recall_accept,
                 "A recalled gait is kept at this fraction of its expected velocity")->capture_default_str();
  app.add_option("--recall-noise-factor", life.recall_noise_factor,
                 "A recall trial of n windows may fall short of the expected velocity by this many times the "
                 "gait's stored window noise / sqrt(n) when that is more than --recall-accept allows "
                 "(0: --recall-accept alone)")
      ->capture_default_str();
  app.add_option("--recall-floor", life.recall_floor,
                 "Whatever its noise, a recall trial must reach this fraction of the expected velocity")
      ->capture_default_str();
  app.add_option("--recall-windows", life.recall_max_windows,
                 "Windows (trials) an inconclusive recall trial of a noisy gait may grow to (1: one window)")
      ->capture_default_str();
  app.add_option("--recall-restart-floor", life.recall_restart_floor,
                 "A clean gait's first recall window below the acceptance but at or above this fraction of its "
                 "expected velocity gets a second window, judged alone (start-up from a near standstill; 0: off)")
      ->capture_default_str();
  app.add_option("--recall-fail-factor", life.recall_fail_factor,
                 "A recall trial below the expected velocity minus this many times the gait's noise / sqrt(n) "
                 "is rejected at once")
      ->capture_default_str();
  app.add_option("--noise-write-windows", life.noise_write_windows,
                 "Walking windows between writes of the gait's window noise to the database (0: only when "
                 "the gait is left)")
      ->capture_default_str();
  app.add_option("--max-free", life.adaptation.max_free, "Free parameters of a rebuilt network")
      ->capture_default_str();
  bool base_ties_only = false;
  app.add_flag("--base-ties-only", base_ties_only,
               "A rebuilt network ties only what the current gait satisfies (start: exactly the current "
               "gait) instead of every symmetry of the new body");
  app.add_option("--seed", life.seed, "Seed of the relearning runs and of the budget rule")->capture_default_str();
  app.add_option("--max-time", life.max_life_seconds, "Stop after this much life time [s]; 0 = never")
      ->capture_default_str();
  app.add_option("--max-anomalies", life.max_anomalies, "Stop after this many anomalies; 0 = never")
      ->capture_default_str();
  app.add_option("--sample-interval", port_options.live.sample_interval,
                 "Robot time between position samples [s]")->capture_default_str();
  app.add_flag("--starts-upside-down", life.starts_upside_down, "The robot starts on its back");
  app.add_option("--listen", listen,
                 "Serve the status service (yamor.v1.Lifelong: status, event stream) on HOST:PORT "
                 "(port 0: a free one; the line 'yamor-lifelong: status on HOST:PORT' tells it)");
  app.add_flag("--no-plot", no_plot, "Do not draw timeline.png");
  bool no_frames = false;
  app.add_flag("--no-frames", no_frames,
               "Do not save pictures of the key moments (frames/anomaly-NN.png, recalled-NN, "
               "relearned-NN: the simulated robot drawn by the daemon)");
  app.add_flag("--quiet", quiet, "No progress line");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")->capture_default_str();

  std::vector<std::string> args;
  try {
    args = WithScenarioOptions(command_line);
  } catch (const Error& e) {
    err << "yamor-lifelong: " << e.what() << "\n";
    return 2;
  }
  app.name(program);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 parses from the back
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return app.exit(e, out, err);
  }

  try {
    SetLogLevel(log_level);
    std::optional<Scenario> scenario;
    if (!scenario_path.empty()) {
      scenario = Scenario::Load(scenario_path);
      if (config_path.empty()) config_path = scenario->config_path;
    }
    if (config_path.empty()) throw Error(StatusCode::kInvalidArgument, "--config (or --scenario) is required");
    if (absolute_threshold > 0) {
      life.anomaly.threshold = absolute_threshold;
      life.anomaly.relative = false;
    }
    life.adaptation.impose_symmetry = !base_ties_only;
    relearn.mode = mode;
    relearn.plugin = plugin;
    relearn.plugin_dirs = plugin_dirs;
    for (const auto& [key, value] : optimizer::ParseFieldSettings(sets)) relearn.set[key] = value;
    if (!model_hosts.empty()) relearn.model_hosts = optimizer::ParseHosts(model_hosts);
    relearn.model_seed = scenario ? scenario->seed : 0;
    // Relearning and recall trials: settle, then measure, as the live evaluator does.
    port_options.live.settle_periods = life.settle_periods;
    port_options.live.measure_periods = life.trial_periods;
    if (!morphology_path.empty()) port_options.morphology_xml = ReadText(morphology_path, "--morphology");
    const std::vector<optimizer::HostAddress> address = optimizer::ParseHosts(host);
    if (address.size() != 1) throw Error(StatusCode::kInvalidArgument, "--host takes one daemon");

    // The starting gait: an optimization configuration keeps its rules.
    const std::string text = ReadText(config_path, "--config");
    InitialGait initial{.source = config_path};
    try {
      initial.config_xml = cpg::WriteConfigXml(cpg::ParseConfigXml(text, config_path));  // a plain robot
    } catch (const Error&) {
      // Not a plain robot: an optimization configuration (or a malformed file,
      // which this parse reports).
      const optimizer::OptimizationConfig start = optimizer::OptimizationConfig::Parse(text, config_path);
      initial.config_xml = start.RobotXml();
      initial.problem_xml = text;
    }

    fs::create_directories(out_dir);
    life.out_dir = out_dir;
    if (db_path.empty()) db_path = (fs::path(out_dir) / "gaits.sqlite").string();
    GaitDatabase db(db_path);
    TimelineWriter timeline(out_dir);
    LifeBroadcast log(timeline);  // the files, and the status service's watchers
    DaemonPort port(address.front(), port_options);
    std::optional<ScenarioPlayer> player;
    if (scenario) {
      player.emplace(*scenario, port.host(), port.rpc_deadline(), [&](double t, const ScenarioChange& c) {
        Log().info("scenario: {} at {} s", c.Describe(), FormatRounded(t));
        log.Event({.time = t,
                   .kind = "scenario_change",
                   .fields = {{"change", JsonString(c.Describe())},
                              {"action", JsonString(c.action)},
                              {"scheduled", JsonNumber(c.at)}}});
      });
      player->Setup(initial.config_xml);
      port.set_before_motion([&](double t) { return player->ApplyDue(t); });
      port.set_on_restart([&] { player->Setup(initial.config_xml); });
    }
    // Pictures of the key moments, drawn by the daemon (RenderFrame).
    FramingLog framing(log, out_dir, no_frames ? std::function<std::string()>() : [&port]() {
      v1::RenderFrameRequest request;
      request.set_width(640);
      request.set_height(480);
      return port.host().Call(&v1::Host::Stub::RenderFrame, request, "RenderFrame").png();
    });
    SessionRelearner relearner(port, relearn);
    LifeCycle cycle(port, relearner, db, framing, life);
    log.set_status([&cycle] { return cycle.Status(); });
    std::unique_ptr<StatusServer> status_server;
    if (!listen.empty()) {
      StatusContext context{.mode = mode, .robot = address.front().ToString()};
      const std::map<std::string, std::string> fields = relearner.Fields();
      if (const auto it = fields.find(optimizer::kMaxEvaluationsField); it != fields.end()) {
        try {
          context.relearn_budget = std::stoull(it->second);
        } catch (const std::exception&) {
          // Left 0: the plugin reads the value its own way.
        }
      }
      status_server = std::make_unique<StatusServer>(listen, log, context);
      const std::string bound = listen.substr(0, listen.rfind(':'));
      out << "yamor-lifelong: status on " << bound << ":" << status_server->port() << std::endl;
    }

    err << "yamor-lifelong: robot at " << address.front().ToString() << ", gait " << config_path
              << (initial.problem_xml.empty() ? "" : " (with its rules)") << ", relearning " << mode << " with "
              << relearner.plugin().name() << "; output in " << out_dir << "\n";

    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);
    std::atomic<bool> done{false};
    std::thread watcher([&] {
      const bool tty = isatty(STDERR_FILENO) != 0;
      auto last_line = std::chrono::steady_clock::now() - std::chrono::seconds(60);
      bool stopping = false;
      while (!done.load()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (g_signals.load() > 0 && !stopping) {
          stopping = true;
          err << (tty ? "\n" : "") << "yamor-lifelong: stopping (the database and timeline are kept)\n";
          cycle.RequestStop();
        }
        const auto now = std::chrono::steady_clock::now();
        if (!quiet && (tty ? now - last_line > std::chrono::milliseconds(500)
                           : now - last_line > std::chrono::seconds(10))) {
          const std::string line = ProgressLine(cycle.Status());
          if (tty) {
            err << "\r\033[K" << line << std::flush;
          } else {
            err << "yamor-lifelong: " << line << "\n";
          }
          last_line = now;
        }
      }
      if (!quiet && tty) err << "\r\033[K" << ProgressLine(cycle.Status()) << "\n";
    });
    // The status service's streams end once what was logged has been sent.
    auto end_service = [&] {
      log.End();
      if (status_server) status_server->Shutdown();
    };
    LifeSummary summary;
    try {
      summary = cycle.Run(initial);
    } catch (...) {
      done.store(true);
      watcher.join();
      end_service();
      throw;
    }
    done.store(true);
    watcher.join();
    end_service();

    if (!no_plot) {
      std::error_code ec;
      const fs::path self = fs::read_symlink("/proc/self/exe", ec);
      const std::string source_dir = YAMOR_SOURCE_DIR_FOR_TOOLS;
      PlotTimeline(out_dir, "yamor-lifelong: " + fs::path(scenario_path.empty() ? config_path : scenario_path)
                                                     .filename().string(),
                   optimizer::FindScript("plot_timeline.py",
                                         optimizer::PlotScriptDirs(ec ? "" : self.string(), source_dir)),
                   optimizer::FindPython(source_dir));
    }
    const LifeStatus& s = summary.status;
    out << "yamor-lifelong: " << summary.reason << " after " << optimizer::FormatDuration(s.time)
              << " of life: " << s.anomalies << " anomalies, " << s.recalls << " recalled, " << s.relearns
              << " relearned, " << s.trials << " trials, " << s.gaps << " gaps; walking gait " << s.gait << "\n";
    const fs::path dir = fs::absolute(out_dir);
    out << "  timeline: " << (dir / "timeline.csv").string() << "\n  events:   "
              << (dir / "events.jsonl").string() << "\n  gaits:    " << fs::absolute(db_path).string() << "\n";
    if (fs::exists(dir / "timeline.png")) out << "  plot:     " << (dir / "timeline.png").string() << "\n";
    if (framing.frames() > 0) {
      out << "  frames:   " << (dir / "frames").string() << "/ (" << framing.frames()
                << " pictures of the key moments; events.jsonl names each)\n";
    }
    return g_signals.load() > 0 ? 130 : 0;
  } catch (const Error& e) {
    err << "yamor-lifelong: " << e.what() << "\n";
    return e.code() == StatusCode::kInvalidArgument || e.code() == StatusCode::kNotFound ? 2 : 1;
  } catch (const std::exception& e) {
    err << "yamor-lifelong: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace yamor::lifelong
