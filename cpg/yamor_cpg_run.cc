// yamor-cpg-run: integrates the CPG network of a robot configuration and
// writes the servo set-points of every module as CSV.
//
//   yamor-cpg-run --config FILE [--duration 20] [--dt 0.001]
//                 [--sample-dt 0.01] [--seed N] --out FILE.csv
//
// CSV: header `time,<id>,<id>,...` (module order of the config), one row per
// sample, set-points clamped to the limit angles in radians, an empty cell for
// a module whose CPG is disabled.
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/network.h"

namespace yamor::cpg {
namespace {

struct RunOptions {
  std::string config_path;
  std::string out_path;
  double duration = 20.0;
  double dt = 0.001;
  double sample_dt = 0.01;
  std::optional<std::uint64_t> seed;
};

// Per-module statistics of the emitted set-points, for the summary.
struct ModuleSummary {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  long samples = 0;
  long clamped = 0;
};

void AppendShortest(std::string& line, double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  line.append(buffer, result.ptr);
}

void AppendTime(std::string& line, double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value,
                                    std::chars_format::general, 12);
  line.append(buffer, result.ptr);
}

std::string Format(double value) {
  std::string text;
  AppendShortest(text, value);
  return text;
}

void RequirePositiveFinite(double value, const char* flag) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw Error(StatusCode::kInvalidArgument,
                std::string(flag) + " must be finite and > 0, got " +
                    Format(value));
  }
}

int Run(const RunOptions& options) {
  RequirePositiveFinite(options.dt, "--dt");
  RequirePositiveFinite(options.sample_dt, "--sample-dt");
  if (!(std::isfinite(options.duration) && options.duration >= 0.0)) {
    throw Error(StatusCode::kInvalidArgument,
                "--duration must be finite and >= 0, got " +
                    Format(options.duration));
  }
  const double stride_real = options.sample_dt / options.dt;
  const long long stride = std::llround(stride_real);
  if (stride < 1 || std::abs(stride_real - static_cast<double>(stride)) > 1e-6) {
    throw Error(StatusCode::kInvalidArgument,
                "--sample-dt " + Format(options.sample_dt) +
                    " must be a whole multiple of --dt " + Format(options.dt));
  }
  const double steps_real = std::ceil(options.duration / options.dt - 1e-9);
  if (steps_real > 1e10) {
    throw Error(StatusCode::kInvalidArgument,
                "--duration / --dt asks for more than 1e10 steps");
  }
  const auto steps = static_cast<long long>(steps_real);

  const RobotConfig config = LoadConfigFile(options.config_path);
  const Network network = Network::Compile(config);
  NetworkState state =
      options.seed ? network.InitialState(*options.seed) : network.InitialState();

  const std::filesystem::path out_path(options.out_path);
  if (out_path.has_parent_path()) {
    std::error_code ignored;
    std::filesystem::create_directories(out_path.parent_path(), ignored);
  }
  std::ofstream out(out_path);
  if (!out) {
    throw Error(StatusCode::kNotFound,
                "cannot open --out file '" + options.out_path + "' for writing");
  }

  std::string line = "time";
  for (const ModuleId id : network.ids()) line += "," + std::to_string(id);
  line += '\n';
  out << line;

  std::vector<std::optional<double>> points;
  std::vector<ModuleSummary> summary(network.size());
  long long rows = 0;
  auto write_row = [&](long long step) {
    SetPoints(network, state, points);
    line.clear();
    AppendTime(line, static_cast<double>(step) * options.dt);
    for (std::size_t i = 0; i < points.size(); ++i) {
      line += ',';
      if (!points[i]) continue;
      AppendShortest(line, *points[i]);
      ModuleSummary& s = summary[i];
      s.min = std::min(s.min, *points[i]);
      s.max = std::max(s.max, *points[i]);
      ++s.samples;
      s.clamped += *points[i] == network.min_angle(i) || *points[i] == network.max_angle(i);
    }
    line += '\n';
    out << line;
    ++rows;
  };

  const auto started = std::chrono::steady_clock::now();
  write_row(0);
  for (long long step = 1; step <= steps; ++step) {
    Step(network, state, options.dt);
    if (step % stride == 0) write_row(step);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  out.close();
  if (!out) {
    throw Error(StatusCode::kDataLoss,
                "writing --out file '" + options.out_path + "' failed");
  }

  Log().info("{}: {} modules, {} coupling terms, {} RK4 steps of {} s ({} s simulated) "
             "in {:.3f} s wall",
             options.config_path, network.size(), network.link_count(), steps,
             options.dt, static_cast<double>(steps) * options.dt, seconds);
  for (std::size_t i = 0; i < network.size(); ++i) {
    const ModuleSummary& s = summary[i];
    if (s.samples == 0) {
      Log().info("  module {}: disabled, no set-points", network.IdAt(i));
      continue;
    }
    Log().info("  module {}: set-point in [{:.4f}, {:.4f}] rad, {:.1f}% of samples at a "
               "limit; final r={:.4f} x={:.4f}",
               network.IdAt(i), s.min, s.max,
               100.0 * static_cast<double>(s.clamped) / static_cast<double>(s.samples),
               state.r[i], state.x[i]);
  }
  Log().info("wrote {} rows to {}", rows, options.out_path);
  return 0;
}

}  // namespace
}  // namespace yamor::cpg

int main(int argc, char** argv) {
  yamor::cpg::RunOptions options;
  std::string log_level = "info";
  std::uint64_t seed = 0;
  CLI::App app{"Integrates the CPG of a YaMoR robot configuration (thesis 6.1.1) "
               "and writes each module's servo set-points as CSV."};
  app.add_option("--config", options.config_path, "robot configuration XML")->required();
  app.add_option("--out", options.out_path, "output CSV file")->required();
  app.add_option("--duration", options.duration, "simulated time [s]")->capture_default_str();
  app.add_option("--dt", options.dt, "RK4 time step [s]")->capture_default_str();
  app.add_option("--sample-dt", options.sample_dt,
                 "CSV sample interval [s], a multiple of --dt")
      ->capture_default_str();
  auto* seed_option = app.add_option(
      "--seed", seed, "random initial phases from this seed (default: all phases 0)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, off")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (seed_option->count() > 0) options.seed = seed;

  try {
    yamor::SetLogLevel(log_level);
    return yamor::cpg::Run(options);
  } catch (const yamor::Error& error) {
    std::cerr << "yamor-cpg-run: " << yamor::StatusCodeName(error.code()) << ": "
              << error.what() << "\n";
  } catch (const std::exception& error) {
    std::cerr << "yamor-cpg-run: " << error.what() << "\n";
  }
  return 1;
}
