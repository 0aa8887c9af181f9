// The runner's decisions against a fake robot whose velocity is a function
// of its gait and its condition (ground, orientation, body, defects), a fake
// relearner (a grid over the first free parameter, each point a trial on the
// fake robot) and an in-memory log.
#include "optimizer-plugins/lifelong/life_cycle.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/status.h"
#include "cpg/config_xml.h"
#include "cpg/symmetry.h"
#include "optimizer-plugins/framework/optimization_config.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;
using cpg::Connector;

constexpr double kPeriod = 2.0;  // every fake gait has a 2 s CPG period

// A three-module chain 0-1-2 (0 central). Transformed: 2 moves from 1's rear
// to 0's left.
cpg::ModuleGraph Chain(bool transformed) {
  std::vector<cpg::GraphModule> modules = {{.id = 0}, {.id = 1}, {.id = 2}};
  std::vector<cpg::GraphEdge> edges = {{.a = 1, .a_connector = Connector::kFront, .b = 0,
                                        .b_connector = Connector::kRear, .angle_steps = 0}};
  if (transformed) {
    edges.push_back({.a = 2, .a_connector = Connector::kFront, .b = 0, .b_connector = Connector::kLeft,
                     .angle_steps = 0});
  } else {
    edges.push_back({.a = 2, .a_connector = Connector::kFront, .b = 1, .b_connector = Connector::kRear,
                     .angle_steps = 0});
  }
  return cpg::ModuleGraph(0, modules, edges);
}

const char* const kChainConfig = R"(<yamorconfig master="0"><modulelist>
  <module realid="0" amplitude="0.5" offset="0" speed="0.5" minangle="-1.5" maxangle="1.5"><bluetooth to="1"/>
    <cpglink to="1" phase="1" weight="1"/></module>
  <module realid="1" amplitude="0.5" offset="0" speed="0.5" minangle="-1.5" maxangle="1.5"><bluetooth to="2"/>
    <cpglink to="0" phase="-1" weight="1"/><cpglink to="2" phase="1" weight="1"/></module>
  <module realid="2" amplitude="0.5" offset="0" speed="0.5" minangle="-1.5" maxangle="1.5">
    <cpglink to="1" phase="-1" weight="1"/></module>
</modulelist></yamorconfig>)";

// The chain's config as an optimization problem: one amplitude for all.
std::string ChainProblem() {
  std::string xml = kChainConfig;
  xml.insert(xml.rfind("</yamorconfig>"),
             "<optimize param=\"amplitude.0\" min=\"0\" max=\"1\"/>"
             "<constrain param=\"amplitude.1\" expr=\"amplitude.0()\"/>"
             "<constrain param=\"amplitude.2\" expr=\"amplitude.0()\"/>");
  return xml;
}

// The fake robot's condition.
struct World {
  bool slippery = false;
  bool upside_down = false;
  bool transformed = false;
  std::set<int> dead;
  std::map<int, std::string> limp;
};

// Mean amplitude of the driven modules of `config`.
double MeanAmplitude(const cpg::RobotConfig& config) {
  double sum = 0;
  int n = 0;
  for (const auto& m : config.modules) {
    if (m.amplitude > 0) {
      sum += m.amplitude;
      ++n;
    }
  }
  return n ? sum / n : 0;
}

// The velocity a gait reaches: its best mean amplitude depends on the condition.
double Velocity(const cpg::RobotConfig& config, const World& w) {
  const double a = MeanAmplitude(config);
  if (w.upside_down) return 0.02 - 0.1 * (a - 0.2) * (a - 0.2);
  if (w.slippery) return 0.03 - 0.2 * (a - 0.9) * (a - 0.9);
  if (!w.dead.empty()) return 0.04 - 0.2 * (a - 0.7) * (a - 0.7);
  if (!w.limp.empty()) return 0.035 - 0.2 * (a - 0.3) * (a - 0.3);
  if (w.transformed) return 0.045 - 0.2 * (a - 0.8) * (a - 0.8);
  return 0.05 - 0.2 * (a - 0.5) * (a - 0.5);
}

class FakeRobot final : public RobotPort {
 public:
  World world;
  std::string config_xml;
  double time = 0;
  std::vector<RobotEvent> events;
  // Changes at robot times: applied when a measurement or settle reaches them.
  std::multimap<double, std::function<void(FakeRobot&)>> schedule;
  int walks = 0;
  int measures = 0;
  int fail_measure_at = -1;  // the n-th Measure throws kUnavailable
  bool restart_on_reattach = false;
  int reattaches = 0;
  std::atomic<bool> stop{false};
  bool rolling = false;     // the gait turns the central module over and over
  bool tilted = false;      // upside down for the accelerometer only
  int accel_reads = 0;
  // What a window measures instead of the clean velocity of the gait (noise,
  // an erratic gait); null: the clean velocity.
  std::function<double(double clean, const cpg::RobotConfig& config)> adjust;

  double Now() override { return time; }
  Window Measure(double periods) override {
    if (stop.load()) throw Error(StatusCode::kCancelled, "stopped");
    if (measures++ == fail_measure_at) throw Error(StatusCode::kUnavailable, "fake daemon gone");
    const double start = time;
    Advance(periods * kPeriod);
    const cpg::RobotConfig config = cpg::ParseConfigXml(config_xml);
    const double clean = Velocity(config, world);
    return Window{.start_time = start,
                  .end_time = time,
                  .velocity = adjust ? adjust(clean, config) : clean,
                  .period = kPeriod};
  }
  void Settle(double periods) override {
    if (stop.load()) throw Error(StatusCode::kCancelled, "stopped");
    Advance(periods * kPeriod);
  }
  std::vector<RobotEvent> TakeEvents() override { return std::exchange(events, {}); }
  AccelReading ReadAccelerometer() override {
    AccelReading r;
    r.valid = true;
    r.samples = 16;
    const bool down = world.upside_down || tilted || (rolling && (accel_reads++ % 3 == 1));
    r.mean = {0.3, 0.0, down ? -9.6 : 9.7};
    r.spread = 0.5;
    return r;
  }
  std::pair<cpg::ModuleGraph, std::string> Body() override {
    return {Chain(world.transformed), world.transformed ? "<morphology transformed/>" : "<morphology/>"};
  }
  void Walk(const std::string& xml) override {
    cpg::ParseConfigXml(xml);  // the daemon would refuse a bad one
    config_xml = xml;
    ++walks;
    events.push_back({.time = time, .kind = "config_loaded"});
  }
  Reattachment Reattach(const std::string& xml, const std::function<bool()>& should_stop) override {
    if (should_stop()) throw Error(StatusCode::kCancelled, "stopped");
    ++reattaches;
    Walk(xml);
    if (restart_on_reattach) {
      time = 0;
      return {.robot_time = 0, .restarted = true};
    }
    time += 5;
    return {.robot_time = time, .restarted = false};
  }
  void RequestStop() override { stop.store(true); }

  // Physical-change events as the daemon reports them.
  void Transform() {
    world.transformed = true;
    events.push_back({.time = time, .kind = "module_disconnected", .module_id = 2});
    events.push_back({.time = time, .kind = "module_connected", .module_id = 2, .detail = "to module 0"});
  }
  void KillModule(int id) {
    world.dead.insert(id);
    events.push_back({.time = time, .kind = "defect_set", .module_id = id, .detail = "module"});
  }
  void LimpMotor(int id) {
    world.limp[id] = "limp";
    events.push_back({.time = time, .kind = "defect_set", .module_id = id, .detail = "motor limp"});
  }

 private:
  void Advance(double seconds) {
    const double end = time + seconds;
    while (!schedule.empty() && schedule.begin()->first <= end) {
      auto action = schedule.begin()->second;
      time = std::max(time, schedule.begin()->first);
      schedule.erase(schedule.begin());
      action(*this);
    }
    time = end;
  }
};

// Tries 11 values of the first free parameter, each one trial on the robot.
class FakeRelearner final : public Relearner {
 public:
  explicit FakeRelearner(FakeRobot& robot) : robot_(robot) {}
  std::vector<RelearnRequest> requests;
  int fail_first = 0;  // the first N runs fail with this code (0: none)
  int failures_left = 0;
  std::atomic<bool> stopped{false};

  RelearnResult Relearn(const RelearnRequest& request, const std::function<void(const Trial&)>& on_trial) override {
    requests.push_back(request);
    RelearnResult result;
    if (failures_left > 0) {
      --failures_left;
      result.error = "fake failure";
      result.error_code = fail_first;
      result.status = "failed";
      return result;
    }
    const optimizer::OptimizationConfig config = optimizer::OptimizationConfig::Parse(request.problem_xml, "req");
    std::vector<double> x = config.StartValues();
    const auto& rule = config.optimized().at(0);
    double best = -1;
    std::vector<double> best_x = x;
    for (int i = 0; i <= 10 && !stopped.load(); ++i) {
      x[0] = rule.min + (rule.max - rule.min) * i / 10.0;
      robot_.Walk(cpg::WriteConfigXml(config.Apply(x)));
      const Window w = robot_.Measure(3);
      on_trial(Trial{.time = w.end_time, .velocity = w.velocity});
      ++result.trials;
      if (w.velocity > best) {
        best = w.velocity;
        best_x = x;
      }
    }
    result.ok = true;
    result.status = "converged";
    result.config_xml = cpg::WriteConfigXml(config.Apply(best_x));
    for (std::size_t i = 0; i < best_x.size(); ++i) {
      result.parameters.emplace_back(config.optimized()[i].param, best_x[i]);
    }
    result.velocity = best;
    result.evaluations = result.trials;
    return result;
  }
  void RequestStop() override { stopped.store(true); }
  std::string mode() const override { return "fake"; }

 private:
  FakeRobot& robot_;
};

class MemoryLog final : public LifeLog {
 public:
  std::vector<TimelineRow> rows;
  std::vector<LifeEvent> events;
  std::function<void(const LifeEvent&)> on_event;
  void Row(const TimelineRow& row) override { rows.push_back(row); }
  void Event(const LifeEvent& event) override {
    events.push_back(event);
    if (on_event) on_event(event);
  }
  std::vector<const LifeEvent*> Of(const std::string& kind) const {
    std::vector<const LifeEvent*> out;
    for (const auto& e : events) {
      if (e.kind == kind) out.push_back(&e);
    }
    return out;
  }
  static std::string Field(const LifeEvent& e, const std::string& key) {
    for (const auto& [k, v] : e.fields) {
      if (k == key) return v;
    }
    return "";
  }
};

class LifeCycleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("life_cycle_test_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    db_ = std::make_unique<GaitDatabase>((dir_ / "gaits.sqlite").string());
  }
  void TearDown() override {
    db_.reset();
    fs::remove_all(dir_);
  }
  LifeOptions Options(double life_seconds) {
    LifeOptions o;
    o.max_life_seconds = life_seconds;
    if (tweak_) tweak_(o);
    return o;
  }
  LifeSummary Live(double life_seconds, const std::string& problem = ChainProblem()) {
    LifeCycle life(robot_, relearner_, *db_, log_, Options(life_seconds));
    return life.Run({.config_xml = kChainConfig, .problem_xml = problem, .source = "chain"});
  }
  int Anomalies(const std::string& trigger) const {
    int n = 0;
    for (const LifeEvent* e : log_.Of("anomaly")) n += MemoryLog::Field(*e, "trigger") == JsonString(trigger);
    return n;
  }

  // A stored gait of the chain (amplitude 0.9: the slippery ground's best,
  // 3 cm/s there) that measures erratically: expected 3 cm/s, window noise
  // `noise`. Its recall trial windows measure `trial` in turn (then clean).
  std::int64_t StoreErraticGait(double noise, std::vector<double> trial) {
    cpg::RobotConfig config = cpg::ParseConfigXml(kChainConfig);
    for (auto& m : config.modules) m.amplitude = 0.9;
    GaitRecord g;
    g.morphology_key = cpg::MorphologyKey(Chain(false));
    g.config_xml = cpg::WriteConfigXml(config);
    g.problem_xml = ChainProblem();
    g.parameters = {{"amplitude.0", 0.9}};
    g.expected_velocity = 0.03;
    g.velocity_noise = noise;
    g.noise_windows = 40;
    g.use_count = 1;
    g.origin = "online";
    g.symptoms = {.trigger = "velocity_drop", .velocity_before = 0.05, .velocity_after = 0.0};
    trial_ = std::move(trial);
    robot_.adjust = [this](double clean, const cpg::RobotConfig& c) {
      if (std::fabs(MeanAmplitude(c) - 0.9) > 1e-9 || next_trial_ >= trial_.size()) return clean;
      return trial_[next_trial_++];
    };
    // The ground turns slippery: the initial gait (amplitude 0.5) stops.
    robot_.schedule.emplace(100, [](FakeRobot& r) { r.world.slippery = true; });
    return db_->Insert(g);
  }
  std::vector<const LifeEvent*> Trials() const { return log_.Of("recall_trial"); }
  // The stored gait's trial of `windows` windows was rejected, its last
  // window's decision "rejected", and the anomaly relearned.
  void ExpectRejectedAndRelearned(const LifeSummary& s, std::size_t windows) const {
    EXPECT_EQ(s.status.recalls, 0);
    EXPECT_EQ(s.status.relearns, 1);
    ASSERT_EQ(Trials().size(), windows);
    EXPECT_EQ(MemoryLog::Field(*Trials().back(), "decision"), JsonString("rejected"));
  }

  fs::path dir_;
  std::unique_ptr<GaitDatabase> db_;
  std::function<void(LifeOptions&)> tweak_;
  std::vector<double> trial_;
  std::size_t next_trial_ = 0;
  FakeRobot robot_;
  FakeRelearner relearner_{robot_};
  MemoryLog log_;
};

TEST_F(LifeCycleTest, UndisturbedWalkingRaisesNoAnomalyAndStoresTheInitialGait) {
  const LifeSummary s = Live(600);
  EXPECT_EQ(s.reason, "time limit");
  EXPECT_EQ(s.status.anomalies, 0);
  EXPECT_TRUE(relearner_.requests.empty());
  ASSERT_EQ(log_.Of("start").size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("start")[0], "known"), "false");
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 1u);
  EXPECT_EQ(gaits[0].origin, "initial");
  EXPECT_EQ(gaits[0].use_count, 1);
  EXPECT_NEAR(gaits[0].expected_velocity, 0.05, 1e-12);
  EXPECT_EQ(gaits[0].problem_xml, ChainProblem());
  EXPECT_EQ(gaits[0].morphology_key, cpg::MorphologyKey(Chain(false)));
  // One row per 6 s window, all walking at 5 cm/s.
  ASSERT_GE(log_.rows.size(), 95u);
  for (const auto& r : log_.rows) {
    EXPECT_EQ(r.state, "walking");
    EXPECT_NEAR(r.velocity, 0.05, 1e-12);
    EXPECT_EQ(r.gait, gaits[0].id);
  }
}

TEST_F(LifeCycleTest, ASecondLifeFindsItsInitialGaitInTheDatabase) {
  Live(60);
  log_.events.clear();
  robot_.time = 0;
  Live(60);
  ASSERT_EQ(log_.Of("start").size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("start")[0], "known"), "true");
  ASSERT_EQ(db_->All().size(), 1u);
  EXPECT_EQ(db_->All()[0].use_count, 2);
}

TEST_F(LifeCycleTest, SlipperyGroundIsRelearnedThenTheOldGaitIsRecalledBothWays) {
  robot_.schedule.emplace(100, [](FakeRobot& r) { r.world.slippery = true; });
  robot_.schedule.emplace(400, [](FakeRobot& r) { r.world.slippery = false; });
  robot_.schedule.emplace(700, [](FakeRobot& r) { r.world.slippery = true; });
  const LifeSummary s = Live(1000);
  // Three anomalies, one optimization: the other two come from the database.
  EXPECT_EQ(s.status.anomalies, 3);
  EXPECT_EQ(s.status.relearns, 1);
  EXPECT_EQ(s.status.recalls, 2);
  ASSERT_EQ(relearner_.requests.size(), 1u);
  EXPECT_EQ(Anomalies("velocity_drop"), 3);
  // The drop was seen in the first window ending after the change.
  const LifeEvent& first = *log_.Of("anomaly")[0];
  EXPECT_GT(first.time, 100);
  EXPECT_LE(first.time, 106);
  ASSERT_EQ(log_.Of("relearn").size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("relearn")[0], "how"), JsonString("same parameters"));
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 2u);
  const GaitRecord& a = gaits[0];
  const GaitRecord& b = gaits[1];
  EXPECT_EQ(b.predecessor, a.id);
  EXPECT_EQ(b.origin, "fake");
  EXPECT_EQ(b.symptoms.trigger, "velocity_drop");
  EXPECT_GT(b.symptoms.Drop(), 0.5);
  EXPECT_NEAR(MeanAmplitude(cpg::ParseConfigXml(b.config_xml)), 0.9, 1e-9);
  EXPECT_NEAR(b.expected_velocity, 0.03, 1e-9);  // its first window
  ASSERT_EQ(b.parameters.size(), 1u);
  EXPECT_EQ(b.parameters[0].first, "amplitude.0");
  // Recalls: A back on normal ground, B on slippery ground again.
  const auto recalled = log_.Of("recalled");
  ASSERT_EQ(recalled.size(), 2u);
  EXPECT_EQ(MemoryLog::Field(*recalled[0], "gait"), std::to_string(a.id));
  EXPECT_EQ(MemoryLog::Field(*recalled[1], "gait"), std::to_string(b.id));
  EXPECT_EQ(db_->Switches(b.id, a.id), 1);
  EXPECT_EQ(db_->Switches(a.id, b.id), 1);
  // The timeline shows each state.
  std::set<std::string> states;
  for (const auto& r : log_.rows) states.insert(r.state);
  EXPECT_EQ(states, (std::set<std::string>{"walking", "anomaly", "recalling", "relearning"}));
  EXPECT_EQ(s.status.gait, b.id);
}

TEST_F(LifeCycleTest, AnErraticGaitWhoseTrialLandsLowWithinItsNoiseIsRecalled) {
  // 2.1 of 3 cm/s: below 0.8 of the expectation (the plain rule rejects it,
  // next test), but within 2 of its 0.8 cm/s window noise.
  const std::int64_t b = StoreErraticGait(0.008, {0.021});
  const LifeSummary s = Live(200);
  EXPECT_EQ(s.status.anomalies, 1);
  EXPECT_EQ(s.status.recalls, 1);
  EXPECT_EQ(s.status.relearns, 0);
  EXPECT_TRUE(relearner_.requests.empty());
  EXPECT_EQ(s.status.trials, 1);  // one window was enough
  ASSERT_EQ(Trials().size(), 1u);
  const LifeEvent& t = *Trials()[0];
  EXPECT_EQ(MemoryLog::Field(t, "gait"), std::to_string(b));
  EXPECT_EQ(MemoryLog::Field(t, "decision"), JsonString("accepted"));
  EXPECT_EQ(MemoryLog::Field(t, "noise"), JsonNumber(0.008));
  EXPECT_NEAR(std::stod(MemoryLog::Field(t, "accept_level")), 0.015, 1e-12);  // 3 − min(2·0.8, 0.5·3)
  EXPECT_EQ(s.status.gait, b);
  const GaitRecord r = *db_->Find(b);
  EXPECT_EQ(r.use_count, 2);
  EXPECT_NEAR(std::stod(MemoryLog::Field(*log_.Of("recalled")[0], "velocity")), 0.021, 1e-12);
  // Walking on, it learned its noise again (clean now) around 3 cm/s.
  EXPECT_NEAR(r.expected_velocity, 0.03, 0.002);
  EXPECT_LT(r.velocity_noise, 0.003);
  EXPECT_GE(r.noise_windows, 4);
}

TEST_F(LifeCycleTest, ThePlainRuleRejectsTheSameTrialAndRelearns) {
  tweak_ = [](LifeOptions& o) {
    o.recall_noise_factor = 0;
    o.recall_restart_floor = 0;
  };
  StoreErraticGait(0.008, {0.021});
  const LifeSummary s = Live(200);
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(s, 1));
}

TEST_F(LifeCycleTest, ACleanGaitKeepsTheOneWindowRuleWithoutTheRestartWindow) {
  // Window noise 0.1 cm/s: 2·d is less than the plain 20 %, so the plain
  // rule judges, in one window.
  tweak_ = [](LifeOptions& o) { o.recall_restart_floor = 0; };
  StoreErraticGait(0.001, {0.023, 0.03, 0.03});
  const LifeSummary s = Live(200);
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(s, 1));
  EXPECT_NEAR(std::stod(MemoryLog::Field(*Trials()[0], "accept_level")), 0.024, 1e-12);
}

// The start-up from a near standstill (seed 5 of the recall benchmark: a
// clean 3.3 cm/s gait's first window 1.6, then 3.35): a clean gait's low
// first window gets a second, judged alone.
TEST_F(LifeCycleTest, ACleanGaitsLowFirstWindowGetsASecondJudgedAlone) {
  const std::int64_t b = StoreErraticGait(0.001, {0.016, 0.0295});
  const LifeSummary s = Live(200);
  EXPECT_EQ(s.status.recalls, 1);
  EXPECT_EQ(s.status.relearns, 0);
  EXPECT_EQ(s.status.trials, 2);
  ASSERT_EQ(Trials().size(), 2u);
  EXPECT_EQ(MemoryLog::Field(*Trials()[0], "decision"), JsonString("longer"));
  EXPECT_NEAR(std::stod(MemoryLog::Field(*Trials()[0], "fail_level")), 0.012, 1e-12);  // 0.4 · 3
  EXPECT_EQ(MemoryLog::Field(*Trials()[1], "decision"), JsonString("accepted"));
  EXPECT_NEAR(std::stod(MemoryLog::Field(*Trials()[1], "judged")), 0.0295, 1e-12);  // alone, not the mean
  ASSERT_EQ(log_.Of("recalled").size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("recalled")[0], "gait"), std::to_string(b));
  EXPECT_NEAR(std::stod(MemoryLog::Field(*log_.Of("recalled")[0], "velocity")), 0.0295, 1e-12);
}

TEST_F(LifeCycleTest, ACleanGaitLowInBothWindowsIsRejectedAfterTwo) {
  StoreErraticGait(0.001, {0.016, 0.02, 0.03});
  const LifeSummary s = Live(200);
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(s, 2));
  EXPECT_EQ(MemoryLog::Field(*Trials()[0], "decision"), JsonString("longer"));
}

TEST_F(LifeCycleTest, ACleanGaitsFirstWindowBelowTheRestartFloorIsRejectedAtOnce) {
  StoreErraticGait(0.001, {0.011, 0.03});
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(Live(200), 1));
}

TEST_F(LifeCycleTest, AnInconclusiveTrialOfANoisyGaitGetsMoreWindowsEachATrial) {
  // 1.0 cm/s: below the acceptance (1.5) but not below what the noise
  // allows a failure (3 − 3·0.8 = 0.6): one more window; the mean of the two
  // (2.0) reaches 3 − 2·0.8/√2 = 1.87.
  const std::int64_t b = StoreErraticGait(0.008, {0.010, 0.030});
  EXPECT_EQ(b, 1);
  const LifeSummary s = Live(200);
  EXPECT_EQ(s.status.recalls, 1);
  EXPECT_EQ(s.status.relearns, 0);
  EXPECT_EQ(s.status.trials, 2);
  ASSERT_EQ(Trials().size(), 2u);
  EXPECT_EQ(MemoryLog::Field(*Trials()[0], "decision"), JsonString("longer"));
  EXPECT_EQ(MemoryLog::Field(*Trials()[0], "accepted"), "false");
  EXPECT_EQ(MemoryLog::Field(*Trials()[1], "decision"), JsonString("accepted"));
  EXPECT_EQ(MemoryLog::Field(*Trials()[1], "window"), "2");
  EXPECT_NEAR(std::stod(MemoryLog::Field(*Trials()[1], "mean")), 0.02, 1e-12);
  ASSERT_EQ(log_.Of("recalled").size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("recalled")[0], "windows"), "2");
  EXPECT_EQ(MemoryLog::Field(*log_.Of("recalled")[0], "gait"), std::to_string(b));
  EXPECT_NEAR(std::stod(MemoryLog::Field(*log_.Of("recalled")[0], "velocity")), 0.02, 1e-12);  // the mean
  // Each window is a row of the timeline, in the recalling state.
  int recall_rows = 0;
  for (const auto& r : log_.rows) recall_rows += r.state == "recalling" && std::isfinite(r.velocity);
  EXPECT_EQ(recall_rows, 2);
}

TEST_F(LifeCycleTest, AGaitThatStoppedWalkingIsRejectedAtOnce) {
  // 0.05 cm/s against 3 ± 0.8: below 3 − 3·0.8, beyond the gait's noise.
  StoreErraticGait(0.008, std::vector<double>(10, 0.0005));
  const LifeSummary s = Live(200);
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(s, 1));
}

TEST_F(LifeCycleTest, AVeryNoisyGaitThatStoppedWalkingIsRejectedWithinTheWindowLimit) {
  // Noise as large as the expectation: a standstill is inside the noise for
  // a while, but never reaches the floor (half the expectation), and the
  // trial ends at --recall-windows.
  StoreErraticGait(0.03, std::vector<double>(10, 0.0005));
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(Live(250), 4));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(MemoryLog::Field(*Trials()[i], "decision"), JsonString("longer"));
  for (const LifeEvent* t : Trials()) EXPECT_EQ(MemoryLog::Field(*t, "accepted"), "false");
}

TEST_F(LifeCycleTest, TheTrialWindowLimitIsAnOption) {
  tweak_ = [](LifeOptions& o) { o.recall_max_windows = 1; };
  StoreErraticGait(0.008, {0.010, 0.030});
  ASSERT_NO_FATAL_FAILURE(ExpectRejectedAndRelearned(Live(200), 1));
}

TEST_F(LifeCycleTest, TheGaitsWindowNoiseIsStoredWhileItWalks) {
  // The gait measures 5 ± 0.4 cm/s, alternately.
  int n = 0;
  robot_.adjust = [&n](double clean, const cpg::RobotConfig&) { return clean + (n++ % 2 ? 0.004 : -0.004); };
  std::int64_t windows_at_150 = -1;
  robot_.schedule.emplace(150, [&](FakeRobot&) { windows_at_150 = db_->Find(1)->noise_windows; });
  const LifeSummary s = Live(300);
  EXPECT_EQ(s.status.anomalies, 0);
  // Written while walking (a kill -9 at 150 s would have kept it), not only at the end.
  EXPECT_GE(windows_at_150, 4);
  const GaitRecord g = *db_->Find(1);
  EXPECT_GT(g.velocity_noise, 0.003);
  EXPECT_LT(g.velocity_noise, 0.009);
  EXPECT_GE(g.noise_windows, 45);  // 300 s of 6 s windows, all of this gait
  // The expectation is the EMA the noise is measured around, not the first
  // window (4.6 cm/s).
  EXPECT_NEAR(g.expected_velocity, 0.05, 0.002);
}

TEST_F(LifeCycleTest, WithoutPeriodicWritesTheNoiseIsStoredWhenTheGaitIsLeft) {
  tweak_ = [](LifeOptions& o) { o.noise_write_windows = 0; };
  int n = 0;
  robot_.adjust = [&n](double clean, const cpg::RobotConfig& c) {
    return std::fabs(MeanAmplitude(c) - 0.5) < 1e-9 ? clean + (n++ % 2 ? 0.004 : -0.004) : clean;
  };
  robot_.schedule.emplace(100, [](FakeRobot& r) { r.world.slippery = true; });
  std::int64_t windows_at_60 = -1, windows_at_130 = -1;
  robot_.schedule.emplace(60, [&](FakeRobot&) { windows_at_60 = db_->Find(1)->noise_windows; });
  // 130 s: in the relearning that followed the drop.
  robot_.schedule.emplace(130, [&](FakeRobot&) { windows_at_130 = db_->Find(1)->noise_windows; });
  const LifeSummary s = Live(200);
  EXPECT_EQ(s.status.relearns, 1);
  EXPECT_EQ(windows_at_60, 0);
  EXPECT_GE(windows_at_130, 10);  // the windows before the drop, the drop's own not counted
  EXPECT_LE(windows_at_130, 17);
  EXPECT_GT(db_->Find(1)->velocity_noise, 0.003);
}

TEST_F(LifeCycleTest, ATransformationRebuildsTheNetworkFromTheNewBody) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.Transform(); });
  const LifeSummary s = Live(300);
  ASSERT_EQ(log_.Of("anomaly").size(), 1u);
  // Events are anomalies at once: detected at the end of the window they came
  // in, with the event's own time beside.
  EXPECT_EQ(Anomalies("module_disconnected"), 1);
  EXPECT_GE(log_.Of("anomaly")[0]->time, 60);
  EXPECT_LE(log_.Of("anomaly")[0]->time, 66);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("anomaly")[0], "event_time"), "60");
  ASSERT_EQ(log_.Of("assessed").size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("assessed")[0], "body_changed"), "true");
  ASSERT_EQ(relearner_.requests.size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("relearn")[0], "how"), JsonString("rebuilt"));
  // The problem's network has the new physical edge 0-2, not 1-2.
  const auto problem = optimizer::OptimizationConfig::Parse(relearner_.requests[0].problem_xml, "p");
  EXPECT_NE(problem.robot().FindCoupling(0, 2), nullptr);
  EXPECT_NE(problem.robot().FindCoupling(2, 0), nullptr);
  EXPECT_EQ(problem.robot().FindCoupling(1, 2), nullptr);
  EXPECT_LE(problem.optimized().size(), 7u);
  EXPECT_EQ(relearner_.requests[0].condition.morphology_xml, "<morphology transformed/>");
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].morphology_key, cpg::MorphologyKey(Chain(true)));
  EXPECT_NE(gaits[1].morphology_key, gaits[0].morphology_key);
  EXPECT_EQ(s.status.anomalies, 1);
}

// `yamor-lifelong --seed` is the life's one seed: a rebuilt network's budget
// rule draws from it as the optimizer does (it used to keep the budget rule
// at seed 1 whatever --seed said).
TEST_F(LifeCycleTest, TheLifeSeedSeedsTheBudgetRule) {
  int lives = 0;
  auto free_set_at = [&](std::uint64_t seed) {
    MemoryLog log;
    FakeRobot robot;
    FakeRelearner relearner{robot};
    GaitDatabase db((dir_ / ("life-" + std::to_string(++lives) + ".sqlite")).string());
    robot.schedule.emplace(60, [](FakeRobot& r) { r.Transform(); });
    LifeOptions o = Options(200);
    o.seed = seed;
    o.adaptation.seed = 1;  // ignored: the life's seed decides
    o.adaptation.max_free = 2;
    LifeCycle life(robot, relearner, db, log, o);
    life.Run({.config_xml = kChainConfig, .problem_xml = ChainProblem(), .source = "chain"});
    EXPECT_EQ(log.Of("relearn").size(), 1u);
    EXPECT_EQ(relearner.requests.size(), 1u);
    if (relearner.requests.empty()) return std::string();
    EXPECT_EQ(relearner.requests[0].seed, seed);
    return MemoryLog::Field(*log.Of("relearn")[0], "free");
  };
  std::set<std::string> seen;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) seen.insert(free_set_at(seed));
  EXPECT_GT(seen.size(), 1u) << "every seed fixed the same parameters: " << *seen.begin();
  EXPECT_EQ(free_set_at(5), free_set_at(5));
}

TEST_F(LifeCycleTest, TurnedOverTheAccelerometerTriggersAndTheGaitIsStoredUpsideDown) {
  robot_.schedule.emplace(90, [](FakeRobot& r) { r.world.upside_down = true; });
  const LifeSummary s = Live(300);
  EXPECT_EQ(Anomalies("orientation"), 1);
  EXPECT_EQ(s.status.anomalies, 1);
  ASSERT_EQ(relearner_.requests.size(), 1u);
  EXPECT_TRUE(relearner_.requests[0].condition.upside_down);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("relearn")[0], "how"), JsonString("same parameters"));
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].orientation, Orientation::kUpsideDown);
  EXPECT_EQ(gaits[1].morphology_key, gaits[0].morphology_key);
  EXPECT_TRUE(gaits[1].symptoms.has_acceleration);
  EXPECT_LT(gaits[1].symptoms.acceleration[2], 0);
}

// 7.5.2 off a table: the robot stalls at the edge (an anomaly while still
// upright) and falls over while it relearns. The gait that comes out is
// stored and watched as an upside-down gait, not as the upright one.
TEST_F(LifeCycleTest, TurnedOverWhileRelearningTheGaitIsStoredWithTheNewOrientation) {
  robot_.schedule.emplace(90, [](FakeRobot& r) { r.LimpMotor(1); });
  robot_.schedule.emplace(110, [](FakeRobot& r) { r.world.upside_down = true; });
  const LifeSummary s = Live(300);
  ASSERT_GE(relearner_.requests.size(), 1u);
  EXPECT_FALSE(relearner_.requests[0].condition.upside_down) << "assessed upright";
  const auto changed = log_.Of("orientation_changed");
  ASSERT_EQ(changed.size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*changed[0], "to"), JsonString("upside_down"));
  EXPECT_TRUE(log_.Of("orientation_not_watched").empty());
  const auto gaits = db_->All();
  ASSERT_GE(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].orientation, Orientation::kUpsideDown);
  // Walking on its back is this gait's normal orientation: no second anomaly for it.
  EXPECT_EQ(Anomalies("orientation"), 0);
  EXPECT_EQ(s.status.anomalies, 1);
}

// Without a flip the relearned gait keeps the assessed orientation.
TEST_F(LifeCycleTest, AnUprightRelearningLogsNoOrientationChange) {
  robot_.schedule.emplace(90, [](FakeRobot& r) { r.LimpMotor(1); });
  Live(300);
  EXPECT_TRUE(log_.Of("orientation_changed").empty());
  const auto gaits = db_->All();
  ASSERT_GE(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].orientation, Orientation::kUpright);
}

TEST_F(LifeCycleTest, AFlipThatDoesNotSlowTheRobotIsAnAnomalyAfterTwoWindows) {
  robot_.schedule.emplace(91, [](FakeRobot& r) { r.tilted = true; });
  Live(200);
  ASSERT_EQ(Anomalies("orientation"), 1);
  // Windows end at 92, 98, ...: seen at 92, confirmed at 98.
  EXPECT_DOUBLE_EQ(log_.Of("anomaly")[0]->time, 98);
}

TEST_F(LifeCycleTest, AGaitThatTurnsTheCentralModuleIsNotWatchedForOrientation) {
  robot_.rolling = true;
  const LifeSummary s = Live(600);
  EXPECT_EQ(s.status.anomalies, 0);
  ASSERT_EQ(log_.Of("orientation_not_watched").size(), 1u);
}

TEST_F(LifeCycleTest, TheTimeLimitEndsARelearningWithItsBestSoFar) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.world.slippery = true; });
  const LifeSummary s = Live(100);  // the relearning starts at about 70 s and would take 66 s
  EXPECT_EQ(s.reason, "time limit");
  EXPECT_LT(s.status.time, 110);
  ASSERT_EQ(log_.Of("relearned").size(), 1u);
  EXPECT_EQ(db_->All().size(), 2u);
}

TEST_F(LifeCycleTest, AModuleDefectRebuildsTheNetworkWithoutThatOscillator) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.KillModule(2); });
  Live(300);
  EXPECT_EQ(Anomalies("defect_set"), 1);
  ASSERT_EQ(relearner_.requests.size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("relearn")[0], "how"), JsonString("rebuilt"));
  const auto problem = optimizer::OptimizationConfig::Parse(relearner_.requests[0].problem_xml, "p");
  // Module 2 is passive: no oscillator, no coupling, nothing of it optimized.
  EXPECT_EQ(problem.robot().FindModule(2)->amplitude, 0);
  EXPECT_EQ(problem.robot().FindCoupling(1, 2), nullptr);
  for (const auto& rule : problem.optimized()) EXPECT_EQ(rule.param.find(".2"), std::string::npos) << rule.param;
  EXPECT_EQ(relearner_.requests[0].condition.module_defects, std::vector<int>{2});
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].symptoms.defects, std::vector<std::string>{"module 2"});
  EXPECT_NE(gaits[1].morphology_key, gaits[0].morphology_key);
}

TEST_F(LifeCycleTest, ALimpMotorKeepsTheNetworkAndRelearnsTheSameParameters) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.LimpMotor(1); });
  Live(300);
  EXPECT_EQ(Anomalies("defect_set"), 1);
  ASSERT_EQ(relearner_.requests.size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("assessed")[0], "body_changed"), "false");
  EXPECT_EQ(MemoryLog::Field(*log_.Of("relearn")[0], "how"), JsonString("same parameters"));
  ASSERT_EQ(relearner_.requests[0].condition.motor_defects.size(), 1u);
  EXPECT_EQ(relearner_.requests[0].condition.motor_defects[0], (std::pair<int, std::string>{1, "limp"}));
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].symptoms.defects, std::vector<std::string>{"motor 1 limp"});
  EXPECT_NEAR(MeanAmplitude(cpg::ParseConfigXml(gaits[1].config_xml)), 0.3, 1e-9);
}

TEST_F(LifeCycleTest, WithoutRulesAProblemIsGeneratedFromTheBody) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.world.slippery = true; });
  Live(200, /*problem=*/"");
  ASSERT_EQ(relearner_.requests.size(), 1u);
  EXPECT_EQ(MemoryLog::Field(*log_.Of("relearn")[0], "how"), JsonString("generated"));
  const auto problem = optimizer::OptimizationConfig::Parse(relearner_.requests[0].problem_xml, "p");
  EXPECT_GE(problem.optimized().size(), 1u);
  EXPECT_LE(problem.optimized().size(), 7u);
}

TEST_F(LifeCycleTest, AVelocityIncreaseIsLoggedNotRelearned) {
  // Amplitude 0.7 on slippery ground: 2.2 cm/s; on dry ground: 4.2 cm/s.
  std::string gait = kChainConfig;
  for (std::size_t at = gait.find("amplitude=\"0.5\""); at != std::string::npos;
       at = gait.find("amplitude=\"0.5\"")) {
    gait.replace(at, 15, "amplitude=\"0.7\"");
  }
  robot_.world.slippery = true;
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.world.slippery = false; });
  LifeCycle life(robot_, relearner_, *db_, log_, Options(300));
  const LifeSummary s = life.Run({.config_xml = gait, .problem_xml = "", .source = "slow"});
  EXPECT_EQ(s.status.anomalies, 0);
  EXPECT_TRUE(relearner_.requests.empty());
  ASSERT_EQ(log_.Of("velocity_increase").size(), 1u);  // then the faster level is expected
  EXPECT_NEAR(s.status.ema, 0.042, 1e-9);
}

TEST_F(LifeCycleTest, TheDaemonGoingAwayIsAGapNotAnEnd) {
  robot_.fail_measure_at = 5;
  const LifeSummary s = Live(200);
  EXPECT_EQ(s.reason, "time limit");
  EXPECT_EQ(robot_.reattaches, 1);
  EXPECT_EQ(s.status.gaps, 1);
  ASSERT_EQ(log_.Of("daemon_lost").size(), 1u);
  ASSERT_EQ(log_.Of("reattached").size(), 1u);
  EXPECT_EQ(s.status.anomalies, 0);
  bool gap_row = false;
  for (const auto& r : log_.rows) gap_row = gap_row || r.event == "daemon lost";
  EXPECT_TRUE(gap_row);
}

TEST_F(LifeCycleTest, AfterADaemonRestartLifeTimeGoesOn) {
  robot_.fail_measure_at = 5;
  robot_.restart_on_reattach = true;
  Live(200);
  EXPECT_EQ(robot_.reattaches, 1);
  double last = -1;
  for (const auto& r : log_.rows) {
    EXPECT_GE(r.time, last) << r.event;
    last = r.time;
  }
  EXPECT_GE(last, 200);
}

TEST_F(LifeCycleTest, ALossDuringRelearningResumesTheAdaptation) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.world.slippery = true; });
  relearner_.fail_first = static_cast<int>(StatusCode::kUnavailable);
  relearner_.failures_left = 1;
  const LifeSummary s = Live(400);
  EXPECT_EQ(robot_.reattaches, 1);
  EXPECT_EQ(s.status.anomalies, 1);
  EXPECT_EQ(log_.Of("anomaly").size(), 1u);
  EXPECT_EQ(relearner_.requests.size(), 2u);
  EXPECT_EQ(log_.Of("relearned").size(), 1u);
  EXPECT_EQ(db_->All().size(), 2u);
}

TEST_F(LifeCycleTest, AFailedRelearningWalksTheWarmStartAndStoresIt) {
  robot_.schedule.emplace(60, [](FakeRobot& r) { r.world.slippery = true; });
  relearner_.fail_first = static_cast<int>(StatusCode::kInternal);
  relearner_.failures_left = 1;
  LifeOptions o = Options(0);
  o.max_anomalies = 1;
  LifeCycle life(robot_, relearner_, *db_, log_, o);
  const LifeSummary s = life.Run({.config_xml = kChainConfig, .problem_xml = ChainProblem(), .source = "chain"});
  EXPECT_EQ(s.reason, "anomaly limit");
  ASSERT_EQ(log_.Of("relearn_failed").size(), 1u);
  const auto gaits = db_->All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].origin, "warm start (relearning failed)");
  EXPECT_EQ(s.status.gait, gaits[1].id);
}

TEST_F(LifeCycleTest, StopEndsTheLifeCleanly) {
  LifeCycle life(robot_, relearner_, *db_, log_, Options(0));
  log_.on_event = [&](const LifeEvent& e) {
    if (e.kind == "start") life.RequestStop();
  };
  const LifeSummary s = life.Run({.config_xml = kChainConfig, .problem_xml = ChainProblem(), .source = "chain"});
  EXPECT_EQ(s.reason, "stopped");
  EXPECT_EQ(s.status.state, "stopped");
  EXPECT_EQ(log_.Of("end").size(), 1u);
}

TEST_F(LifeCycleTest, BadOptionsAreRefused) {
  for (auto change : std::vector<std::function<void(LifeOptions&)>>{
           [](LifeOptions& o) { o.window_periods = 0; }, [](LifeOptions& o) { o.trial_periods = -1; },
           [](LifeOptions& o) { o.orientation_cos = 1; }, [](LifeOptions& o) { o.max_recall = -1; },
           [](LifeOptions& o) { o.adaptation.max_free = 0; }, [](LifeOptions& o) { o.anomaly.threshold = 0; },
           [](LifeOptions& o) { o.recall_noise_factor = -1; }, [](LifeOptions& o) { o.recall_floor = 1.5; },
           [](LifeOptions& o) { o.recall_max_windows = 0; }, [](LifeOptions& o) { o.recall_fail_factor = -0.1; },
           [](LifeOptions& o) { o.noise_write_windows = -1; }, [](LifeOptions& o) { o.recall_restart_floor = 1.2; },
           [](LifeOptions& o) { o.recall_noise_factor = std::nan(""); }}) {
    LifeOptions o;
    change(o);
    EXPECT_THROW(LifeCycle(robot_, relearner_, *db_, log_, o), Error);
  }
}

}  // namespace
}  // namespace yamor::lifelong
