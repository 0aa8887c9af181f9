#include "optimizer-plugins/lifelong/timeline.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "common/status.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;

std::string Read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Timeline, LinesAreCsvAndJson) {
  EXPECT_EQ(TimelineLine({.time = 12.5, .velocity = 0.05, .ema = 0.049, .state = "walking", .gait = 3}),
            "12.5,0.05,0.049,walking,,3");
  EXPECT_EQ(TimelineLine({.time = 1,
                          .velocity = std::numeric_limits<double>::quiet_NaN(),
                          .ema = std::numeric_limits<double>::quiet_NaN(),
                          .state = "anomaly",
                          .event = "anomaly: a, \"b\"",
                          .gait = 1}),
            "1,,,anomaly,\"anomaly: a, \"\"b\"\"\",1");
  EXPECT_EQ(EventLine({.time = 2, .kind = "anomaly", .fields = {{"trigger", JsonString("x\"y\n")},
                                                              {"v", JsonNumber(0.25)},
                                                              {"bad", JsonNumber(std::nan(""))}}}),
            "{\"time\":2,\"kind\":\"anomaly\",\"trigger\":\"x\\\"y\\n\",\"v\":0.25,\"bad\":null}");
}

TEST(Timeline, FilesAreAppendedAcrossRunsWithOneHeader) {
  const fs::path dir = fs::temp_directory_path() / ("timeline_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    TimelineWriter w(dir.string());
    w.Row({.time = 1, .velocity = 0.1, .ema = 0.1, .state = "walking", .gait = 1});
    w.Event({.time = 1, .kind = "start"});
  }
  {
    TimelineWriter w(dir.string());
    w.Row({.time = 2, .velocity = 0.2, .ema = 0.1, .state = "walking", .gait = 1});
  }
  EXPECT_EQ(Read(dir / "timeline.csv"),
            std::string(kTimelineHeader) + "\n1,0.1,0.1,walking,,1\n2,0.2,0.1,walking,,1\n");
  EXPECT_EQ(Read(dir / "events.jsonl"), "{\"time\":1,\"kind\":\"start\"}\n");
  // Another file under the name is not appended to.
  { std::ofstream(dir / "timeline.csv") << "a,b\n1,2\n"; }
  try {
    TimelineWriter w(dir.string());
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kFailedPrecondition);
  }
  fs::remove_all(dir);
}

// A LifeLog that keeps what it gets.
class KeptLog final : public LifeLog {
 public:
  void Row(const TimelineRow& row) override { rows.push_back(row); }
  void Event(const LifeEvent& event) override { events.push_back(event); }
  std::vector<TimelineRow> rows;
  std::vector<LifeEvent> events;
};

TEST(FramingLog, KeyMomentsGetAPictureNamedInTheirEvent) {
  const fs::path dir = fs::temp_directory_path() / ("yamor_framing_" + std::to_string(getpid()));
  fs::remove_all(dir);
  KeptLog kept;
  int taken = 0;
  FramingLog log(kept, dir.string(), [&] { return "png" + std::to_string(++taken); });
  log.Row({.time = 1, .state = "walking"});
  log.Event({.time = 2, .kind = "start"});
  log.Event({.time = 3, .kind = "anomaly", .fields = {{"trigger", JsonString("drop")}}});
  log.Event({.time = 4, .kind = "relearned"});
  log.Event({.time = 5, .kind = "anomaly"});
  EXPECT_EQ(taken, 3) << "only anomaly, recalled and relearned are framed";
  EXPECT_EQ(log.frames(), 3);
  ASSERT_EQ(kept.rows.size(), 1u);
  ASSERT_EQ(kept.events.size(), 4u);
  EXPECT_TRUE(kept.events[0].fields.empty());
  EXPECT_EQ(EventLine(kept.events[1]),
            "{\"time\":3,\"kind\":\"anomaly\",\"trigger\":\"drop\",\"frame\":\"frames/anomaly-01.png\"}");
  EXPECT_EQ(kept.events[2].fields.back().second, "\"frames/relearned-01.png\"");
  EXPECT_EQ(kept.events[3].fields.back().second, "\"frames/anomaly-02.png\"");
  EXPECT_EQ(Read(dir / "frames" / "anomaly-01.png"), "png1");
  EXPECT_EQ(Read(dir / "frames" / "relearned-01.png"), "png2");
  EXPECT_EQ(Read(dir / "frames" / "anomaly-02.png"), "png3");
  fs::remove_all(dir);
}

TEST(FramingLog, AFrameThatCannotBeTakenChangesNothingElse) {
  const fs::path dir = fs::temp_directory_path() / ("yamor_framing_fail_" + std::to_string(getpid()));
  fs::remove_all(dir);
  KeptLog kept;
  FramingLog log(kept, dir.string(), []() -> std::string {
    throw Error(StatusCode::kUnimplemented, "RenderFrame: a real robot");
  });
  log.Event({.time = 3, .kind = "anomaly", .fields = {{"trigger", JsonString("drop")}}});
  log.Event({.time = 4, .kind = "recalled"});
  EXPECT_EQ(log.failures(), 2);
  EXPECT_EQ(log.frames(), 0);
  ASSERT_EQ(kept.events.size(), 2u);
  EXPECT_EQ(EventLine(kept.events[0]), "{\"time\":3,\"kind\":\"anomaly\",\"trigger\":\"drop\"}");
  EXPECT_FALSE(fs::exists(dir / "frames"));
  // Without a taker (--no-frames) events pass untouched.
  FramingLog off(kept, dir.string(), {});
  off.Event({.time = 5, .kind = "anomaly"});
  EXPECT_TRUE(kept.events.back().fields.empty());
  EXPECT_EQ(off.failures(), 0);
}

}  // namespace
}  // namespace yamor::lifelong
