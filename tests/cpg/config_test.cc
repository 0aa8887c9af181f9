// Tests of the robot configuration model and of every Validate rule. Rule
// tests go through ParseConfigXml so the message must carry file and line.
#include "cpg/robot_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "cpg/config_xml.h"

namespace yamor::cpg {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Returns the yamor::Error thrown by `call`; records a failure if none is.
Error ErrorOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const Error& error) {
    return error;
  }
  ADD_FAILURE() << "expected a yamor::Error";
  return Error(StatusCode::kOk, "");
}

// Expects INVALID_ARGUMENT with a message containing every fragment.
void ExpectInvalid(const std::function<void()>& call,
                   const std::vector<std::string>& fragments) {
  const Error error = ErrorOf(call);
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << error.what();
  for (const std::string& fragment : fragments) {
    EXPECT_THAT(error.what(), HasSubstr(fragment));
  }
}

// A small valid document kept as lines so tests can edit a known line and
// know the line number an error must report. Tree: 1 -> 2 -> 3, master 1.
class ConfigDoc {
 public:
  ConfigDoc()
      : lines_{
            R"(<?xml version="1.0"?>)",                                   // 1
            R"(<yamorconfig master="1">)",                                // 2
            R"(  <modulelist>)",                                          // 3
            R"(    <module realid="1" amplitude="0" offset="0" speed="0" minangle="-1.57" maxangle="1.57">)",  // 4
            R"(      <bluetooth to="2"/>)",                               // 5
            R"(    </module>)",                                           // 6
            R"(    <module realid="2" amplitude="0.5" offset="0.1" speed="0.6" minangle="-1" maxangle="1">)",  // 7
            R"(      <bluetooth to="3"/>)",                               // 8
            R"(      <cpglink to="3" phase="1.5" weight="1"/>)",          // 9
            R"(    </module>)",                                           // 10
            R"(    <module realid="3" amplitude="0.5" offset="0.1" speed="0.6" minangle="-1" maxangle="1">)",  // 11
            R"(      <cpglink to="2" phase="-1.5" weight="1"/>)",         // 12
            R"(    </module>)",                                           // 13
            R"(  </modulelist>)",                                         // 14
            R"(</yamorconfig>)",                                          // 15
        } {}

  /// Replaces `from` by `to` on 1-based `line`; fails the test if absent.
  ConfigDoc& Replace(int line, std::string_view from, std::string_view to) {
    std::string& text = lines_.at(line - 1);
    const auto at = text.find(from);
    if (at == std::string::npos) {
      ADD_FAILURE() << "line " << line << " has no '" << from << "'";
    } else {
      text.replace(at, from.size(), to);
    }
    return *this;
  }

  /// Sets the whole of `line` (an empty string keeps the numbering).
  ConfigDoc& Set(int line, std::string text) {
    lines_.at(line - 1) = std::move(text);
    return *this;
  }

  /// Inserts a line after `line`; later lines move down by one.
  ConfigDoc& InsertAfter(int line, std::string text) {
    lines_.insert(lines_.begin() + line, std::move(text));
    return *this;
  }

  std::string Text() const {
    std::string text;
    for (const std::string& line : lines_) text += line + "\n";
    return text;
  }

  /// Parses as "robot.xml".
  RobotConfig Parse() const { return ParseConfigXml(Text(), "robot.xml"); }

  /// Expects INVALID_ARGUMENT starting "robot.xml:<line>: " with fragments.
  void ExpectError(int line, const std::vector<std::string>& fragments) const {
    const Error error = ErrorOf([&] { Parse(); });
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << error.what();
    EXPECT_THAT(error.what(),
                StartsWith("robot.xml:" + std::to_string(line) + ": "));
    for (const std::string& fragment : fragments) {
      EXPECT_THAT(error.what(), HasSubstr(fragment));
    }
  }

 private:
  std::vector<std::string> lines_;
};

// The in-code equivalent of ConfigDoc, without source locations.
RobotConfig SmallConfig() {
  RobotConfig config;
  config.modules = {{1, 0.0, 0.0, 0.0, -1.57, 1.57},
                    {2, 0.5, 0.1, 0.6, -1.0, 1.0},
                    {3, 0.5, 0.1, 0.6, -1.0, 1.0}};
  config.couplings = {{2, 3, 1.5, 1.0}, {3, 2, -1.5, 1.0}};
  config.bluetooth_parent = {{2, 1}, {3, 2}};
  config.master_id = 1;
  return config;
}

TEST(RobotConfigTest, FindModuleAndCoupling) {
  RobotConfig config = SmallConfig();
  const RobotConfig& view = config;
  ASSERT_NE(view.FindModule(2), nullptr);
  EXPECT_EQ(view.FindModule(2)->speed, 0.6);
  EXPECT_EQ(view.FindModule(4), nullptr);
  config.FindModule(3)->amplitude = 0.25;
  EXPECT_EQ(config.modules[2].amplitude, 0.25);

  ASSERT_NE(view.FindCoupling(3, 2), nullptr);
  EXPECT_EQ(view.FindCoupling(3, 2)->phase, -1.5);
  EXPECT_EQ(view.FindCoupling(1, 2), nullptr);
  config.FindCoupling(2, 3)->weight = 0.5;
  EXPECT_EQ(config.couplings[0].weight, 0.5);
}

TEST(RobotConfigTest, EqualityIgnoresLocations) {
  RobotConfig a = SmallConfig();
  RobotConfig b = SmallConfig();
  b.source_file = "x.xml";
  b.module_locations[1] = {"x.xml", 4};
  EXPECT_EQ(a, b);
  b.master_id = 2;
  EXPECT_NE(a, b);
}

TEST(RobotConfigTest, SmallConfigsAreValid) {
  EXPECT_NO_THROW(Validate(SmallConfig()));
  EXPECT_NO_THROW(ConfigDoc().Parse());
  EXPECT_EQ(ConfigDoc().Parse(), SmallConfig());
  RobotConfig single;
  single.modules = {{7, 0.0, 0.0, 0.0, -1.0, 1.0}};
  single.master_id = 7;
  EXPECT_NO_THROW(Validate(single));
}

// --- Each rule through the XML reader: file, line, module, attribute. ---

TEST(ValidateRuleTest, MinAngleMustBeBelowMaxAngle) {
  const Error error = ErrorOf([] {
    ConfigDoc().Replace(7, R"(minangle="-1" maxangle="1")",
                        R"(minangle="1.2" maxangle="0.3")").Parse();
  });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
  EXPECT_STREQ(error.what(),
               "robot.xml:7: module 2: minangle (1.2) must be < maxangle (0.3)");
  ConfigDoc()
      .Replace(11, R"(minangle="-1")", R"(minangle="1")")
      .ExpectError(11, {"module 3", "minangle (1)", "maxangle (1)"});
}

TEST(ValidateRuleTest, IdMustBeInRange) {
  ConfigDoc()
      .Replace(11, R"(realid="3")", R"(realid="255")")
      .Replace(8, R"(to="3")", R"(to="255")")
      .Replace(9, R"(to="3")", R"(to="255")")
      .ExpectError(11, {"module 255", "realid (255)", "0..254"});
  ConfigDoc()
      .Replace(11, R"(realid="3")", R"(realid="-1")")
      .Replace(8, R"(to="3")", R"(to="-1")")
      .Replace(9, R"(to="3")", R"(to="-1")")
      .ExpectError(11, {"module -1", "realid (-1)"});
  ConfigDoc()
      .Replace(11, R"(realid="3")", R"(realid="254")")
      .Replace(8, R"(to="3")", R"(to="254")")
      .Replace(9, R"(to="3")", R"(to="254")")
      .Parse();
}

TEST(ValidateRuleTest, IdsMustBeUnique) {
  ConfigDoc()
      .Replace(11, R"(realid="3")", R"(realid="2")")
      .ExpectError(11, {"module 2", "realid 2", "line 7"});
}

TEST(ValidateRuleTest, AmplitudeAndSpeedMustBeNonNegative) {
  ConfigDoc()
      .Replace(7, R"(amplitude="0.5")", R"(amplitude="-0.5")")
      .ExpectError(7, {"module 2", "amplitude (-0.5)", ">= 0"});
  ConfigDoc()
      .Replace(11, R"(speed="0.6")", R"(speed="-0.25")")
      .ExpectError(11, {"module 3", "speed (-0.25)", ">= 0"});
}

TEST(ValidateRuleTest, NonFiniteModuleValuesAreRejected) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"amplitude=\"0.5\"", "amplitude=\"nan\""},
      {"offset=\"0.1\"", "offset=\"inf\""},
      {"speed=\"0.6\"", "speed=\"-inf\""},
      {"minangle=\"-1\"", "minangle=\"-infinity\""},
      {"maxangle=\"1\"", "maxangle=\"NaN\""}};
  for (const auto& [from, to] : cases) {
    SCOPED_TRACE(to);
    const std::string name = to.substr(0, to.find('='));
    ConfigDoc().Replace(7, from, to).ExpectError(
        7, {"module 2", name + " (\"", "finite"});
  }
}

TEST(ValidateRuleTest, NonFiniteCouplingValuesAreRejected) {
  ConfigDoc()
      .Replace(9, R"(phase="1.5")", R"(phase="nan")")
      .ExpectError(9, {"module 2", "cpglink to (3)", "phase", "finite"});
  ConfigDoc()
      .Replace(12, R"(weight="1")", R"(weight="inf")")
      .ExpectError(12, {"module 3", "cpglink to (2)", "weight", "finite"});
}

TEST(ValidateRuleTest, CouplingToUnknownModule) {
  ConfigDoc()
      .Replace(9, R"(to="3")", R"(to="9")")
      .ExpectError(9, {"module 2", "cpglink to (9)", "no listed module"});
}

TEST(ValidateRuleTest, SelfCoupling) {
  ConfigDoc()
      .Replace(12, R"(to="2")", R"(to="3")")
      .ExpectError(12, {"module 3", "cpglink to (3)", "itself"});
}

TEST(ValidateRuleTest, DuplicateCoupling) {
  ConfigDoc()
      .InsertAfter(9, R"(      <cpmlink to="3" phase="0.5" weight="2"/>)")
      .ExpectError(10, {"module 2", "cpglink to (3)", "twice", "line 9"});
}

TEST(ValidateRuleTest, BluetoothChildMustBeListed) {
  ConfigDoc()
      .Replace(8, R"(to="3")", R"(to="9")")
      .ExpectError(8, {"module 2", "bluetooth to (9)", "no listed module"});
}

TEST(ValidateRuleTest, BluetoothChildHasOneParent) {
  ConfigDoc()
      .InsertAfter(11, R"(      <bluetooth to="2"/>)")
      .ExpectError(12, {"module 3", "bluetooth to (2)", "parent 1", "line 5"});
}

TEST(ValidateRuleTest, BluetoothCycle) {
  // 2 -> 3 -> 2 while 1 stays the master: with and without the attribute.
  for (const bool with_master : {true, false}) {
    SCOPED_TRACE(with_master);
    ConfigDoc doc;
    doc.Set(5, "").Set(12, R"(      <bluetooth to="2"/>)");
    if (!with_master) doc.Set(2, "<yamorconfig>");
    doc.ExpectError(12, {"module 2", "bluetooth", "cycle", "2 -> 3 -> 2"});
  }
}

TEST(ValidateRuleTest, UnreachableModule) {
  ConfigDoc().Set(8, "").ExpectError(
      11, {"module 3", "bluetooth", "unreachable from master 1"});
}

TEST(ValidateRuleTest, TwoRootsWithoutMasterAttribute) {
  ConfigDoc()
      .Set(2, "<yamorconfig>")
      .Set(8, "")
      .ExpectError(2, {"master", "2 roots", "modules 1, 3"});
}

TEST(ValidateRuleTest, NoRootWithoutMasterAttribute) {
  ConfigDoc()
      .Set(2, "<yamorconfig>")
      .Set(12, R"(      <bluetooth to="1"/>)")
      .ExpectError(2, {"master", "no root"});
}

TEST(ValidateRuleTest, MasterMustBeTheTreeRoot) {
  ConfigDoc()
      .Replace(2, R"(master="1")", R"(master="2")")
      .ExpectError(2, {"module 2", "master (2)", "root", "bluetooth"});
}

TEST(ValidateRuleTest, MasterMustBeListed) {
  ConfigDoc()
      .Replace(2, R"(master="1")", R"(master="9")")
      .ExpectError(2, {"master (9)", "not a listed module"});
}

TEST(ValidateRuleTest, ZeroModules) {
  ConfigDoc doc;
  for (int line = 4; line <= 13; ++line) doc.Set(line, "");
  doc.ExpectError(3, {"modulelist", "no <module>"});
}

// --- The same rules on configs built in code (no source locations). ---

TEST(ValidateInCodeTest, ModuleRules) {
  auto with = [](auto edit) {
    RobotConfig config = SmallConfig();
    edit(config);
    return config;
  };
  ExpectInvalid([&] { Validate(with([](RobotConfig& c) { c.modules.clear(); })); },
                {"no modules"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[2].amplitude = kNan; })); },
      {"module 3: amplitude (nan) must be finite"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].offset = -kInf; })); },
      {"module 2: offset (-inf) must be finite"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].speed = kInf; })); },
      {"module 2: speed (inf)"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].min_angle = kNan; })); },
      {"module 2: minangle (nan)"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].max_angle = kInf; })); },
      {"module 2: maxangle (inf)"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].amplitude = -1e-300; })); },
      {"module 2: amplitude (-1e-300) must be >= 0"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].speed = -1; })); },
      {"module 2: speed (-1) must be >= 0"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].max_angle = -1; })); },
      {"module 2: minangle (-1) must be < maxangle (-1)"});
  // Found by robot_config_fuzzer's 10-minute run: amplitude 1e308 passed and
  // the oscillators overflowed to a NaN set-point. The named parameters'
  // ranges (cpg/parameters.h) now hold for configuration files too.
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[0].amplitude = 1e308; })); },
      {"module 1: amplitude (1e+308) must be in [0, 6.283185307179586]"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].offset = -7; })); },
      {"module 2: offset (-7) must be in"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].speed = 10.5; })); },
      {"module 2: speed (10.5) must be in [0, 10]"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[1].min_angle = -1e9; })); },
      {"module 2: minangle (-1e+09) must be in"});
  ExpectInvalid(
      [&] { Validate(with([](RobotConfig& c) { c.modules[2].id = 2; })); },
      {"module 2: realid 2 is used by two modules"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.modules.push_back({255, 0, 0, 0, -1, 1}); }));
  }, {"module 255: realid (255) must be in 0..254"});
}

TEST(ValidateInCodeTest, CouplingRules) {
  auto with = [](auto edit) {
    RobotConfig config = SmallConfig();
    edit(config);
    return config;
  };
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings.push_back({9, 2, 0, 1}); }));
  }, {"module 9: cpglink to (2)", "from-module 9"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings.push_back({2, 9, 0, 1}); }));
  }, {"module 2: cpglink to (9) names no listed module"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings.push_back({1, 1, 0, 1}); }));
  }, {"module 1: cpglink to (1) couples the module to itself"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings.push_back({3, 2, 0, 1}); }));
  }, {"module 3: cpglink to (2) appears twice"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings[0].phase = kNan; }));
  }, {"module 2: cpglink to (3): phase (nan) must be finite"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings[1].weight = -kInf; }));
  }, {"module 3: cpglink to (2): weight (-inf) must be finite"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.couplings[1].weight = 1e300; }));
  }, {"module 3: cpglink to (2): weight (1e+300) must be in [-1000, 1000]"});
  // Any finite phase is an angle: random gaits (Table 6.1) go beyond 4π.
  EXPECT_NO_THROW(Validate(with([](RobotConfig& c) { c.couplings[0].phase = -16; })));
}

TEST(ValidateInCodeTest, TreeRules) {
  auto with = [](auto edit) {
    RobotConfig config = SmallConfig();
    edit(config);
    return config;
  };
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.bluetooth_parent[9] = 1; }));
  }, {"module 1: bluetooth to (9) names no listed module"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.bluetooth_parent[3] = 8; }));
  }, {"module 8: bluetooth to (3)", "parent module 8"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.master_id = 4; }));
  }, {"master (4) is not a listed module"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.master_id = 3; }));
  }, {"module 3: master (3) is not the root", "module 2 lists it"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.bluetooth_parent[2] = 3; }));
  }, {"module 2: bluetooth tree has a cycle (child -> parent: 2 -> 3 -> 2)"});
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.bluetooth_parent.erase(3); }));
  }, {"module 3: bluetooth: unreachable from master 1"});
  // A self-parent is the shortest cycle.
  ExpectInvalid([&] {
    Validate(with([](RobotConfig& c) { c.bluetooth_parent[3] = 3; }));
  }, {"module 3: bluetooth tree has a cycle (child -> parent: 3 -> 3)"});
}

TEST(ValidateInCodeTest, MessagesUseSourceFileWithoutLines) {
  RobotConfig config = SmallConfig();
  config.source_file = "built.xml";
  config.modules[1].speed = -1;
  ExpectInvalid([&] { Validate(config); },
                {"built.xml: module 2: speed (-1) must be >= 0"});
}

}  // namespace
}  // namespace yamor::cpg
