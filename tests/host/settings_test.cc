// yamord settings (TOML) and the real <-> simulation id map.
#include <gtest/gtest.h>

#include "common/status.h"
#include "host/id_map.h"
#include "host/settings.h"
#include "tests/support/code_of.h"

namespace yamor::host {
namespace {

using ::yamor::testing::CodeOf;

TEST(SettingsTest, DefaultsAreTheThesisDaemon) {
  const Settings s;
  EXPECT_EQ(s.listen, "127.0.0.1:2224");
  EXPECT_EQ(s.backend, "sim");
  EXPECT_EQ(s.device, "");
  EXPECT_EQ(s.baud, 115200);
  EXPECT_EQ(s.data_bits, 8);
  EXPECT_EQ(s.parity, "none");
  EXPECT_EQ(s.stop_bits, 1);
  EXPECT_EQ(s.flow_control, "none");
  EXPECT_DOUBLE_EQ(s.hello_timeout, 0.3);
  EXPECT_DOUBLE_EQ(s.reply_timeout, 1.0);
  EXPECT_EQ(s.workers, 0u);
  EXPECT_FALSE(s.master.has_value());
  EXPECT_EQ(s.record, "") << "no recording unless asked";
  EXPECT_EQ(ParseSettingsToml(SettingsToToml(s), "d").record, "");
  EXPECT_NO_THROW(ValidateSettings(s));
}

TEST(SettingsTest, ParsesEveryKeyAndRoundTripsThroughToml) {
  const Settings s = ParseSettingsToml(R"(
listen = "0.0.0.0:3000"
backend = "serial"
device = "tcp://[::1]:2223"
baud = 57600
data_bits = 7
parity = "even"
stop_bits = 2
flow_control = "hardware"
hello_timeout = 0.5
reply_timeout = 2.5
world = "snake"
config = "/etc/yamor/snake.xml"
workers = 4
master = 0
led_tracker = "camapp:5000"
tracker_calibration = "/etc/yamor/camera.txt"
tracker_max_age = 0.25
position_source = "tracker"
log_level = "debug"
max_concurrent_calls = 8
link_timeout = 0.5
link_retries = 4
free_run = 1.0
seed = 99
record = "/var/log/yamor/session 1.rec"
[id_map]
0 = 10
10 = 0
)", "test.toml");
  EXPECT_EQ(s.listen, "0.0.0.0:3000");
  EXPECT_EQ(s.backend, "serial");
  EXPECT_EQ(s.device, "tcp://[::1]:2223");
  EXPECT_EQ(s.baud, 57600);
  EXPECT_EQ(s.data_bits, 7);
  EXPECT_EQ(s.parity, "even");
  EXPECT_EQ(s.stop_bits, 2);
  EXPECT_EQ(s.flow_control, "hardware");
  EXPECT_DOUBLE_EQ(s.hello_timeout, 0.5);
  EXPECT_DOUBLE_EQ(s.reply_timeout, 2.5);
  const SerialOptions serial = SerialOptionsOf(s);
  EXPECT_EQ(serial.device, "tcp://[::1]:2223");
  EXPECT_EQ(serial.baud, 57600);
  EXPECT_EQ(serial.data_bits, 7);
  EXPECT_EQ(serial.parity, Parity::kEven);
  EXPECT_EQ(serial.stop_bits, 2);
  EXPECT_EQ(serial.flow_control, FlowControl::kHardware);
  EXPECT_DOUBLE_EQ(serial.hello_timeout, 0.5);
  EXPECT_EQ(s.world, "snake");
  EXPECT_EQ(s.config, "/etc/yamor/snake.xml");
  EXPECT_EQ(s.workers, 4u);
  EXPECT_EQ(s.master, 0);
  EXPECT_EQ(s.led_tracker, "camapp:5000");
  EXPECT_EQ(s.tracker_calibration, "/etc/yamor/camera.txt");
  EXPECT_DOUBLE_EQ(s.tracker_max_age, 0.25);
  EXPECT_EQ(s.position_source, "tracker");
  EXPECT_EQ(s.log_level, "debug");
  EXPECT_EQ(s.max_concurrent_calls, 8u);
  EXPECT_DOUBLE_EQ(s.link_timeout, 0.5);
  EXPECT_EQ(s.link_retries, 4);
  EXPECT_DOUBLE_EQ(s.free_run, 1.0);
  EXPECT_EQ(s.seed, 99u);
  EXPECT_EQ(s.record, "/var/log/yamor/session 1.rec");
  EXPECT_EQ(ParseIdMap(s.id_map).ToSim(10), 0);

  const Settings again = ParseSettingsToml(SettingsToToml(s), "printed");
  EXPECT_EQ(SettingsToToml(again), SettingsToToml(s));
  EXPECT_EQ(again.id_map, s.id_map);
  EXPECT_EQ(again.master, s.master);
  EXPECT_EQ(again.device, s.device);
  EXPECT_EQ(again.parity, s.parity);
  EXPECT_DOUBLE_EQ(again.reply_timeout, s.reply_timeout);
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
      {"backend = \"serial\"\n", "backend 'serial' needs a device"},
      {"backend = \"usb\"\n", "backend 'usb' is not 'sim' or 'serial'"},
      {"device = 7\n", "test.toml:1: device must be a string"},
      {"device = \"tcp://robot\"\n", "device 'tcp://robot' is not tcp://HOST:PORT"},
      {"baud = 12345\n", "baud 12345 is not a supported line rate"},
      {"data_bits = 9\n", "data_bits 9 is outside 5..8"},
      {"parity = \"mark\"\n", "parity 'mark' is not none, odd or even"},
      {"stop_bits = 3\n", "stop_bits 3 is not 1 or 2"},
      {"flow_control = \"rts\"\n", "flow_control 'rts' is not none, software or hardware"},
      {"hello_timeout = 0\n", "hello_timeout"},
      {"reply_timeout = -1.5\n", "reply_timeout -1.5"},
      {"listen = \"nowhere\"\n", "is not ADDR:PORT"},
      {"log_level = \"loud\"\n", "log_level 'loud'"},
      {"link_timeout = 0\n", "link_timeout"},
      {"link_retries = 11\n", "link_retries"},
      {"tracker_max_age = 0\n", "tracker_max_age 0 s is outside (0, 60]"},
      {"position_source = \"camera\"\n", "position_source \"camera\" is neither auto nor tracker"},
      {"position_source = \"tracker\"\n", "position_source tracker needs led_tracker"},
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

TEST(SettingsTest, SerialValuesOutOfRangeAreOutOfRange) {
  Settings s;
  s.baud = 12345;
  EXPECT_EQ(CodeOf([&] { ValidateSettings(s); }), StatusCode::kOutOfRange);
  s = Settings();
  s.stop_bits = 0;
  EXPECT_EQ(CodeOf([&] { ValidateSettings(s); }), StatusCode::kOutOfRange);
  s = Settings();
  s.reply_timeout = 500.0;
  EXPECT_EQ(CodeOf([&] { ValidateSettings(s); }), StatusCode::kOutOfRange);
  s = Settings();
  s.parity = "Even";
  EXPECT_EQ(CodeOf([&] { ValidateSettings(s); }), StatusCode::kInvalidArgument);
  s = Settings();
  s.backend = "serial";
  s.device = "/dev/ttyUSB0";
  EXPECT_NO_THROW(ValidateSettings(s));
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
