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

}  // namespace
}  // namespace yamor::lifelong
