#include "optimizer-plugins/optimize/run.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "optimizer-plugins/framework/host_pool.h"
#include "optimizer-plugins/framework/live_evaluator.h"
#include "optimizer-plugins/framework/optimization_config.h"
#include "optimizer-plugins/framework/plugin_loader.h"
#include "optimizer-plugins/framework/progress.h"
#include "optimizer-plugins/framework/resume.h"
#include "optimizer-plugins/framework/run_setup.h"
#include "optimizer-plugins/framework/session.h"
#include "optimizer-plugins/film/best_video.h"

namespace yamor::optimize {

namespace fs = std::filesystem;
using namespace yamor::optimizer;  // NOLINT: the command is the framework's user

namespace {

std::atomic<int> g_signals{0};

void OnSignal(int) { g_signals.fetch_add(1); }

std::string KindName(YamorFieldKind kind) {
  switch (kind) {
    case YAMOR_FIELD_INTEGER: return "integer";
    case YAMOR_FIELD_REAL: return "real";
    case YAMOR_FIELD_BOOLEAN: return "boolean";
    case YAMOR_FIELD_FILE: return "file";
    case YAMOR_FIELD_CHOICE: return "choice";
    case YAMOR_FIELD_TEXT: return "text";
  }
  return "?";
}

int ListPlugins(const std::vector<std::string>& dirs, std::ostream& out) {
  const std::vector<std::string> files = ListPluginFiles(dirs);
  if (files.empty()) {
    out << "no optimizer plugins found in:";
    for (const auto& d : dirs) out << " " << d;
    out << "\n";
    return 1;
  }
  for (const std::string& file : files) {
    try {
      const LoadedPlugin p = LoadedPlugin::Load(file);
      out << p.name() << " " << p.version() << " (" << p.author() << ") — " << p.description()
          << "\n  " << file << "\n";
      for (const FieldSpec& f : p.fields()) {
        out << "  --set " << f.name << "=" << (f.default_value.empty() ? "\"\"" : f.default_value)
            << "  [" << KindName(f.kind);
        if (f.kind == YAMOR_FIELD_INTEGER || f.kind == YAMOR_FIELD_REAL) {
          out << " in [" << FormatDouble(f.min) << ", " << FormatDouble(f.max) << "]";
        }
        if (f.kind == YAMOR_FIELD_CHOICE) {
          out << ":";
          for (std::size_t i = 0; i < f.choices.size(); ++i) out << (i ? "|" : " ") << f.choices[i];
        }
        out << "] " << f.description << (f.framework ? " (every plugin)" : "") << "\n";
      }
    } catch (const Error& e) {
      out << file << ": not usable: " << e.what() << "\n";
    }
  }
  return 0;
}

// One progress line over every running instance (with the robot time of a
// live run).
std::string ProgressLine(const std::vector<std::unique_ptr<Session>>& sessions, double elapsed,
                         const LiveEvaluator* live) {
  long long done = 0, budget = 0;
  bool has_best = false;
  double best = 0.0;
  std::string status;
  for (const auto& s : sessions) {
    const SessionSnapshot snap = s->Snapshot();
    done += snap.evaluations;
    budget += snap.budget;
    if (snap.has_best && (!has_best || snap.best_velocity > best)) best = snap.best_velocity;
    has_best = has_best || snap.has_best;
    if (sessions.size() == 1) status = snap.plugin_status;
  }
  const double rate = elapsed > 0 ? done / elapsed : 0.0;
  std::ostringstream line;
  line << done << "/" << budget << " evaluations";
  char best_text[32] = "-";
  if (has_best) std::snprintf(best_text, sizeof(best_text), "%.2f cm/s", best * 100.0);
  line << " | best " << best_text;
  char rate_text[32];
  std::snprintf(rate_text, sizeof(rate_text), "%.2f", rate);
  line << " | " << rate_text << " eval/s | elapsed " << FormatDuration(elapsed);
  if (live != nullptr) line << " | robot time " << FormatDuration(live->RobotSeconds());
  if (const std::string left = RemainingEstimate(done, budget, elapsed); !left.empty()) {
    line << " | " << left;
  }
  if (!status.empty()) line << " | " << status;
  return line.str();
}

// Draws progress.png with the plot script of the installed layout (next to
// this executable) or of the source tree; fails softly.
void DrawProgress(const std::string& out_dir, const std::string& title) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const std::string source_dir = YAMOR_SOURCE_DIR_FOR_TOOLS;
  PlotProgress(out_dir, title,
               FindScript("plot_progress.py", PlotScriptDirs(ec ? "" : self.string(), source_dir)),
               FindPython(source_dir));
}

// The command line as a shell would take it back (run.toml's info.command).
std::string CommandLine(const std::vector<std::string>& argv) {
  std::string line;
  for (std::size_t i = 0; i < argv.size(); ++i) {
    std::string arg = argv[i];
    if (arg.empty() || arg.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                             "0123456789_-.,:/=@+") != std::string::npos) {
      std::string quoted = "'";
      for (char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
      arg = quoted + "'";
    }
    line += (i == 0 ? "" : " ") + arg;
  }
  return line;
}

// Parses --video-size "WxH".
std::pair<int, int> ParseVideoSize(const std::string& text) {
  const auto x = text.find('x');
  const auto digits = [](const std::string& s) {
    return !s.empty() && s.size() <= 5 && s.find_first_not_of("0123456789") == std::string::npos;
  };
  if (x == std::string::npos || !digits(text.substr(0, x)) || !digits(text.substr(x + 1))) {
    throw Error(StatusCode::kInvalidArgument,
                "--video-size " + text + ": expected WIDTHxHEIGHT, e.g. 320x240");
  }
  const int width = std::stoi(text.substr(0, x));
  const int height = std::stoi(text.substr(x + 1));
  if (width < 1 || width > 4096 || height < 1 || height > 4096) {
    throw Error(StatusCode::kInvalidArgument,
                "--video-size " + text + ": width and height must be 1..4096");
  }
  return {width, height};
}

// The video of the best gait (best.mp4, best-strip.png) in `dir`: the best
// candidate filmed by a host of the pool. A failure is a warning: the run
// and its results stay as they are. Returns the lines to print.
std::vector<std::string> MakeBestVideo(HostPool& pool, const OptimizationConfig& config,
                                       const Problem& problem, const SessionResult& result,
                                       const FilmOptions& options, double seconds,
                                       const fs::path& dir,
                                       const std::function<bool()>& cancelled, std::ostream& err) {
  std::vector<std::string> lines;
  try {
    const Candidate candidate = problem.to_candidate(result.best_point);
    double period = 0.0;
    try {
      period = GaitPeriod(config.Apply(result.best_point));
    } catch (const Error&) {
      // The strip then spans the evaluation.
    }
    // The host makes the MP4 itself (raw frames to its ffmpeg: about half the
    // CPU of PNG frames made into a video here) and sends as PNG only the
    // strip's frames, chosen here from the frame times the film will have.
    FilmOptions film_options = options;
    film_options.mp4 = true;
    // As the daemon counts them; a film past its 100,000-frame cap is refused
    // there, so no more times are needed here.
    const auto count = static_cast<std::size_t>(
        std::clamp(std::round(seconds * options.frame_rate), 1.0, 100000.0));
    std::vector<double> times(count);
    for (std::size_t i = 0; i < count; ++i) times[i] = static_cast<double>(i) / options.frame_rate;
    for (const std::size_t index : StripFrameIndices(times, period)) {
      film_options.png_frames.push_back(static_cast<uint32_t>(index));
    }
    const FilmResult film = pool.FilmCandidate(candidate, film_options, cancelled);
    if (film.evaluation.velocity != result.best_velocity) {
      Log().warn("the filmed best gait ran at {} m/s on {}, the recorded best at {} m/s (hosts of "
                 "another build?)",
                 film.evaluation.velocity, film.evaluation.host, result.best_velocity);
    }
    if (film.frames.empty() && film.mp4.empty()) {
      throw Error(StatusCode::kInternal, film.evaluation.host + " sent no frames");
    }
    const BestVideo video = WriteBestVideo(film, options.frame_rate, period, dir.string());
    if (!video.video_error.empty()) {
      err << "yamor-optimize: warning: no video of the best gait: " << video.video_error << "\n";
    } else if (video.video) {
      lines.push_back("  video:     " + video.video_path + " (" + std::to_string(video.frames) +
                      " frames, " + FormatDouble(options.frame_rate) + " fps, filmed on " +
                      film.evaluation.host + ")");
    } else {
      lines.push_back("  video:     " + std::to_string(video.frames) + " frames as " +
                      (dir / "best-%06d.png").string());
      lines.push_back("  note:      " + video.note);
    }
    if (!video.strip_error.empty()) {
      err << "yamor-optimize: warning: no best-strip.png: " << video.strip_error << "\n";
    } else {
      lines.push_back("  strip:     " + video.strip_path);
    }
  } catch (const std::exception& e) {
    err << "yamor-optimize: warning: no video of the best gait (the results are kept): "
              << e.what() << "\n";
  }
  return lines;
}

}  // namespace

int Run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
        const std::string& program) {
  std::vector<std::string> command{program};
  command.insert(command.end(), args.begin(), args.end());
  CLI::App app{
      "yamor-optimize: learns gaits by running an optimizer plugin over a pool of yamord hosts,\n"
      "or online on the robot of one yamord (--live).\n"
      "Example: yamor-optimize --plugin powell --config configs/optimize/quadruped-7.xml "
      "--world quadruped --hosts 127.0.0.1:2224 --out results/run1"};
  std::string plugin_name, config_path, hosts_spec = "127.0.0.1:2224", out_dir, batch_path;
  std::string resume_dir;
  std::string world, morphology_path, log_level = "info";
  std::vector<std::string> sets, plugin_dirs;
  std::uint64_t seed = 1, eval_seed = 0;
  double warmup = 8.0, duration = 12.0, time_step = 0.0, give_up_after = 120.0;
  std::string live_spec;
  LiveOptions live_options;
  bool list_plugins = false, no_plot = false, quiet = false, no_video = false;
  std::string video_size = "320x240";
  double video_fps = 25.0;
  app.add_flag("--list-plugins", list_plugins, "List the plugins found and their fields, then exit");
  app.add_option("--plugin", plugin_name, "Plugin name (NAME.so in the plugin folders) or path to a .so");
  app.add_option("--plugin-dir", plugin_dirs, "Extra folder to look for plugins in (before the defaults)");
  app.add_option("--config", config_path, "Optimization configuration (robot + optimize/constrain rules)");
  app.add_option("--hosts", hosts_spec,
                 "yamord hosts: H:P,H:P or @FILE (one per line; re-read when it changes)")
      ->capture_default_str();
  app.add_option("--world", world, "Built-in world (morphology) the daemons simulate, e.g. quadruped; "
                                   "default: each daemon's own world");
  app.add_option("--morphology", morphology_path, "Morphology XML file sent to the daemons (overrides --world)");
  app.add_option("--set", sets, "Plugin field value KEY=VALUE (repeatable; see --list-plugins)");
  app.add_option("--batch", batch_path, "Batch start: a TOML file of [[instance]] tables (name, seed, set)");
  app.add_option("--seed", seed, "Seed of the plugin's random generator")->capture_default_str();
  app.add_option("--eval-seed", eval_seed, "Seed of every simulated evaluation")->capture_default_str();
  app.add_option("--warmup", warmup, "Seconds before the measured span (thesis 6.2.1)")->capture_default_str();
  app.add_option("--duration", duration, "Measured span [s]")->capture_default_str();
  app.add_option("--time-step", time_step, "Physics step [s]; 0 = the daemon's default")->capture_default_str();
  app.add_option("--give-up-after", give_up_after,
                 "Fail when no host is reachable for this long while work waits [s]")->capture_default_str();
  app.add_option("--live", live_spec,
                 "Optimize online on the robot of one yamord HOST:PORT (thesis 6.3) instead of "
                 "simulating candidates on --hosts; see docs/optimizers.md");
  app.add_option("--live-settle-periods", live_options.settle_periods,
                 "--live: CPG periods a candidate runs before it is measured")->capture_default_str();
  app.add_option("--live-measure-periods", live_options.measure_periods,
                 "--live: CPG periods measured (thesis 7.3)")->capture_default_str();
  app.add_option("--live-sample-interval", live_options.sample_interval,
                 "--live: robot seconds between position samples")->capture_default_str();
  app.add_option("--out", out_dir, "Results folder (evaluations.csv, best.xml, summary.json, progress.png)");
  app.add_option("--resume", resume_dir,
                 "Continue the killed run recorded in this results folder (same arguments; "
                 "recorded evaluations are not run again)");
  app.add_flag("--no-plot", no_plot, "Do not draw progress.png");
  app.add_flag("--no-video", no_video,
               "Do not film the best gait (best.mp4 and best-strip.png, made by a host of the pool "
               "at the end of the run)");
  app.add_option("--video-size", video_size, "Size of the best gait's video frames WIDTHxHEIGHT")
      ->capture_default_str();
  app.add_option("--video-fps", video_fps, "Frames per simulated second of the best gait's video")
      ->capture_default_str();
  app.add_flag("--quiet", quiet, "No progress line");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")->capture_default_str();
  app.name(program);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 parses from the back
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return app.exit(e, out, err);
  }

  try {
    SetLogLevel(log_level);
    std::vector<std::string> dirs = plugin_dirs;
    for (const auto& d : DefaultPluginDirs()) dirs.push_back(d);
    if (list_plugins) return ListPlugins(dirs, out);

    if (plugin_name.empty()) throw Error(StatusCode::kInvalidArgument, "--plugin is required (see --list-plugins)");
    if (config_path.empty()) throw Error(StatusCode::kInvalidArgument, "--config is required");
    if (!resume_dir.empty()) {
      if (!out_dir.empty() && fs::path(out_dir).lexically_normal() !=
                                  fs::path(resume_dir).lexically_normal()) {
        throw Error(StatusCode::kInvalidArgument,
                    "--out " + out_dir + " and --resume " + resume_dir + " name different folders");
      }
      if (!fs::is_directory(resume_dir)) {
        throw Error(StatusCode::kNotFound, "--resume " + resume_dir + ": no such results folder");
      }
      out_dir = resume_dir;
    }
    if (out_dir.empty()) throw Error(StatusCode::kInvalidArgument, "--out is required");
    const auto [video_width, video_height] = ParseVideoSize(video_size);
    if (!(video_fps > 0 && video_fps <= 240)) {
      throw Error(StatusCode::kInvalidArgument,
                  "--video-fps " + FormatDouble(video_fps) + " is outside (0, 240]");
    }
    if (!(warmup >= 0 && duration > 0)) {
      throw Error(StatusCode::kInvalidArgument, "--warmup must be >= 0 and --duration > 0");
    }
    const std::map<std::string, std::string> set = ParseFieldSettings(sets);

    const bool live = app.count("--live") > 0;
    if (live) {
      // Options of simulated evaluations would be silently ignored on a robot.
      for (const char* flag : {"--hosts", "--world", "--morphology", "--batch", "--warmup",
                               "--duration", "--time-step", "--eval-seed", "--give-up-after"}) {
        if (app.count(flag) > 0) {
          throw Error(StatusCode::kInvalidArgument,
                      std::string(flag) + " cannot be combined with --live: --live evaluates on "
                                          "the daemon's robot as it is (see docs/optimizers.md)");
        }
      }
    } else {
      for (const char* flag : {"--live-settle-periods", "--live-measure-periods",
                               "--live-sample-interval"}) {
        if (app.count(flag) > 0) {
          throw Error(StatusCode::kInvalidArgument, std::string(flag) + " needs --live HOST:PORT");
        }
      }
    }

    const LoadedPlugin plugin = LoadedPlugin::Load(FindPlugin(plugin_name, dirs));
    const OptimizationConfig config = OptimizationConfig::LoadFile(config_path);
    const Problem problem = MakeProblem(config);

    std::vector<BatchInstance> instances;
    if (!batch_path.empty()) {
      instances = LoadBatchFile(batch_path, seed);
    } else {
      instances.push_back({"run", seed, {}});
    }

    EvaluationSettings settings;
    settings.config_xml = config.RobotXml();
    settings.world = world;
    if (!morphology_path.empty()) {
      std::ifstream in(morphology_path);
      if (!in) throw Error(StatusCode::kNotFound, "cannot read --morphology " + morphology_path);
      std::stringstream text;
      text << in.rdbuf();
      settings.morphology_xml = text.str();
    }
    settings.warmup = warmup;
    settings.duration = duration;
    settings.seed = eval_seed;
    settings.time_step = time_step;
    PoolOptions pool_options;
    pool_options.give_up_after = give_up_after;

    // The evaluator: a pool of simulating hosts, or one live robot.
    std::unique_ptr<HostPool> pool;
    std::unique_ptr<HostListWatcher> host_file;
    std::unique_ptr<LiveEvaluator> live_evaluator;
    Evaluator* evaluator = nullptr;
    std::string evaluator_description;
    std::string evaluator_line;
    if (live) {
      const std::vector<HostAddress> address = ParseHosts(live_spec);
      if (address.size() != 1) {
        throw Error(StatusCode::kInvalidArgument, "--live takes one HOST:PORT, got " + live_spec);
      }
      // The optimization configuration's robot becomes the robot's: loaded,
      // connected (or refreshed) and switched on before the first trial.
      const LivePreparation prepared = PrepareLiveRobot(address[0], config.RobotXml(), config_path);
      live_evaluator = std::make_unique<LiveEvaluator>(address[0], live_options);
      evaluator = live_evaluator.get();
      evaluator_description = "live " + address[0].ToString();
      evaluator_line = "live robot " + address[0].ToString() + " (" + prepared.backend + ", " +
                       (live_evaluator->Simulated() ? "virtual time" : "real time") + ", " +
                       (prepared.connected_now ? "connected now" : "already connected") + ")";
    } else {
      const std::vector<HostAddress> hosts = ParseHosts(hosts_spec);
      for (const auto& h : hosts) {
        evaluator_description += (evaluator_description.empty() ? "" : ",") + h.ToString();
      }
      pool = std::make_unique<HostPool>(hosts, settings, pool_options);
      evaluator = pool.get();
      int up = 0;
      for (const auto& status : pool->Status()) up += status.up ? 1 : 0;
      evaluator_line = std::to_string(up) + "/" + std::to_string(hosts.size()) +
                       " hosts up (capacity " + std::to_string(pool->Capacity()) + ")";
      // --hosts @FILE follows the file: hosts added join, hosts removed drain.
      if (hosts_spec.front() == '@') {
        host_file = std::make_unique<HostListWatcher>(hosts_spec.substr(1), *pool);
      }
    }
    // What the evaluations depend on besides the plugin (run.toml; --resume).
    RunIdentity identity = EvaluationIdentity(config, settings);
    if (live) {
      identity["evaluation"] = "live " + live_spec +
                               " settle_periods=" + FormatDouble(live_options.settle_periods) +
                               " measure_periods=" + FormatDouble(live_options.measure_periods) +
                               " sample_interval=" + FormatDouble(live_options.sample_interval);
    }

    // Field values are validated for every instance before any host works.
    std::vector<std::unique_ptr<Session>> sessions;
    std::vector<std::string> instance_dirs;
    for (const BatchInstance& instance : instances) {
      std::map<std::string, std::string> instance_set = set;
      for (const auto& [k, v] : instance.set) instance_set[k] = v;
      const std::string dir = batch_path.empty() ? out_dir : (fs::path(out_dir) / instance.name).string();
      instance_dirs.push_back(dir);
      sessions.push_back(std::make_unique<Session>(
          plugin, problem, *evaluator,
          SessionOptions{.label = instance.name, .seed = instance.seed, .set = instance_set,
                         .out_dir = dir, .evaluator_description = evaluator_description,
                         .live = live, .resume = !resume_dir.empty(), .identity = identity,
                         .info = {{"command", CommandLine(command)}}}));
    }
    err << "yamor-optimize: " << plugin.name() << " " << plugin.version() << " on "
              << config.optimized().size() << " parameters of " << config_path << "; "
              << evaluator_line << "; results in " << out_dir << "\n";

    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);

    std::vector<SessionResult> results(sessions.size());
    std::atomic<std::size_t> running{sessions.size()};
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < sessions.size(); ++i) {
      threads.emplace_back([&, i] {
        results[i] = sessions[i]->Run();
        running.fetch_sub(1);
      });
    }
    const auto start = std::chrono::steady_clock::now();
    const bool tty = isatty(STDERR_FILENO) != 0;
    auto last_line = std::chrono::steady_clock::now();
    bool stopping = false;
    while (running.load() > 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      if (g_signals.load() > 0 && !stopping) {
        stopping = true;
        err << (tty ? "\n" : "") << "yamor-optimize: stopping (results so far are kept)\n";
        for (auto& s : sessions) s->RequestStop();
        evaluator->RequestStop();
      }
      const auto now = std::chrono::steady_clock::now();
      const double elapsed = std::chrono::duration<double>(now - start).count();
      if (!quiet && (tty || now - last_line > std::chrono::seconds(10))) {
        const std::string line = ProgressLine(sessions, elapsed, live_evaluator.get());
        if (tty) err << "\r\033[K" << line << std::flush;
        else err << "yamor-optimize: " << line << "\n";
        last_line = now;
      }
    }
    for (auto& t : threads) t.join();
    if (!quiet && tty) err << "\r\033[K" << ProgressLine(sessions,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
        live_evaluator.get()) << "\n";

    // The video of each instance's best gait: after the run, so that a
    // failed video never touches the results; a signal from here on skips it.
    const int signals_before_video = g_signals.load();
    const auto video_cancelled = [signals_before_video] {
      return g_signals.load() > signals_before_video;
    };
    FilmOptions film_options;
    film_options.width = video_width;
    film_options.height = video_height;
    film_options.frame_rate = video_fps;
    if (!no_video && live) {
      err << "yamor-optimize: no video with --live (film the robot with yamorctl record)\n";
    }

    int exit_code = 0;
    for (std::size_t i = 0; i < sessions.size(); ++i) {
      const SessionResult& r = results[i];
      if (!no_plot && r.evaluations > 0) {
        DrawProgress(instance_dirs[i], plugin.name() + " on " + fs::path(config_path).filename().string() +
                                           (batch_path.empty() ? "" : " (" + instances[i].name + ")"));
      }
      std::vector<std::string> video_lines;
      if (!no_video && pool && r.has_best && !video_cancelled()) {
        if (!quiet) err << "yamor-optimize: filming the best gait (Ctrl-C skips it)\n";
        video_lines = MakeBestVideo(*pool, config, problem, r, film_options, warmup + duration,
                                    fs::absolute(instance_dirs[i]), video_cancelled, err);
      }
      out << "yamor-optimize: " << (batch_path.empty() ? "" : "[" + instances[i].name + "] ")
                << r.status << " after " << r.evaluations << " evaluations";
      if (r.has_best) {
        char velocity[64];
        std::snprintf(velocity, sizeof(velocity), "%.3f cm/s", r.best_velocity * 100.0);
        out << "; best velocity " << velocity << " (evaluation " << r.best_index << ")";
      }
      out << "\n";
      if (live) out << "  robot time: " << FormatDuration(r.robot_seconds) << " in "
                          << r.evaluations << " live trials\n";
      if (!r.error.empty()) out << "  error: " << r.error << "\n";
      const fs::path dir = fs::absolute(instance_dirs[i]);
      out << "  results:   " << dir.string() << "/ (evaluations.csv, summary.json)\n";
      if (r.has_best) out << "  best gait: " << (dir / "best.xml").string() << "\n";
      if (fs::exists(dir / "progress.png")) out << "  plot:      " << (dir / "progress.png").string() << "\n";
      for (const std::string& line : video_lines) out << line << "\n";
      if (r.status == "failed") exit_code = 1;
    }
    if (g_signals.load() > 0 && exit_code == 0) exit_code = 130;
    return exit_code;
  } catch (const Error& e) {
    err << "yamor-optimize: " << e.what() << "\n";
    return e.code() == StatusCode::kInvalidArgument || e.code() == StatusCode::kNotFound ? 2 : 1;
  } catch (const std::exception& e) {
    err << "yamor-optimize: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace yamor::optimize
