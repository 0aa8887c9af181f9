// Tests of the optimization configuration (thesis 5.7.2): loading the rules,
// resolving candidates through the constraint expressions, and the errors.
#include "optimizer-plugins/framework/optimization_config.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>
#include <unistd.h>

#include "common/log.h"
#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/robot_config.h"

namespace yamor::optimizer {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace fs = std::filesystem;

const std::string kQuadruped7 =
    (fs::path(YAMOR_SOURCE_DIR) / "configs" / "optimize" / "quadruped-7.xml").string();
constexpr double kPi = M_PI;
constexpr double kTwoPi = 2 * M_PI;

Error ErrorOf(const std::function<void()>& call) {
  try {
    call();
  } catch (const Error& error) {
    return error;
  }
  ADD_FAILURE() << "expected a yamor::Error";
  return Error(StatusCode::kOk, "");
}

std::map<std::string, double> AsMap(const std::vector<std::pair<std::string, double>>& values) {
  std::map<std::string, double> out;
  for (const auto& [name, value] : values) {
    EXPECT_TRUE(out.emplace(name, value).second) << name << " appears twice";
  }
  return out;
}

// Captures what the yamor logger writes while alive.
class LogCapture {
 public:
  LogCapture() : sink_(std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64)) {
    Log().sinks().push_back(sink_);
  }
  ~LogCapture() { std::erase(Log().sinks(), sink_); }
  std::string Text() const {
    std::string out;
    for (const std::string& line : sink_->last_formatted()) out += line;
    return out;
  }

 private:
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
};

// ---------------------------------------------------------------------------
// quadruped-7.xml

TEST(Quadruped7, SevenParametersWithTable61Bounds) {
  const OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  EXPECT_EQ(config.source(), kQuadruped7);
  const std::vector<OptimizeRule>& rules = config.optimized();
  ASSERT_EQ(rules.size(), 7u);
  const struct {
    const char* param;
    double min, max;
  } expected[] = {{"amplitude.0", 0, kPi / 4},      {"amplitude.5", 0, kPi / 2},
                  {"offset.5", -kPi / 2, 0},        {"phase.0.5", 0, kTwoPi},
                  {"phase.0.1", 0, kTwoPi},         {"phase.1.2", 0, kTwoPi},
                  {"phase.2.3", 0, kTwoPi}};
  for (std::size_t k = 0; k < 7; ++k) {
    EXPECT_EQ(rules[k].param, expected[k].param);
    EXPECT_DOUBLE_EQ(rules[k].min, expected[k].min) << rules[k].param;
    EXPECT_DOUBLE_EQ(rules[k].max, expected[k].max) << rules[k].param;
    EXPECT_GT(rules[k].line, 0);
  }
  // 3 hip amplitudes, 3 knee amplitudes, 3 knee offsets, 3 hip->knee lags
  // + 4 knee->hip back-links, ring closure + 4 ring back-links.
  EXPECT_EQ(config.constrained().size(), 21u);
  // The robot is quadruped.xml's, rules removed.
  const cpg::RobotConfig robot = cpg::LoadConfigFile(
      (fs::path(YAMOR_SOURCE_DIR) / "configs" / "robots" / "quadruped.xml").string());
  EXPECT_EQ(config.robot(), robot);
  EXPECT_EQ(cpg::ParseConfigXml(config.RobotXml()), robot);
  EXPECT_THAT(config.RobotXml(), ::testing::Not(HasSubstr("optimize")));
  EXPECT_THAT(config.RobotXml(), ::testing::Not(HasSubstr("constrain")));
}

TEST(Quadruped7, StartValuesAreTheRobotsValues) {
  const OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  const std::vector<double> start = config.StartValues();
  ASSERT_EQ(start.size(), 7u);
  const cpg::RobotConfig& robot = config.robot();
  EXPECT_EQ(start[0], robot.FindModule(0)->amplitude);
  EXPECT_EQ(start[1], robot.FindModule(5)->amplitude);
  EXPECT_EQ(start[2], robot.FindModule(5)->offset);
  EXPECT_EQ(start[3], robot.FindCoupling(0, 5)->phase);
  EXPECT_EQ(start[4], robot.FindCoupling(0, 1)->phase);
  // The file is already consistent with its constraints.
  const cpg::RobotConfig applied = config.Apply(start);
  for (const cpg::Coupling& c : robot.couplings) {
    EXPECT_NEAR(applied.FindCoupling(c.from, c.to)->phase, c.phase, 1e-12)
        << c.from << " -> " << c.to;
  }
}

TEST(Quadruped7, ResolveGivesTheConstrainedValues) {
  const OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  const std::vector<double> x = {0.5, 1.0, -0.7, 2.0, 1.0, 2.5, 4.0};
  const std::vector<std::pair<std::string, double>> resolved = config.Resolve(x);
  ASSERT_EQ(resolved.size(), 7u + 21u);
  for (std::size_t k = 0; k < 7; ++k) {
    EXPECT_EQ(resolved[k].first, config.optimized()[k].param);
    EXPECT_EQ(resolved[k].second, x[k]);
  }
  for (std::size_t k = 0; k < 21; ++k) {
    EXPECT_EQ(resolved[7 + k].first, config.constrained()[k].param);
  }
  const std::map<std::string, double> v = AsMap(resolved);
  for (int hip : {1, 2, 3}) EXPECT_EQ(v.at("amplitude." + std::to_string(hip)), 0.5);
  for (int knee : {6, 7, 8}) {
    EXPECT_EQ(v.at("amplitude." + std::to_string(knee)), 1.0);
    EXPECT_EQ(v.at("offset." + std::to_string(knee)), -0.7);
  }
  for (int leg = 0; leg < 4; ++leg) {
    const std::string hip = std::to_string(leg);
    const std::string knee = std::to_string(leg + 5);
    if (leg != 0) {
      EXPECT_EQ(v.at("phase." + hip + "." + knee), 2.0);
    }
    EXPECT_EQ(v.at("phase." + knee + "." + hip), -2.0);
  }
  // Ring closure: 1 + 2.5 + 4 = 7.5, so 3 -> 0 is 4π - 7.5 and the four lags
  // sum to 4π.
  const double closure = v.at("phase.3.0");
  EXPECT_NEAR(closure, 2 * kTwoPi - 7.5, 1e-12);
  EXPECT_GE(closure, 0.0);
  EXPECT_LT(closure, kTwoPi);
  const double sum = 1.0 + 2.5 + 4.0 + closure;
  EXPECT_NEAR(std::remainder(sum, kTwoPi), 0.0, 1e-12);
  // Back-links negated, including the one of the closing link.
  EXPECT_EQ(v.at("phase.1.0"), -1.0);
  EXPECT_EQ(v.at("phase.2.1"), -2.5);
  EXPECT_EQ(v.at("phase.3.2"), -4.0);
  EXPECT_EQ(v.at("phase.0.3"), -closure);
}

TEST(Quadruped7, RingClosesForAnyLags) {
  const OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> lag(0.0, kTwoPi);
  for (int i = 0; i < 200; ++i) {
    std::vector<double> x = config.StartValues();
    x[4] = lag(random);
    x[5] = lag(random);
    x[6] = lag(random);
    if (i == 0) x[4] = x[5] = x[6] = 2 * kPi / 3;  // sums to 2π exactly-ish
    if (i == 1) x[4] = x[5] = x[6] = 0;
    if (i == 2) x[4] = x[5] = x[6] = kTwoPi;
    const std::map<std::string, double> v = AsMap(config.Resolve(x));
    const double closure = v.at("phase.3.0");
    EXPECT_GE(closure, 0.0);
    EXPECT_LT(closure, kTwoPi);
    const double sum = x[4] + x[5] + x[6] + closure;
    EXPECT_NEAR(std::remainder(sum, kTwoPi), 0.0, 1e-9) << x[4] << " " << x[5] << " " << x[6];
    if (i <= 2) {
      EXPECT_EQ(closure, 0.0) << "no full turn for a closed ring";
    }
  }
}

TEST(Quadruped7, ApplySetsEveryResolvedValue) {
  const OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  const std::vector<double> x = {0.3, 1.2, -1.0, 5.0, 0.5, 0.25, 3.0};
  const cpg::RobotConfig applied = config.Apply(x);
  for (const auto& [name, value] : config.Resolve(x)) {
    const std::size_t dot = name.find('.');
    const std::string kind = name.substr(0, dot);
    const std::string ids = name.substr(dot + 1);
    if (kind == "phase") {
      const std::size_t dot2 = ids.find('.');
      const cpg::Coupling* c =
          applied.FindCoupling(std::stoi(ids.substr(0, dot2)), std::stoi(ids.substr(dot2 + 1)));
      ASSERT_NE(c, nullptr) << name;
      EXPECT_EQ(c->phase, value) << name;
    } else {
      const cpg::ModuleParams* m = applied.FindModule(std::stoi(ids));
      ASSERT_NE(m, nullptr) << name;
      EXPECT_EQ(kind == "amplitude" ? m->amplitude : m->offset, value) << name;
    }
  }
  EXPECT_EQ(applied.FindModule(2)->amplitude, 0.3);
  EXPECT_EQ(applied.FindModule(7)->offset, -1.0);
  EXPECT_EQ(applied.FindCoupling(8, 3)->phase, -5.0);
  // Untouched values stay, and robot() itself is not changed.
  EXPECT_EQ(applied.FindModule(4)->amplitude, 0.0);
  EXPECT_EQ(applied.FindModule(0)->speed, 0.3);
  EXPECT_EQ(applied.FindCoupling(0, 1)->weight, 1.0);
  EXPECT_NE(config.robot().FindModule(2)->amplitude, 0.3);
  cpg::Validate(applied);
}

TEST(Quadruped7, ConcurrentResolveMatchesSerial) {
  const OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  std::mt19937 random(42);
  std::vector<std::vector<double>> points;
  for (int i = 0; i < 400; ++i) {
    std::vector<double> x;
    for (const OptimizeRule& rule : config.optimized()) {
      x.push_back(std::uniform_real_distribution<double>(rule.min, rule.max)(random));
    }
    points.push_back(x);
  }
  std::vector<std::vector<std::pair<std::string, double>>> serial;
  for (const auto& x : points) serial.push_back(config.Resolve(x));

  constexpr int kThreads = 4;
  std::vector<std::vector<std::vector<std::pair<std::string, double>>>> results(kThreads);
  std::vector<std::thread> threads;
  const OptimizationConfig copy = config;  // copies share the parser pool
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      const OptimizationConfig& use = t % 2 == 0 ? config : copy;
      results[t].resize(points.size());
      for (std::size_t i = 0; i < points.size(); ++i) {
        // Each thread walks the points from its own starting point.
        const std::size_t k = (i + 97 * t) % points.size();
        results[t][k] = use.Resolve(points[k]);
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) {
    for (std::size_t k = 0; k < points.size(); ++k) {
      ASSERT_EQ(results[t][k], serial[k]) << "thread " << t << " point " << k;
    }
  }
}

TEST(Quadruped7, CopiesAndMovesKeepWorking) {
  OptimizationConfig config = OptimizationConfig::LoadFile(kQuadruped7);
  const std::vector<double> x = config.StartValues();
  const auto expected = config.Resolve(x);
  OptimizationConfig copy = config;
  OptimizationConfig moved = std::move(config);
  EXPECT_EQ(copy.Resolve(x), expected);
  EXPECT_EQ(moved.Resolve(x), expected);
  OptimizationConfig assigned = OptimizationConfig::LoadFile(kQuadruped7);
  assigned = copy;
  EXPECT_EQ(assigned.Resolve(x), expected);
}

TEST(Empty, DefaultConstructedRefusesUse) {
  OptimizationConfig empty;
  EXPECT_TRUE(empty.optimized().empty());
  EXPECT_EQ(ErrorOf([&] { empty.Resolve({}); }).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ErrorOf([&] { empty.StartValues(); }).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ErrorOf([&] { empty.Apply({}); }).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(ErrorOf([&] { empty.RobotXml(); }).code(), StatusCode::kFailedPrecondition);
  empty = OptimizationConfig::LoadFile(kQuadruped7);
  EXPECT_EQ(empty.Resolve(empty.StartValues()).size(), 28u);
}

// ---------------------------------------------------------------------------
// M2Pi

TEST(M2Pi, Values) {
  EXPECT_NEAR(M2Pi(4.0), kTwoPi - 4.0, 1e-15);
  EXPECT_EQ(M2Pi(kTwoPi), 0.0);
  EXPECT_EQ(M2Pi(0.0), 0.0);
  EXPECT_EQ(M2Pi(-0.0), 0.0);
  EXPECT_NEAR(M2Pi(-1.0), 1.0, 1e-15);
  EXPECT_NEAR(M2Pi(1.0), kTwoPi - 1.0, 1e-15);
  EXPECT_NEAR(M2Pi(3 * kPi / 2), kPi / 2, 1e-15);
  EXPECT_NEAR(M2Pi(kPi), kPi, 1e-15);
  EXPECT_NEAR(M2Pi(-7.0), 7.0 - kTwoPi, 1e-14);
  EXPECT_NEAR(M2Pi(100.0), std::ceil(100.0 / kTwoPi) * kTwoPi - 100.0, 1e-12);
  for (double x : {-20.0, -3.0, -0.5, 0.1, 2.0, 6.0, 13.0, 1000.0}) {
    const double r = M2Pi(x);
    EXPECT_GE(r, 0.0) << x;
    EXPECT_LT(r, kTwoPi) << x;
    EXPECT_NEAR(std::remainder(x + r, kTwoPi), 0.0, 1e-9) << x;
  }
}

TEST(M2Pi, NearMultiplesOfTwoPiGiveZero) {
  for (int k = -5; k <= 5; ++k) {
    for (double noise : {0.0, 1e-12, -1e-12, 1e-14, -1e-14}) {
      EXPECT_EQ(M2Pi(kTwoPi * k + noise), 0.0) << "k=" << k << " noise=" << noise;
    }
  }
  EXPECT_EQ(M2Pi(kPi / 2 + kPi / 2 + kPi / 2 + kPi / 2), 0.0);
  EXPECT_EQ(M2Pi(2 * kPi / 3 * 3), 0.0);
  EXPECT_GT(M2Pi(kTwoPi - 1e-6), 0.0);  // a real residue stays
  EXPECT_NEAR(M2Pi(kTwoPi - 1e-6), 1e-6, 1e-12);
}

TEST(M2Pi, NonFiniteIsNaN) {
  EXPECT_TRUE(std::isnan(M2Pi(std::nan(""))));
  EXPECT_TRUE(std::isnan(M2Pi(INFINITY)));
  EXPECT_TRUE(std::isnan(M2Pi(-INFINITY)));
}

// ---------------------------------------------------------------------------
// Small documents: expressions, rule order, errors.

// A two-module robot (lines 1-10) followed by `rules`, rule i on line 11 + i.
// Module 0: amplitude 0.5, offset 0.1; module 1: amplitude 0.25; coupling
// 0 -> 1 phase 1, 1 -> 0 phase -1.
std::string Doc(const std::vector<std::string>& rules) {
  std::string xml =
      "<yamorconfig master=\"0\">\n"                                             // 1
      "<modulelist>\n"                                                           // 2
      "<module realid=\"0\" amplitude=\"0.5\" offset=\"0.1\" speed=\"0.3\" "     // 3
      "minangle=\"-1\" maxangle=\"1\">\n"
      "  <bluetooth to=\"1\"/>\n"                                                // 4
      "  <cpglink to=\"1\" phase=\"1\" weight=\"1\"/>\n"                         // 5
      "</module>\n"                                                              // 6
      "<module realid=\"1\" amplitude=\"0.25\" offset=\"0\" speed=\"0.3\" "      // 7
      "minangle=\"-1\" maxangle=\"1\">\n"
      "  <cpglink to=\"0\" phase=\"-1\" weight=\"1\"/>\n"                        // 8
      "</module>\n"                                                              // 9
      "</modulelist>\n";                                                         // 10
  for (const std::string& rule : rules) xml += rule + "\n";
  return xml + "</yamorconfig>\n";
}

OptimizationConfig Load(const std::vector<std::string>& rules) {
  return OptimizationConfig::Parse(Doc(rules), "t.xml");
}

// Expects INVALID_ARGUMENT starting with "t.xml:<line>: " and containing
// every fragment.
void ExpectLoadError(const std::vector<std::string>& rules, int line,
                     const std::vector<std::string>& fragments) {
  const Error error = ErrorOf([&] { Load(rules); });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << error.what();
  EXPECT_THAT(error.what(), StartsWith("t.xml:" + std::to_string(line) + ": "));
  for (const std::string& fragment : fragments) {
    EXPECT_THAT(error.what(), HasSubstr(fragment));
  }
}

const std::string kOptimizeA0 = R"r(<optimize param="amplitude.0" min="0" max="1"/>)r";

// A constrain rule for amplitude.1.
std::string ConstrainA1(const std::string& expr) {
  return "<constrain param=\"amplitude.1\" expr=\"" + expr + "\"/>";
}

TEST(Expressions, ThesisFormWithArithmeticAndFunctions) {
  const OptimizationConfig config = Load({
      kOptimizeA0,
      R"r(<constrain param="amplitude.1" expr="2*amplitude.0()+sin(_pi/2)"/>)r",
      R"r(<constrain param="offset.1" expr="min(pi, amplitude.0()) - 1"/>)r",
      R"r(<constrain param="phase.0.1" expr="amplitude.0() > 0.4 ? M2Pi(amplitude.0()) : 0.5"/>)r",
      R"r(<constrain param="weight.0.1" expr="2.5 * (offset.0() + 1e-1) / 0.2"/>)r",
  });
  const std::map<std::string, double> v = AsMap(config.Resolve({0.3}));
  EXPECT_DOUBLE_EQ(v.at("amplitude.1"), 2 * 0.3 + 1);
  EXPECT_DOUBLE_EQ(v.at("offset.1"), 0.3 - 1);
  EXPECT_DOUBLE_EQ(v.at("phase.0.1"), 0.5);
  EXPECT_DOUBLE_EQ(v.at("weight.0.1"), 2.5);  // fixed offset.0 = 0.1 of the file
  const std::map<std::string, double> w = AsMap(config.Resolve({0.45}));
  EXPECT_DOUBLE_EQ(w.at("amplitude.1"), 1.9);
  EXPECT_DOUBLE_EQ(w.at("phase.0.1"), kTwoPi - 0.45);
}

TEST(Expressions, ThesisSpellingOfAConstrainRule) {
  const OptimizationConfig config = Load({
      kOptimizeA0,
      R"r(<optimize param="amplitude.1" expr="amplitude.0() / 2"/>)r",
  });
  ASSERT_EQ(config.optimized().size(), 1u);
  ASSERT_EQ(config.constrained().size(), 1u);
  EXPECT_EQ(config.constrained()[0].param, "amplitude.1");
  EXPECT_EQ(config.constrained()[0].expr, "amplitude.0() / 2");
  EXPECT_EQ(config.constrained()[0].line, 12);
  EXPECT_EQ(config.optimized()[0].line, 11);
  EXPECT_EQ(AsMap(config.Resolve({0.8})).at("amplitude.1"), 0.4);
}

TEST(Expressions, LaterRulesSeeEarlierResults) {
  const OptimizationConfig config = Load({
      kOptimizeA0,
      R"r(<constrain param="phase.0.1" expr="amplitude.0() * 2"/>)r",
      R"r(<constrain param="phase.1.0" expr="-phase.0.1()"/>)r",
      R"r(<constrain param="amplitude.1" expr="phase.0.1() + phase.1.0() + 0.125"/>)r",
  });
  for (double a : {0.0, 0.2, 0.9}) {
    const std::map<std::string, double> v = AsMap(config.Resolve({a}));
    EXPECT_EQ(v.at("phase.0.1"), 2 * a);
    EXPECT_EQ(v.at("phase.1.0"), -2 * a);
    EXPECT_EQ(v.at("amplitude.1"), 0.125);
  }
}

TEST(Expressions, ForwardReferenceReadsTheFileValueAndWarns) {
  LogCapture log;
  const OptimizationConfig config = Load({
      kOptimizeA0,
      R"r(<constrain param="amplitude.1" expr="phase.0.1()"/>)r",
      R"r(<constrain param="phase.0.1" expr="amplitude.0()"/>)r",
  });
  const std::map<std::string, double> v = AsMap(config.Resolve({0.75}));
  EXPECT_EQ(v.at("phase.0.1"), 0.75);
  EXPECT_EQ(v.at("amplitude.1"), 1.0);  // the file's phase 0 -> 1, not 0.75
  EXPECT_THAT(log.Text(),
              HasSubstr("t.xml:12: constrain rule for 'amplitude.1' calls phase.0.1()"));
}

TEST(Expressions, EveryParameterKindIsAFunction) {
  const OptimizationConfig config = Load({
      kOptimizeA0,
      R"r(<constrain param="weight.1.0" expr="amplitude.1() + offset.0() + speed.1() + )r"
      R"r(minangle.0() + maxangle.1() + phase.1.0() + weight.0.1()"/>)r",
  });
  EXPECT_DOUBLE_EQ(AsMap(config.Resolve({0.5})).at("weight.1.0"),
                   0.25 + 0.1 + 0.3 + -1 + 1 + -1 + 1);
}

TEST(Start, OutOfBoundsFileValueIsClampedWithAWarning) {
  LogCapture log;
  const OptimizationConfig config =
      Load({R"r(<optimize param="amplitude.0" min="0.6" max="1"/>)r",
            R"r(<optimize param="offset.0" min="-1" max="0"/>)r"});
  EXPECT_EQ(config.StartValues(), (std::vector<double>{0.6, 0.0}));
  EXPECT_THAT(log.Text(), HasSubstr("t.xml:11: the configuration's amplitude.0 = 0.5"));
  EXPECT_THAT(log.Text(), HasSubstr("t.xml:12: the configuration's offset.0 = 0.1"));
}

TEST(Errors, UnknownParameterNames) {
  ExpectLoadError({R"r(<optimize param="foo.3" min="0" max="1"/>)r"}, 11,
                  {"unknown parameter 'foo.3'"});
  ExpectLoadError({R"r(<optimize param="amplitude" min="0" max="1"/>)r"}, 11,
                  {"unknown parameter 'amplitude'"});
  ExpectLoadError({R"r(<optimize param="amplitude.01" min="0" max="1"/>)r"}, 11,
                  {"unknown parameter 'amplitude.01'"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.9" expr="1"/>)r"}, 12,
                  {"'amplitude.9'", "module 9 is not in the configuration"});
  ExpectLoadError({R"r(<optimize param="phase.0.7" min="0" max="1"/>)r"}, 11,
                  {"'phase.0.7'", "module 7"});
  ExpectLoadError({R"r(<optimize param="phase.0.0" min="0" max="1"/>)r"}, 11,
                  {"'phase.0.0'", "never coupled to itself"});
  ExpectLoadError({R"r(<optimize param="weight.1.1" min="0" max="1"/>)r"}, 11,
                  {"'weight.1.1'", "never coupled to itself"});
  ExpectLoadError({R"r(<optimize param="phase.0" min="0" max="1"/>)r"}, 11,
                  {"unknown parameter 'phase.0'"});
}

TEST(Errors, MissingCoupling) {
  std::string xml = Doc({R"r(<optimize param="phase.1.0" min="0" max="1"/>)r"});
  const std::string link = R"r(<cpglink to="0" phase="-1" weight="1"/>)r";
  xml.replace(xml.find(link), link.size(), "<!-- no link back -->");
  const Error error = ErrorOf([&] { OptimizationConfig::Parse(xml, "t.xml"); });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(error.what(), StartsWith("t.xml:11: "));
  EXPECT_THAT(error.what(), HasSubstr("'phase.1.0'"));
  EXPECT_THAT(error.what(), HasSubstr("no coupling 1 -> 0"));
}

TEST(Errors, DuplicateRules) {
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.0" expr="1"/>)r"}, 12,
                  {"'amplitude.0' is both optimized and constrained", "line 11"});
  ExpectLoadError({kOptimizeA0, R"r(<optimize param="amplitude.0" min="0" max="0.5"/>)r"}, 12,
                  {"'amplitude.0' is listed twice", "line 11"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="offset.1" expr="1"/>)r",
                   R"r(<optimize param="offset.1" expr="2"/>)r"},
                  13, {"'offset.1' is listed twice", "line 12"});
}

TEST(Errors, Bounds) {
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="1" max="1"/>)r"}, 11,
                  {"'amplitude.0'", "min (1) must be below max (1)"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="1" max="0.5"/>)r"}, 11,
                  {"min (1) must be below max (0.5)"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0" max="inf"/>)r"}, 11,
                  {"max (\"inf\") must be a finite number"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="nan" max="1"/>)r"}, 11,
                  {"min (\"nan\") must be a finite number"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0" max="1e999"/>)r"}, 11,
                  {"must be a finite number"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0" max="pi"/>)r"}, 11,
                  {"max (\"pi\") is not a number"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0"/>)r"}, 11, {"missing attribute max"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0" max="7"/>)r"}, 11,
                  {"'amplitude.0'", "bounds [0, 7] exceed what the modules accept"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="-0.1" max="1"/>)r"}, 11,
                  {"bounds [-0.1, 1] exceed"});
  ExpectLoadError({R"r(<optimize param="phase.0.1" min="-13" max="0"/>)r"}, 11,
                  {"'phase.0.1'", "exceed"});
  ExpectLoadError({R"r(<optimize param="speed.0" min="0" max="11"/>)r"}, 11,
                  {"'speed.0'", "exceed"});
}

TEST(Errors, MalformedRules) {
  ExpectLoadError({R"r(<optimize min="0" max="1"/>)r"}, 11, {"missing attribute param"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.1"/>)r"}, 12,
                  {"'amplitude.1'", "missing attribute expr"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.1" expr="  "/>)r"}, 12,
                  {"empty expr"});
  ExpectLoadError({kOptimizeA0, R"r(<optimize param="amplitude.1" expr="1" min="0"/>)r"}, 12,
                  {"takes no min/max"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.1" expr="1" min="0"/>)r"}, 12,
                  {"unknown attribute min on <constrain>"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0" max="1" step="0.1"/>)r"}, 11,
                  {"unknown attribute step"});
  ExpectLoadError({R"r(<optimize param="amplitude.0" min="0" max="1">x</optimize>)r"}, 11,
                  {"takes no content"});
  ExpectLoadError({kOptimizeA0, R"r(<fixed param="amplitude.1"/>)r"}, 12,
                  {"unknown element <fixed>"});
}

TEST(Errors, RulesOnlyAsChildrenOfTheRoot) {
  std::string xml = Doc({kOptimizeA0});
  xml.replace(xml.find("  <bluetooth"), 0, R"r(<constrain param="amplitude.1" expr="1"/>)r");
  const Error error = ErrorOf([&] { OptimizationConfig::Parse(xml, "t.xml"); });
  EXPECT_THAT(error.what(), StartsWith("t.xml:4: "));
  EXPECT_THAT(error.what(), HasSubstr("unknown element <constrain> in <module>"));
}

TEST(Errors, NoOptimizeRule) {
  ExpectLoadError({}, 1, {"no <optimize"});
  ExpectLoadError({R"r(<constrain param="amplitude.1" expr="1"/>)r"}, 1, {"no <optimize"});
}

TEST(Errors, RobotErrorsStillNameTheirLine) {
  std::string xml = Doc({kOptimizeA0});
  xml.replace(xml.find("speed=\"0.3\""), 11, "speed=\"x\"");
  const Error error = ErrorOf([&] { OptimizationConfig::Parse(xml, "t.xml"); });
  EXPECT_THAT(error.what(), StartsWith("t.xml:3: "));
  EXPECT_THAT(error.what(), HasSubstr("speed"));
}

TEST(Errors, ExpressionSyntaxNamesThePosition) {
  {
    const Error error =
        ErrorOf([] { Load({kOptimizeA0, ConstrainA1("amplitude.0()+")}); });
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(error.what(), StartsWith("t.xml:12: "));
    EXPECT_THAT(error.what(), HasSubstr("'amplitude.1'"));
    EXPECT_THAT(error.what(), HasSubstr("\"amplitude.0()+\""));
    EXPECT_THAT(error.what(), HasSubstr("at position 15"));
  }
  {
    const Error error =
        ErrorOf([] { Load({kOptimizeA0, ConstrainA1("1 + bogus.3()")}); });
    EXPECT_THAT(error.what(), StartsWith("t.xml:12: "));
    EXPECT_THAT(error.what(), HasSubstr("at position 4"));
    EXPECT_THAT(error.what(), HasSubstr("unknown parameter 'bogus.3'"));
  }
  {
    // A parameter without its brackets gets a hint.
    const Error error =
        ErrorOf([] { Load({kOptimizeA0, ConstrainA1("2*amplitude.0")}); });
    EXPECT_THAT(error.what(), StartsWith("t.xml:12: "));
    EXPECT_THAT(error.what(), HasSubstr("at position 2"));
    EXPECT_THAT(error.what(), HasSubstr("write amplitude.0()"));
  }
  {
    // A coupling that does not exist is no function.
    const Error error =
        ErrorOf([] { Load({kOptimizeA0, ConstrainA1("phase.0.0()")}); });
    EXPECT_THAT(error.what(), StartsWith("t.xml:12: "));
    EXPECT_THAT(error.what(), HasSubstr("at position 0"));
    EXPECT_THAT(error.what(), HasSubstr("never coupled to itself"));
  }
  {
    // No bracket hint for a parameter called with arguments.
    const Error error =
        ErrorOf([] { Load({kOptimizeA0, ConstrainA1("amplitude.0(1)")}); });
    EXPECT_THAT(error.what(), StartsWith("t.xml:12: "));
    EXPECT_THAT(error.what(), HasSubstr("Too many parameters"));
    EXPECT_THAT(error.what(), ::testing::Not(HasSubstr("write amplitude.0()")));
  }
}

TEST(Errors, NonFiniteAtTheStartPoint) {
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.1" expr="amplitude.0()/0"/>)r"}, 12,
                  {"'amplitude.1'", "evaluates to inf", "amplitude.0=0.5", "start point"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.1" expr="sqrt(-1)"/>)r"}, 12,
                  {"'amplitude.1'", "evaluates to nan"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="phase.0.1" expr="M2Pi(1/0)"/>)r"}, 12,
                  {"'phase.0.1'", "evaluates to nan"});
}

TEST(Errors, ConstrainedValueTheModulesRefuseAtTheStartPoint) {
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="amplitude.1" expr="-amplitude.0()"/>)r"}, 12,
                  {"'amplitude.1'", "evaluates to -0.5", "outside what the modules accept"});
  ExpectLoadError({kOptimizeA0, R"r(<constrain param="minangle.1" expr="2"/>)r"}, 12,
                  {"minangle.1 = 2 not below maxangle.1 = 1"});
}

TEST(Errors, LoadFileNamesTheFile) {
  const Error missing = ErrorOf([] { OptimizationConfig::LoadFile("/nonexistent/q.xml"); });
  EXPECT_EQ(missing.code(), StatusCode::kNotFound);
  EXPECT_THAT(missing.what(), HasSubstr("/nonexistent/q.xml"));

  const fs::path path = fs::temp_directory_path() /
                         ("yamor_optimization_config_test_" + std::to_string(::getpid()) + ".xml");
  {
    std::ofstream out(path);
    out << Doc({kOptimizeA0, R"r(<constrain param="amplitude.1" expr="(amplitude.0()"/>)r"});
  }
  const Error error = ErrorOf([&] { OptimizationConfig::LoadFile(path.string()); });
  fs::remove(path);
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(error.what(), StartsWith(path.string() + ":12: "));
}

TEST(Resolve, RejectsBadCandidates) {
  const OptimizationConfig config = Load({
      kOptimizeA0,
      R"r(<optimize param="offset.0" min="-1" max="1"/>)r",
      R"r(<constrain param="amplitude.1" expr="sqrt(amplitude.0() - 0.25)"/>)r",
  });
  EXPECT_EQ(config.Resolve({0.5, 0}).size(), 3u);
  const auto expect = [&](const std::vector<double>& x, const std::string& prefix,
                          const std::vector<std::string>& fragments) {
    const Error error = ErrorOf([&] { config.Resolve(x); });
    EXPECT_EQ(error.code(), StatusCode::kInvalidArgument) << error.what();
    EXPECT_THAT(error.what(), StartsWith(prefix));
    for (const std::string& fragment : fragments) EXPECT_THAT(error.what(), HasSubstr(fragment));
    const Error apply_error = ErrorOf([&] { config.Apply(x); });
    EXPECT_EQ(apply_error.code(), StatusCode::kInvalidArgument);
  };
  expect({0.5}, "t.xml: ", {"1 values but 2 parameters", "amplitude.0, offset.0"});
  expect({0.5, 0, 1}, "t.xml: ", {"3 values"});
  expect({std::nan(""), 0}, "t.xml:11: ", {"'amplitude.0'", "not finite"});
  expect({0.5, INFINITY}, "t.xml:12: ", {"'offset.0'", "not finite"});
  expect({1.5, 0}, "t.xml:11: ", {"'amplitude.0'", "1.5 is outside [0, 1]"});
  expect({0.5, -1.01}, "t.xml:12: ", {"'offset.0'", "outside [-1, 1]"});
  expect({0.125, 0.25}, "t.xml:13: ",
         {"'amplitude.1'", "sqrt(amplitude.0() - 0.25)", "evaluates to nan",
          "amplitude.0=0.125, offset.0=0.25"});
  // The bounds are inclusive.
  EXPECT_EQ(config.Resolve({1.0, -1.0}).size(), 3u);
}

TEST(Resolve, LimitAngleOrderIsChecked) {
  const OptimizationConfig config = Load({
      R"r(<optimize param="minangle.0" min="-1.5" max="1.5"/>)r",
  });
  EXPECT_EQ(config.Apply({0.5}).FindModule(0)->min_angle, 0.5);
  const Error error = ErrorOf([&] { config.Resolve({1.2}); });
  EXPECT_EQ(error.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(error.what(), HasSubstr("minangle.0 = 1.2 not below maxangle.0 = 1"));
}

}  // namespace
}  // namespace yamor::optimizer
