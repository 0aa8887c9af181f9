// yamor-characterize: thesis chapter 4 in simulation.
//   noise  a module at rest → Table 4.1 and the data of Figures B.1–B.4
//   moves  the moves of 4.3.4 → the curves of Figures B.5–B.19
//   record a board's raw counts through a yamord (real robot or simulation)
//          → a logged CSV for `noise --input` and `moves --input`
// Files are written through a temporary name and a rename: an interrupted
// run leaves no half-written CSV.
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/format.h"
#include "common/status.h"
#include "tools/characterize/board_recorder.h"
#include "tools/characterize/characterize.h"

namespace {

namespace ch = yamor::characterize;
namespace fs = std::filesystem;

void Noise(const fs::path& out, std::uint64_t seed, double duration, double rate,
           const std::string& input) {
  ch::NoiseOptions options;
  options.seed = seed;
  options.duration = duration;
  options.sample_rate = rate;
  const ch::NoiseResult result = input.empty() ? ch::MeasureNoise(options)
                                               : ch::NoiseFromLog(ch::ReadLoggedReadings(input));
  fs::create_directories(out);
  ch::WriteFileAtomically(out / "noise.csv", ch::NoiseCsv(result));
  ch::WriteFileAtomically(out / "histogram.csv", ch::HistogramCsv(result));
  ch::WriteFileAtomically(out / "table4-1.csv", ch::Table41Csv(result));
  std::printf("Table 4.1 (%zu readings per axis, %s): measured | thesis\n", result.noise.size(),
              input.empty() ? ("simulated, seed " + std::to_string(seed)).c_str()
                            : ("from " + input).c_str());
  std::printf("axis   N_min    N_max   N_ampl  N_ratio |  N_min    N_max   N_ampl  N_ratio\n");
  for (size_t axis = 0; axis < 3; ++axis) {
    const ch::NoiseAxis& a = result.axes[axis];
    std::printf("%c    %7.3f  %7.3f  %7.3f  %6.2f%% | %6.3f  %7.3f  %7.3f  %6.2f%%\n", "XYZ"[axis],
                a.n_min, a.n_max, a.n_ampl, 100 * a.n_ratio, ch::ThesisTable41::kMin[axis],
                ch::ThesisTable41::kMax[axis], ch::ThesisTable41::kAmpl[axis],
                100 * ch::ThesisTable41::kRatio[axis]);
  }
}

void FilterInput(const fs::path& out, const std::string& input, const std::string& name) {
  const ch::MoveResult r = ch::FilterLog(name, ch::ReadLoggedReadings(input));
  fs::create_directories(out);
  ch::WriteFileAtomically(out / (name + ".csv"), ch::MoveCsv(r));
  const auto& last = r.rows.back();
  std::printf("%s: %zu samples; final position [cm] noise-filtered %.2f %.2f %.2f, filtered %.2f "
              "%.2f %.2f\n", name.c_str(), r.rows.size(), 100 * last.noise_filtered.position.x(),
              100 * last.noise_filtered.position.y(), 100 * last.noise_filtered.position.z(),
              100 * last.filtered.position.x(), 100 * last.filtered.position.y(),
              100 * last.filtered.position.z());
}

void Moves(const fs::path& out, std::uint64_t seed, const std::string& only) {
  ch::MoveOptions options;
  options.module.seed = seed;
  std::vector<yamor::physics::MotionPath> moves;
  for (const auto& path : ch::ThesisMoves(seed)) {
    if (only == "all" || only == path.name()) moves.push_back(path);
  }
  if (moves.empty()) {
    throw yamor::Error(yamor::StatusCode::kInvalidArgument,
                       "unknown move '" + only + "' (sine, circle, go-and-return, random, drop, all)");
  }
  fs::create_directories(out);
  std::ostringstream summary;
  summary << "move,axis,final_error_noise_filtered,final_error_filtered,impacts\n";
  std::printf("move            axis  final position error [cm]: noise-filtered  filtered\n");
  for (const auto& path : moves) {
    const ch::MoveResult r = ch::MeasureMove(path, options);
    ch::WriteFileAtomically(out / (r.name + ".csv"), ch::MoveCsv(r));
    for (int axis = 0; axis < 3; ++axis) {
      summary << r.name << ',' << "xyz"[axis] << ','
              << yamor::FormatDouble(r.final_error_noise_filtered[axis]) << ','
              << yamor::FormatDouble(r.final_error_filtered[axis]) << ',' << r.impacts << '\n';
      std::printf("%-15s %c %35.2f %9.2f\n", r.name.c_str(), "XYZ"[axis],
                  100 * r.final_error_noise_filtered[axis], 100 * r.final_error_filtered[axis]);
    }
  }
  ch::WriteFileAtomically(out / (only == "all" ? "summary.csv" : "summary-" + only + ".csv"),
                          summary.str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"yamor-characterize: thesis chapter 4 (accelerometer) in simulation"};
  app.require_subcommand(1);
  std::string out = "results/characterize";
  std::uint64_t seed = 0;
  double duration = 10, rate = 110;
  std::string move = "all";
  std::string input, name = "logged";
  CLI::App* noise = app.add_subcommand("noise", "module at rest → Table 4.1, Figures B.1–B.4 data");
  noise->add_option("--out", out, "output folder (default results/characterize)");
  noise->add_option("--seed", seed, "sensor noise seed");
  noise->add_option("--duration", duration, "seconds at rest (10)")->check(CLI::PositiveNumber);
  noise->add_option("--rate", rate, "readings per second (110)")->check(CLI::PositiveNumber);
  noise->add_option("--input", input,
                    "logged readings of a board at rest (CSV: time,count_x,count_y,count_z)");
  CLI::App* moves = app.add_subcommand("moves", "moves of 4.3.4 → Figures B.5–B.19 data");
  moves->add_option("--out", out, "output folder (default results/characterize)");
  moves->add_option("--seed", seed, "sensor noise, shock and random-move seed");
  moves->add_option("--move", move, "sine, circle, go-and-return, random, drop or all");
  moves->add_option("--input", input,
                    "filter logged readings instead (CSV: time,count_x,count_y,count_z; "
                    "the first 1024 at rest)");
  moves->add_option("--name", name, "with --input: name of the output CSV (logged)");
  yamor::characterize::BoardRecording board;
  std::string record_out;
  CLI::App* record = app.add_subcommand(
      "record", "a board's raw counts through a yamord (serial backend or simulation) → CSV");
  record->add_option("--host", board.host, "yamord host:port (127.0.0.1:2224)");
  record->add_option("--module", board.module_id, "real id of the module (UART on)")->required();
  record->add_option("--seconds", board.seconds, "length (10)")->check(CLI::PositiveNumber);
  record->add_option("--out", record_out, "CSV to write (time,count_x,count_y,count_z)")
      ->required();
  CLI11_PARSE(app, argc, argv);
  try {
    if (record->parsed()) {
      const auto readings = yamor::characterize::RecordBoard(board);
      ch::WriteFileAtomically(record_out, yamor::characterize::LoggedReadingsCsv(readings));
      std::printf("recorded %zu readings of module %d from %s to %s\n", readings.size(),
                  board.module_id, board.host.c_str(), record_out.c_str());
    }
    if (noise->parsed()) Noise(out, seed, duration, rate, input);
    if (moves->parsed()) {
      if (input.empty()) {
        Moves(out, seed, move);
      } else {
        FilterInput(out, input, name);
      }
    }
  } catch (const yamor::Error& e) {
    std::fprintf(stderr, "yamor-characterize: %s: %s\n",
                 std::string(yamor::StatusCodeName(e.code())).c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "yamor-characterize: %s\n", e.what());
    return 1;
  }
  return 0;
}
