#include "tools/characterize/characterize.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "common/status.h"

namespace yamor::characterize {
namespace {

// Table 4.1 is reproduced per axis: over 10 s at rest (> 1000 readings) the
// simulated noise spans the thesis's band to within one ADC count at each end.
TEST(CharacterizeNoiseTest, Table41WithinTheThesisBandPerAxis) {
  for (std::uint64_t seed : {0u, 1u, 2u}) {
    NoiseOptions options;
    options.seed = seed;
    const NoiseResult r = MeasureNoise(options);
    ASSERT_GT(r.noise.size(), 1000u);
    const double delta = r.count_size;
    for (size_t axis = 0; axis < 3; ++axis) {
      const NoiseAxis& a = r.axes[axis];
      EXPECT_NEAR(a.n_min, ThesisTable41::kMin[axis], delta) << "axis " << axis << " seed " << seed;
      EXPECT_NEAR(a.n_max, ThesisTable41::kMax[axis], delta) << "axis " << axis << " seed " << seed;
      EXPECT_NEAR(a.n_ampl, ThesisTable41::kAmpl[axis], 2 * delta) << "axis " << axis;
      EXPECT_NEAR(a.n_ratio, ThesisTable41::kRatio[axis], 0.002) << "axis " << axis;
      EXPECT_NEAR(a.n_ampl, a.n_max - a.n_min, 1e-12);
      int total = 0;
      for (const auto& [code, count] : a.histogram) total += count;
      EXPECT_EQ(total, static_cast<int>(r.noise.size()));
    }
    // Figure B.2: codes inside the X distribution that never occur.
    const auto& x = r.axes[0].histogram;
    EXPECT_EQ(x.count(513), 0u);
    EXPECT_GT(x.count(512) + x.count(514), 1u);
  }
}

// 4.5.2: dead reckoning of a go-and-return move drifts, and the window plus
// movement-end filters leave a smaller final position error.
TEST(CharacterizeMovesTest, GoAndReturnDriftsAndTheFiltersHelp) {
  double unfiltered_total = 0, filtered_total = 0;
  for (std::uint64_t seed : {0u, 1u, 2u, 3u}) {
    MoveOptions options;
    options.module.seed = seed;
    const MoveResult r = MeasureMove(physics::GoAndReturnMove(), options);
    ASSERT_GT(r.rows.size(), 300u);
    // The tracker saw the move: 10 cm out and back, to its resolution.
    double x_max = 0;
    for (const MoveRow& row : r.rows) x_max = std::max(x_max, row.tracker_position.x());
    EXPECT_NEAR(x_max, 0.10, 0.0033);
    const double unfiltered = r.final_error_noise_filtered.head<2>().norm();
    const double filtered = r.final_error_filtered.head<2>().norm();
    std::printf("go-and-return seed %llu: final horizontal error noise-filtered %.2f cm, "
                "filtered %.2f cm\n", static_cast<unsigned long long>(seed), 100 * unfiltered,
                100 * filtered);
    EXPECT_GT(unfiltered, 0.005) << "dead reckoning should drift (seed " << seed << ")";
    EXPECT_LT(filtered, unfiltered) << "seed " << seed;
    unfiltered_total += unfiltered;
    filtered_total += filtered;
  }
  EXPECT_LT(filtered_total, unfiltered_total / 2);
}

// The tracker is a 25-Hz camera: its curves change only at its frames, and
// its velocity over frames stays within what 3.3 mm steps allow.
TEST(CharacterizeMovesTest, TheTrackerSeesTheMoveAtItsFrameRate) {
  MoveOptions options;
  const MoveResult r = MeasureMove(physics::SineMove(), options);
  ASSERT_GT(r.rows.size(), 100u);
  int changes = 0;
  for (size_t i = 1; i < r.rows.size(); ++i) {
    if (r.rows[i].tracker_position != r.rows[i - 1].tracker_position ||
        r.rows[i].tracker_velocity != r.rows[i - 1].tracker_velocity) {
      ++changes;
    }
  }
  const double span = r.rows.back().time - r.rows.front().time;
  EXPECT_LE(changes, int(span * options.tracker_rate) + 1);
  EXPECT_GT(changes, int(span * options.tracker_rate) / 4) << "the LED moved for the 2-s move";
  double peak_speed = 0;
  for (const MoveRow& row : r.rows) peak_speed = std::max(peak_speed, row.tracker_velocity.norm());
  EXPECT_LT(peak_speed, 1.0) << "a hand move seen at 25 Hz, not 3.3 mm per AN3397 sample";
  options.tracker_rate = 0;
  EXPECT_THROW(MeasureMove(physics::SineMove(), options), Error);
}

TEST(CharacterizeMovesTest, DropShiftsTheOffsetsAndVelocityKeepsGrowing) {
  MoveOptions options;
  options.module.seed = 5;
  const MoveResult r = MeasureMove(physics::DropMove(), options);
  EXPECT_EQ(r.impacts, 1);
  // After the impact the shifted x/y offsets read as a constant acceleration
  // that the noise-filtered chain integrates (Figure B.18).
  const MoveRow& last = r.rows.back();
  const MoveRow& mid = r.rows[r.rows.size() - 100];
  EXPECT_GT(std::abs(last.noise_filtered.velocity.x()), std::abs(mid.noise_filtered.velocity.x()));
}

TEST(CharacterizeFilesTest, AtomicWriteLeavesNoPartialFile) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("yamor_characterize_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  WriteFileAtomically(dir / "a.csv", "x\n1\n");
  std::ifstream in(dir / "a.csv");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "x\n1\n");
  EXPECT_FALSE(std::filesystem::exists(dir / "a.csv.partial"));
  try {
    WriteFileAtomically(dir / "missing" / "b.csv", "y");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing/b.csv"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(CharacterizeNoiseTest, CsvHasAllCodesOfTheSpan) {
  NoiseOptions options;
  options.duration = 2;
  const NoiseResult r = MeasureNoise(options);
  const std::string csv = HistogramCsv(r);
  EXPECT_NE(csv.find("\nx,513,"), std::string::npos);  // listed, with count 0
  EXPECT_NE(csv.find("\nx,513,0.0395"), std::string::npos) << csv.substr(0, 200);
  EXPECT_THROW(MeasureNoise(NoiseOptions{.duration = -1}), Error);
}

}  // namespace
}  // namespace yamor::characterize

namespace yamor::characterize {
namespace {

class LoggedCsvTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("yamor_characterize_log_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path Write(const std::string& name, const std::string& text) {
    const auto path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  std::string ErrorOf(const std::string& text) {
    try {
      ReadLoggedReadings(Write("log.csv", text));
    } catch (const Error& e) {
      return std::string(StatusCodeName(e.code())) + " " + e.what();
    }
    return "no error";
  }
  std::filesystem::path dir_;
};

TEST_F(LoggedCsvTest, ReadsItsOwnNoiseCsvBack) {
  NoiseOptions options;
  options.duration = 1;
  const NoiseResult simulated = MeasureNoise(options);
  const auto readings = ReadLoggedReadings(Write("noise.csv", NoiseCsv(simulated)));
  ASSERT_EQ(readings.size(), simulated.counts.size());
  for (size_t i = 0; i < readings.size(); ++i) {
    EXPECT_EQ(readings[i].counts, simulated.counts[i]);
    EXPECT_EQ(readings[i].time, simulated.time[i]);
  }
  // Table 4.1 from the log: the zero is the mean, so the band is centred.
  const NoiseResult logged = NoiseFromLog(readings);
  for (size_t axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(logged.axes[axis].n_ampl, simulated.axes[axis].n_ampl, 1e-9);
    EXPECT_LT(logged.axes[axis].n_min, 0);
    EXPECT_GT(logged.axes[axis].n_max, 0);
  }
}

TEST_F(LoggedCsvTest, FiltersALoggedMoveLikeTheSimulatedOne) {
  MoveOptions options;
  const physics::MotionPath path = physics::GoAndReturnMove();
  physics::DrivenModule module(path, options.module);
  std::ostringstream csv;
  csv << "time,count_x,count_y,count_z\n";
  for (const auto& s : module.Run()) {
    csv << s.time << ',' << s.reading.counts[0] << ',' << s.reading.counts[1] << ','
        << s.reading.counts[2] << '\n';
  }
  const MoveResult logged = FilterLog("logged", ReadLoggedReadings(Write("move.csv", csv.str())));
  const MoveResult simulated = MeasureMove(path, options);
  ASSERT_EQ(logged.rows.size(), simulated.rows.size());
  EXPECT_NEAR(logged.rows.back().filtered.position.x(), simulated.rows.back().filtered.position.x(),
              1e-6);
}

TEST_F(LoggedCsvTest, BadFilesNameTheFileAndLine) {
  const std::string header = "time,count_x,count_y,count_z\n";
  std::string e = ErrorOf(header + "0,512,512,760\n0.01,512,abc,760\n");
  EXPECT_NE(e.find("INVALID_ARGUMENT"), std::string::npos) << e;
  EXPECT_NE(e.find("log.csv:3: count_y 'abc' is not an integer"), std::string::npos) << e;
  e = ErrorOf(header + "0,512,512,760\n0.01,512,51");  // cut mid-line
  EXPECT_NE(e.find("log.csv:3: 3 fields, the header has 4 (truncated last line)"),
            std::string::npos) << e;
  e = ErrorOf(header + "0,512,512,1024\n");
  EXPECT_NE(e.find("log.csv:2: count_z 1024 outside [0, 1023]"), std::string::npos) << e;
  e = ErrorOf(header + "0.5,512,512,760\n0.5,512,512,760\n");
  EXPECT_NE(e.find("log.csv:3: time 0.5 does not increase"), std::string::npos) << e;
  e = ErrorOf("time,count_x,count_z\n0,1,2\n");
  EXPECT_NE(e.find("log.csv:1: header has no column 'count_y'"), std::string::npos) << e;
  e = ErrorOf(header);
  EXPECT_NE(e.find("no readings after the header"), std::string::npos) << e;
  e = ErrorOf("");
  EXPECT_NE(e.find("log.csv:1: empty file"), std::string::npos) << e;
  e = ErrorOf(header + "nan,1,2,3\n");
  EXPECT_NE(e.find("time 'nan' is not a finite number"), std::string::npos) << e;
  try {
    ReadLoggedReadings(dir_ / "absent.csv");
    FAIL();
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), StatusCode::kNotFound);
    EXPECT_NE(std::string(error.what()).find("absent.csv"), std::string::npos);
  }
  // Shorter than the calibration.
  EXPECT_THROW(FilterLog("short", ReadLoggedReadings(Write("s.csv", header + "0,1,2,3\n1,1,2,3\n"))),
               Error);
}

}  // namespace
}  // namespace yamor::characterize
