// Tests of the XML reader and writer and of the robot files in configs/.
#include "cpg/config_xml.h"

#include "cpg/parameters.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "common/status.h"
#include "cpg/robot_config.h"

namespace yamor::cpg {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace fs = std::filesystem;

const fs::path kRobotDir = fs::path(YAMOR_SOURCE_DIR) / "configs" / "robots";

Error ErrorOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const Error& error) {
    return error;
  }
  ADD_FAILURE() << "expected a yamor::Error";
  return Error(StatusCode::kOk, "");
}

// Expects INVALID_ARGUMENT for `xml` read as "t.xml", starting with the
// given line and containing every fragment.
void ExpectParseError(const std::string& xml, int line,
                      const std::vector<std::string>& fragments) {
  const Error error = ErrorOf([&] { ParseConfigXml(xml, "t.xml"); });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << error.what();
  EXPECT_THAT(error.what(), StartsWith("t.xml:" + std::to_string(line) + ": "));
  for (const std::string& fragment : fragments) {
    EXPECT_THAT(error.what(), HasSubstr(fragment));
  }
}

// A two-module document; `module2` is the second module element (line 5).
std::string TwoModules(const std::string& module2_attributes,
                       const std::string& module2_children = "") {
  return "<yamorconfig>\n"                                              // 1
         "<modulelist>\n"                                               // 2
         "<module realid=\"1\" amplitude=\"0\" offset=\"0\" speed=\"0\" "
         "minangle=\"-1\" maxangle=\"1\">\n"                            // 3
         "<bluetooth to=\"2\"/></module>\n"                             // 4
         "<module " + module2_attributes + ">\n" +                      // 5
         module2_children +                                             // 6..
         "</module>\n"
         "</modulelist>\n"
         "</yamorconfig>\n";
}

const std::string kGoodAttributes =
    R"(realid="2" amplitude="0.5" offset="0" speed="1" minangle="-1" maxangle="1")";

std::vector<fs::path> RobotFiles() {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(kRobotDir)) {
    if (entry.path().extension() == ".xml") files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(RobotFilesTest, EveryFileLoadsAndValidates) {
  const std::vector<fs::path> files = RobotFiles();
  std::set<std::string> names;
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    names.insert(file.filename().string());
    RobotConfig config;
    ASSERT_NO_THROW(config = LoadConfigFile(file.string()));
    EXPECT_NO_THROW(Validate(config));
    EXPECT_EQ(config.source_file, file.string());
    EXPECT_EQ(config.module_locations.size(), config.modules.size());
  }
  for (const char* expected : {"wheel.xml", "quadruped.xml", "snake.xml",
                               "trebuchet.xml", "dog.xml", "tripod.xml"}) {
    EXPECT_TRUE(names.contains(expected)) << expected;
  }
}

TEST(RobotFilesTest, EveryFileRoundTrips) {
  for (const fs::path& file : RobotFiles()) {
    SCOPED_TRACE(file.string());
    const RobotConfig config = LoadConfigFile(file.string());
    const std::string written = WriteConfigXml(config);
    const RobotConfig reread = ParseConfigXml(written);
    EXPECT_EQ(reread, config);
    EXPECT_EQ(WriteConfigXml(reread), written);
  }
}

TEST(RobotFilesTest, WheelIsTheThesisExample) {
  const RobotConfig wheel = LoadConfigFile((kRobotDir / "wheel.xml").string());
  ASSERT_EQ(wheel.modules.size(), 4u);
  EXPECT_EQ(wheel.modules[0], (ModuleParams{1, 0.0, 0.0, 0.0, -1.57, 1.57}));
  for (int i = 1; i < 4; ++i) {
    EXPECT_EQ(wheel.modules[i].amplitude, 1.04);
    EXPECT_EQ(wheel.modules[i].offset, 1.04);
    EXPECT_EQ(wheel.modules[i].speed, 0.6);
    EXPECT_EQ(wheel.modules[i].min_angle, -1.57);
    EXPECT_EQ(wheel.modules[i].max_angle, 1.57);
  }
  EXPECT_EQ(wheel.modules[1].id, 6);
  EXPECT_EQ(wheel.modules[2].id, 7);
  EXPECT_EQ(wheel.modules[3].id, 12);
  EXPECT_EQ(wheel.master_id, 1);
  const std::map<ModuleId, ModuleId> tree = {{6, 1}, {7, 6}, {12, 7}};
  EXPECT_EQ(wheel.bluetooth_parent, tree);
  const std::vector<Coupling> couplings = {
      {6, 12, -2.09, 1.0}, {6, 7, 2.09, 1.0},  {7, 6, -2.09, 1.0},
      {7, 12, 2.09, 1.0},  {12, 7, -2.09, 1.0}, {12, 6, 2.09, 1.0}};
  EXPECT_EQ(wheel.couplings, couplings);
  // Locations: module 6 starts on line 8, its first cpmlink is line 11.
  EXPECT_EQ(wheel.module_locations.at(6).line, 8);
  EXPECT_EQ(wheel.coupling_locations.at({6, 12}).line, 11);
  EXPECT_EQ(wheel.bluetooth_locations.at(7).line, 10);
}

TEST(RobotFilesTest, QuadrupedMatchesFigureC5AndTable61) {
  const RobotConfig quad =
      LoadConfigFile((kRobotDir / "quadruped.xml").string());
  ASSERT_EQ(quad.modules.size(), 9u);
  EXPECT_EQ(quad.master_id, 4);
  for (ModuleId hip = 0; hip < 4; ++hip) {
    EXPECT_EQ(*quad.FindModule(hip),
              (ModuleParams{hip, 0.784599677188, 0, 0.3, -0.78, 0.78}));
    EXPECT_EQ(*quad.FindModule(hip + 5),
              (ModuleParams{hip + 5, 0.186096234105, -0.174561075651, 0.3,
                            -1.57, 1.57}));
    EXPECT_EQ(quad.bluetooth_parent.at(hip), 4);
    EXPECT_EQ(quad.bluetooth_parent.at(hip + 5), hip);
    ASSERT_NE(quad.FindCoupling(hip, (hip + 1) % 4), nullptr);
    EXPECT_EQ(quad.FindCoupling(hip, (hip + 1) % 4)->phase, 1.5707963267949);
    EXPECT_EQ(quad.FindCoupling((hip + 1) % 4, hip)->phase, -1.5707963267949);
    EXPECT_EQ(quad.FindCoupling(hip, hip + 5)->phase, 4.71238898038469);
    EXPECT_EQ(quad.FindCoupling(hip + 5, hip)->phase, -4.71238898038469);
  }
  EXPECT_EQ(*quad.FindModule(4), (ModuleParams{4, 0, 0, 0, -1.57, 1.57}));
  EXPECT_EQ(quad.couplings.size(), 16u);
}

TEST(RobotFilesTest, AppendixARobots) {
  const RobotConfig snake = LoadConfigFile((kRobotDir / "snake.xml").string());
  EXPECT_EQ(snake.master_id, 0);
  EXPECT_EQ(snake.modules.size(), 9u);
  EXPECT_EQ(snake.couplings.size(), 14u);
  for (ModuleId i = 1; i < 8; ++i) {
    EXPECT_EQ(snake.bluetooth_parent.at(i + 1), i);
    EXPECT_EQ(snake.FindCoupling(i, i + 1)->phase, 1.5707963267949);
    EXPECT_EQ(snake.FindCoupling(i + 1, i)->phase, -1.5707963267949);
  }

  const RobotConfig trebuchet =
      LoadConfigFile((kRobotDir / "trebuchet.xml").string());
  EXPECT_EQ(trebuchet.master_id, 1);
  EXPECT_EQ(*trebuchet.FindModule(12),
            (ModuleParams{12, 1.0, -0.8, 1.0, -1.57, -1.0}));
  const std::vector<Coupling> links = {
      {10, 7, 3.0, 1.0}, {10, 12, 0.0, 1.0}, {7, 10, -3.0, 1.0},
      {12, 10, 0.0, 1.0}};  // Table A.1's (12, 0.0) read as (10, 0.0)
  EXPECT_EQ(trebuchet.couplings, links);

  const RobotConfig dog = LoadConfigFile((kRobotDir / "dog.xml").string());
  EXPECT_EQ(dog.master_id, 1);
  EXPECT_EQ(*dog.FindModule(5), (ModuleParams{5, 1.0, -1.0, 0.6, -1.55, 0.7}));
  EXPECT_EQ(dog.FindCoupling(11, 10)->phase, -3.0);
  EXPECT_EQ(dog.couplings.size(), 6u);
  const std::map<ModuleId, ModuleId> tree = {
      {11, 1}, {10, 11}, {12, 11}, {5, 12}};
  EXPECT_EQ(dog.bluetooth_parent, tree);
}

TEST(ConfigXmlTest, IdAndRealidCpmlinkAndCpglinkAreSynonyms) {
  const std::string a = TwoModules(
      R"(id="2" amplitude="0.5" offset="0" speed="1" minangle="-1" maxangle="1")",
      R"(<cpmlink to="1" phase="0.25" weight="2"/>)");
  const std::string b = TwoModules(kGoodAttributes,
                                   R"(<cpglink to="1" phase="0.25" weight="2"/>)");
  const std::string both = TwoModules(
      R"(realid="2" id="2" amplitude="0.5" offset="0" speed="1" minangle="-1" maxangle="1")",
      R"(<cpglink to="1" phase="0.25" weight="2"/>)");
  const RobotConfig config = ParseConfigXml(a);
  EXPECT_EQ(config, ParseConfigXml(b));
  EXPECT_EQ(config, ParseConfigXml(both));
  ASSERT_EQ(config.couplings.size(), 1u);
  EXPECT_EQ(config.couplings[0], (Coupling{2, 1, 0.25, 2.0}));
  EXPECT_EQ(config.master_id, 1);  // inferred: the root of the tree
}

TEST(ConfigXmlTest, RealidAndIdMustAgree) {
  ExpectParseError(
      TwoModules(
          R"(realid="2" id="3" amplitude="0.5" offset="0" speed="1" minangle="-1" maxangle="1")"),
      5, {"realid (2)", "id (3)", "disagree"});
}

TEST(ConfigXmlTest, MalformedXmlReportsTheLine) {
  // tinyxml2 names the line of the element left open.
  ExpectParseError("<yamorconfig>\n<modulelist>\n<module>\n</modulelist>\n",
                   3, {"malformed XML", "module"});
  ExpectParseError("<yamorconfig>\n\n<modulelist attr=>\n", 3,
                   {"malformed XML"});
  ExpectParseError("", 1, {"malformed XML"});
}

TEST(ConfigXmlTest, NumbersAreParsedStrictly) {
  for (const char* bad : {"abc", "1.0x", "", "1,5", "0x1p3", "1.0 2", "--1",
                          "+-1", "+"}) {
    SCOPED_TRACE(bad);
    ExpectParseError(
        TwoModules(std::string(R"(realid="2" amplitude=")") + bad +
                   R"(" offset="0" speed="1" minangle="-1" maxangle="1")"),
        5, {"module 2", "amplitude (\"", "not a number"});
  }
  ExpectParseError(
      TwoModules(
          R"(realid="2" amplitude="1e999" offset="0" speed="1" minangle="-1" maxangle="1")"),
      5, {"module 2", "amplitude (\"1e999\")", "range"});
  for (const char* bad : {"2.0", "two", "2 2", ""}) {
    SCOPED_TRACE(bad);
    ExpectParseError(
        TwoModules(std::string(R"(realid=")") + bad +
                   R"(" amplitude="0.5" offset="0" speed="1" minangle="-1" maxangle="1")"),
        5, {"realid (\"", "not an integer"});
  }
  ExpectParseError(TwoModules(kGoodAttributes,
                              R"(<cpglink to="x" phase="1" weight="1"/>)"),
                   6, {"module 2", "cpglink to (\"x\")", "not an integer"});
  ExpectParseError(TwoModules(kGoodAttributes,
                              R"(<cpglink to="1" phase="1" weight="heavy"/>)"),
                   6, {"module 2", "weight (\"heavy\")", "not a number"});
}

TEST(ConfigXmlTest, NumberFormsThatAreAccepted) {
  const struct {
    const char* text;
    double value;
  } cases[] = {{"1.0", 1.0},       {"-2.09", -2.09},  {"3.14159", 3.14159},
               {" 0.5 ", 0.5},     {"+0.5", 0.5},     {"1e-3", 1e-3},
               {".5", 0.5},        {"6", 6.0},        {"-0", 0.0},
               {"5e-324", 5e-324}, {"6.283185307179586", 6.283185307179586}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    const RobotConfig config = ParseConfigXml(TwoModules(
        std::string(R"(realid="2" amplitude="0.5" offset=")") + c.text +
        R"(" speed="1" minangle="-1" maxangle="1")"));
    EXPECT_EQ(config.modules[1].offset, c.value);
  }
  // The largest double is read exactly too, and refused by the range.
  ExpectParseError(TwoModules(R"(realid="2" amplitude="0.5" offset="1.7976931348623157e308" )"
                              R"(speed="1" minangle="-1" maxangle="1")"),
                   5, {"offset (1.7976931348623157e+308) must be in"});
}

TEST(ConfigXmlTest, MissingAttributes) {
  ExpectParseError(
      TwoModules(R"(realid="2" amplitude="0.5" offset="0" speed="1" minangle="-1")"),
      5, {"module 2", "missing attribute maxangle"});
  ExpectParseError(
      TwoModules(R"(amplitude="0.5" offset="0" speed="1" minangle="-1" maxangle="1")"),
      5, {"missing attribute realid"});
  ExpectParseError(TwoModules(kGoodAttributes, R"(<cpglink to="1" phase="1"/>)"),
                   6, {"module 2", "cpglink to (1)", "missing attribute weight"});
  ExpectParseError(TwoModules(kGoodAttributes, R"(<bluetooth/>)"), 6,
                   {"module 2", "missing attribute to"});
}

TEST(ConfigXmlTest, UnknownElementsAndAttributes) {
  ExpectParseError(TwoModules(kGoodAttributes, "<servo/>\n"), 6,
                   {"module 2", "unknown element <servo>"});
  ExpectParseError(
      TwoModules(kGoodAttributes + R"( frequency="2")"), 5,
      {"module 2", "unknown attribute frequency"});
  ExpectParseError(TwoModules(kGoodAttributes,
                              R"(<cpglink to="1" phase="1" weight="1" delay="2"/>)"),
                   6, {"module 2", "unknown attribute delay"});
  ExpectParseError(
      "<yamorconfig>\n<modulelist/>\n<camera/>\n</yamorconfig>\n", 3,
      {"unknown element <camera>", "<yamorconfig>"});
  ExpectParseError("<yamorconfig>\n<modulelist>\n<robot/>\n</modulelist>\n"
                   "</yamorconfig>\n",
                   3, {"unknown element <robot>", "<modulelist>"});
  ExpectParseError("<config/>\n", 1, {"<config>", "<yamorconfig>"});
  ExpectParseError("<yamorconfig speed=\"1\"/>\n", 1,
                   {"unknown attribute speed"});
  ExpectParseError(TwoModules(kGoodAttributes, "fast\n"), 6,
                   {"unexpected text \"fast\""});
  ExpectParseError("<yamorconfig>\n</yamorconfig>\n", 1, {"no <modulelist>"});
  ExpectParseError(
      "<yamorconfig>\n<modulelist/>\n<modulelist/>\n</yamorconfig>\n", 3,
      {"second <modulelist>"});
  ExpectParseError("<yamorconfig/>\n<yamorconfig/>\n", 2,
                   {"second root element"});
}

TEST(ConfigXmlTest, CommentsAndSchemaAttributesAreIgnored) {
  const std::string xml =
      "<?xml version=\"1.0\"?>\n<!-- robot -->\n"
      "<yamorconfig xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\">\n"
      "<!-- list --><modulelist><!-- m -->\n"
      "<module realid=\"4\" amplitude=\"0\" offset=\"0\" speed=\"0\" "
      "minangle=\"-1\" maxangle=\"1\"><!-- nothing --></module>\n"
      "</modulelist></yamorconfig>\n";
  const RobotConfig config = ParseConfigXml(xml, "c.xml");
  ASSERT_EQ(config.modules.size(), 1u);
  EXPECT_EQ(config.master_id, 4);
  EXPECT_EQ(config.source_file, "c.xml");
  EXPECT_EQ(config.module_locations.at(4).line, 5);
  EXPECT_EQ(config.module_locations.at(4).file, "c.xml");
}

TEST(ConfigXmlTest, LoadMissingFileIsNotFound) {
  const Error error = ErrorOf([] {
    LoadConfigFile((kRobotDir / "no-such-robot.xml").string());
  });
  EXPECT_EQ(error.code(), StatusCode::kNotFound);
  EXPECT_THAT(error.what(), HasSubstr("no-such-robot.xml"));
  EXPECT_EQ(ErrorOf([] { LoadConfigFile(kRobotDir.string()); }).code(),
            StatusCode::kNotFound);
}

TEST(ConfigXmlTest, LoadReportsTheFileName) {
  const fs::path path = fs::path(::testing::TempDir()) / "cpgxml_bad.xml";
  {
    std::ofstream out(path);
    out << TwoModules(
        R"(realid="2" amplitude="0.5" offset="0" speed="1" minangle="1" maxangle="-1")");
  }
  const Error error = ErrorOf([&] { LoadConfigFile(path.string()); });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(error.what(), StartsWith(path.string() + ":5: module 2: minangle"));
  fs::remove(path);
}

TEST(ConfigXmlTest, SaveAndLoad) {
  const RobotConfig config =
      LoadConfigFile((kRobotDir / "quadruped.xml").string());
  const fs::path path = fs::path(::testing::TempDir()) / "cpgxml_saved.xml";
  SaveConfigFile(config, path.string());
  const RobotConfig loaded = LoadConfigFile(path.string());
  EXPECT_EQ(loaded, config);
  EXPECT_EQ(loaded.source_file, path.string());
  fs::remove(path);
  EXPECT_EQ(ErrorOf([&] {
              SaveConfigFile(config, "/nonexistent-dir/cpgxml/robot.xml");
            }).code(),
            StatusCode::kNotFound);
}

TEST(ConfigXmlTest, CanonicalForm) {
  RobotConfig config;
  config.modules = {{12, 1.04, 1.04, 0.6, -1.57, 1.57},
                    {1, 0.0, -0.0, 0.0, -1.5, 1e-300},
                    {7, 0.1, 0.2, 2.5, -1.0, 1.0},
                    {6, 0.3, 0.0, 0.6, -1.0, 1.0}};
  // Couplings grouped by from-module in module order: the canonical order.
  config.couplings = {{12, 7, -2.09, 1.0},
                      {7, 12, 2.0943951023931953, 0.5},
                      {7, 6, 3.0, -1.0}};
  config.bluetooth_parent = {{7, 1}, {6, 1}, {12, 7}};
  config.master_id = 1;
  const std::string expected =
      R"(<?xml version="1.0" encoding="UTF-8"?>
<yamorconfig master="1">
  <modulelist>
    <module realid="12" amplitude="1.04" offset="1.04" speed="0.6" minangle="-1.57" maxangle="1.57">
      <cpglink to="7" phase="-2.09" weight="1"/>
    </module>
    <module realid="1" amplitude="0" offset="-0" speed="0" minangle="-1.5" maxangle="1e-300">
      <bluetooth to="6"/>
      <bluetooth to="7"/>
    </module>
    <module realid="7" amplitude="0.1" offset="0.2" speed="2.5" minangle="-1" maxangle="1">
      <bluetooth to="12"/>
      <cpglink to="12" phase="2.0943951023931953" weight="0.5"/>
      <cpglink to="6" phase="3" weight="-1"/>
    </module>
    <module realid="6" amplitude="0.3" offset="0" speed="0.6" minangle="-1" maxangle="1"/>
  </modulelist>
</yamorconfig>
)";
  EXPECT_EQ(WriteConfigXml(config), expected);
  EXPECT_EQ(ParseConfigXml(expected), config);
}

TEST(ConfigXmlTest, WriteGroupsCouplingsByModule) {
  RobotConfig config;
  config.modules = {{1, 0, 0, 0, -1, 1}, {2, 0, 0, 0, -1, 1}};
  config.couplings = {{2, 1, 0.5, 1.0}, {1, 2, -0.5, 1.0}};
  config.bluetooth_parent = {{2, 1}};
  config.master_id = 1;
  const RobotConfig reread = ParseConfigXml(WriteConfigXml(config));
  const std::vector<Coupling> grouped = {{1, 2, -0.5, 1.0}, {2, 1, 0.5, 1.0}};
  EXPECT_EQ(reread.couplings, grouped);
}

TEST(ConfigXmlTest, WriteRejectsInvalidConfigs) {
  RobotConfig config;
  config.modules = {{1, 0, 0, 0, 1, -1}};
  config.master_id = 1;
  const Error error = ErrorOf([&] { WriteConfigXml(config); });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(error.what(), HasSubstr("module 1: minangle"));
}

// --- Property: random valid configurations round-trip exactly. ---

// Doubles over the whole finite range: zeros, subnormals, extremes and
// random mantissas with exponents from 2^-1022 to 2^1023.
// Values beyond `limit` (the field's range, cpg/parameters.h) are folded
// back with fmod, which is exact, so the random mantissa bits survive.
double RandomDouble(std::mt19937_64& rng, bool non_negative, double limit) {
  double value = 0.0;
  switch (rng() % 10) {
    case 0: value = 0.0; break;
    case 1: value = -0.0; break;  // -0 >= 0 holds, so it is valid everywhere
    case 2:  // subnormal
      value = std::bit_cast<double>(rng() & ((std::uint64_t{1} << 52) - 1));
      break;
    case 3: value = limit; break;
    case 4: value = std::numeric_limits<double>::min(); break;
    case 5: value = static_cast<double>(rng() % 2001) / 1000.0; break;
    default: {
      const std::uint64_t exponent = 1 + rng() % 2046;  // biased, finite
      value = std::bit_cast<double>((exponent << 52) | (rng() >> 12));
    }
  }
  if (value > limit) value = std::fmod(value, limit);
  if (value != 0.0 && !non_negative && (rng() & 1)) value = -value;
  return value;
}

RobotConfig RandomConfig(std::mt19937_64& rng) {
  std::vector<ModuleId> pool(kMaxModuleId + 1);
  std::iota(pool.begin(), pool.end(), 0);
  std::shuffle(pool.begin(), pool.end(), rng);
  const std::size_t count = 1 + rng() % 24;
  std::vector<ModuleId> ids(pool.begin(), pool.begin() + count);

  RobotConfig config;
  // Tree over `ids` in one order, modules stored in another, so parents
  // often come after their children in the file.
  config.master_id = ids[0];
  for (std::size_t i = 1; i < count; ++i) {
    config.bluetooth_parent[ids[i]] = ids[rng() % i];
  }
  std::shuffle(ids.begin(), ids.end(), rng);
  for (ModuleId id : ids) {
    ModuleParams module;
    module.id = id;
    module.amplitude = RandomDouble(rng, true, kMaxAmplitude);
    module.offset = RandomDouble(rng, false, kMaxAmplitude);
    module.speed = RandomDouble(rng, true, kMaxSpeedHz);
    double low = RandomDouble(rng, false, kMaxLimitAngle);
    double high = RandomDouble(rng, false, kMaxLimitAngle);
    while (low == high) high = RandomDouble(rng, false, kMaxLimitAngle);
    module.min_angle = std::min(low, high);
    module.max_angle = std::max(low, high);
    config.modules.push_back(module);
  }
  // Couplings grouped by from-module in module order (the canonical order).
  for (ModuleId from : ids) {
    std::vector<ModuleId> others;
    for (ModuleId to : ids) {
      if (to != from) others.push_back(to);
    }
    std::shuffle(others.begin(), others.end(), rng);
    const std::size_t links = std::min<std::size_t>(others.size(), rng() % 4);
    for (std::size_t k = 0; k < links; ++k) {
      config.couplings.push_back({from, others[k], RandomDouble(rng, false, 1e6),
                                  RandomDouble(rng, false, kMaxCouplingWeight)});
    }
  }
  return config;
}

TEST(ConfigXmlPropertyTest, RandomConfigsRoundTripExactly) {
  std::mt19937_64 rng(20070601);
  for (int i = 0; i < 200; ++i) {
    const RobotConfig config = RandomConfig(rng);
    ASSERT_NO_THROW(Validate(config)) << "case " << i;
    const std::string written = WriteConfigXml(config);
    SCOPED_TRACE("case " + std::to_string(i) + ":\n" + written);
    const RobotConfig reread = ParseConfigXml(written);
    ASSERT_EQ(reread, config);
    // Bit-exact, including the sign of zero.
    ASSERT_EQ(WriteConfigXml(reread), written);
    for (std::size_t m = 0; m < config.modules.size(); ++m) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(reread.modules[m].offset),
                std::bit_cast<std::uint64_t>(config.modules[m].offset));
    }
  }
}

}  // namespace
}  // namespace yamor::cpg
