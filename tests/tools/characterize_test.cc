#include "tools/characterize/characterize.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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
  const auto dir = std::filesystem::temp_directory_path() / "yamor_characterize_test";
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
