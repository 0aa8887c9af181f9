// yamord settings (TOML) and the real <-> simulation id map.
#include <gtest/gtest.h>

#include "common/status.h"
#include "host/id_map.h"
#include "host/settings.h"

namespace yamor::host {
namespace {

template <typename F>
StatusCode CodeOf(F&& call, std::string* message = nullptr) {
  try {
    call();
  } catch (const Error& e) {
    if (message) *message = e.what();
    return e.code();
  }
  return StatusCode::kOk;
}

TEST(SettingsTest, DefaultsAreTheThesisDaemon) {
  const Settings s;
  EXPECT_EQ(s.listen, "127.0.0.1:2224");
  EXPECT_EQ(s.backend, "sim");
  EXPECT_EQ(s.workers, 0u);
  EXPECT_FALSE(s.master.has_value());
  EXPECT_EQ(s.record, "") << "no recording unless asked";
  EXPECT_EQ(ParseSettingsToml(SettingsToToml(s), "d").record, "");
  EXPECT_NO_THROW(ValidateSettings(s));
}

TEST(SettingsTest, ParsesEveryKeyAndRoundTripsThroughToml) {
  const Settings s = ParseSettingsToml(R"(
listen = "0.0.0.0:3000"
world = "snake"
config = "/etc/yamor/snake.xml"
workers = 4
master = 0
led_tracker = "camapp:5000"
log_level = "debug"
max_concurrent_calls = 8
link_timeout = 0.5
free_run = 1.0
seed = 99
record = "/var/log/yamor/session 1.rec"
[id_map]
0 = 10
10 = 0
)", "test.toml");
  EXPECT_EQ(s.listen, "0.0.0.0:3000");
  EXPECT_EQ(s.world, "snake");
  EXPECT_EQ(s.config, "/etc/yamor/snake.xml");
  EXPECT_EQ(s.workers, 4u);
  EXPECT_EQ(s.master, 0);
  EXPECT_EQ(s.led_tracker, "camapp:5000");
  EXPECT_EQ(s.log_level, "debug");
  EXPECT_EQ(s.max_concurrent_calls, 8u);
  EXPECT_DOUBLE_EQ(s.link_timeout, 0.5);
  EXPECT_DOUBLE_EQ(s.free_run, 1.0);
  EXPECT_EQ(s.seed, 99u);
  EXPECT_EQ(s.record, "/var/log/yamor/session 1.rec");
  EXPECT_EQ(ParseIdMap(s.id_map).ToSim(10), 0);

  const Settings again = ParseSettingsToml(SettingsToToml(s), "printed");
  EXPECT_EQ(SettingsToToml(again), SettingsToToml(s));
  EXPECT_EQ(again.id_map, s.id_map);
  EXPECT_EQ(again.master, s.master);
  EXPECT_EQ(again.record, s.record);
  EXPECT_EQ(SettingsToToml(ParseSettingsToml(SettingsToToml(Settings()), "d")),
            SettingsToToml(Settings()));
}

TEST(SettingsTest, MistakesNameTheFileAndLine) {
  struct Case {
    const char* toml;
    const char* expected;
  };
  const Case cases[] = {
      {"listen = \"x:1\"\nwrold = \"snake\"\n", "test.toml:2: unknown setting 'wrold'"},
      {"workers = \"four\"\n", "test.toml:1: workers must be an integer"},
      {"workers = -1\n", "test.toml:1: workers = -1 is outside"},
      {"master = 300\n", "test.toml:1: master = 300"},
      {"listen = \n", "test.toml:1:"},
      {"backend = \"serial\"\n", "backend 'serial' is not available"},
      {"listen = \"nowhere\"\n", "is not ADDR:PORT"},
      {"log_level = \"loud\"\n", "log_level 'loud'"},
      {"link_timeout = 0\n", "link_timeout"},
      {"\nrecord = 5\n", "test.toml:2: record must be a string"},
      {"[id_map]\n1 = 5\n2 = 5\n", "both map to simulation id 5"},
  };
  for (const Case& c : cases) {
    std::string message;
    EXPECT_NE(CodeOf([&] { ParseSettingsToml(c.toml, "test.toml"); }, &message), StatusCode::kOk)
        << c.toml;
    EXPECT_NE(message.find(c.expected), std::string::npos) << c.toml << " -> " << message;
  }
  EXPECT_EQ(CodeOf([] { LoadSettingsFile("/nonexistent/yamord.toml"); }), StatusCode::kNotFound);
}

TEST(IdMapTest, MapsBothWaysAndRejectsCollisions) {
  const IdMap map = ParseIdMap(" 0:10, 1:11 ");
  EXPECT_EQ(map.ToSim(0), 10);
  EXPECT_EQ(map.ToSim(1), 11);
  EXPECT_EQ(map.ToSim(5), 5) << "unmapped ids stay";
  EXPECT_EQ(map.ToReal(10), 0);
  EXPECT_EQ(map.ToReal(5), 5);
  EXPECT_EQ(map.ToString(), "0:10,1:11");
  EXPECT_TRUE(ParseIdMap("").empty());
  EXPECT_EQ(CodeOf([] { ParseIdMap("0:10,1"); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([] { ParseIdMap("0:300"); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([] { ParseIdMap("0:1,0:2"); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([] { ParseIdMap("0:5,1:5"); }), StatusCode::kInvalidArgument);
  EXPECT_NO_THROW(map.CheckInjective({0, 1, 2}));
  std::string message;
  EXPECT_EQ(CodeOf([&] { map.CheckInjective({0, 10}); }, &message), StatusCode::kInvalidArgument)
      << "real 0 and the unmapped real 10 would both be simulation module 10";
  EXPECT_NE(message.find("same simulation id 10"), std::string::npos) << message;
}

}  // namespace
}  // namespace yamor::host
