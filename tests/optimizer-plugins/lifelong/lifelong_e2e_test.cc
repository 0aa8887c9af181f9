// End to end: yamor-lifelong against a real yamord, each scenario of
// configs/lifelong in short form (short windows, a few relearning trials,
// the change early): the anomaly is detected, the right adaptation chosen,
// the relearning runs and the database stores (and later recalls) the gait.
// Daemon restarts, SIGTERM and bad inputs too.
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "common/status.h"
#include "optimizer-plugins/lifelong/gait_database.h"
#include "physics/render/renderer.h"
#include "tests/support/yamord_process.h"
#include "yamor/v1/lifelong.grpc.pb.h"

namespace yamor::lifelong {
namespace {

namespace fs = std::filesystem;
using ::yamor::testing::YamordProcess;
using std::chrono::seconds;

const char* const kYamord = YAMORD_PATH;
const char* const kLifelong = YAMOR_LIFELONG_PATH;
const std::string kSource = YAMOR_SOURCE_DIR;

std::string Read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The raw JSON value of `key` in one events.jsonl line ("" when absent).
std::string Field(const std::string& line, const std::string& key) {
  const std::string tag = "\"" + key + "\":";
  const auto at = line.find(tag);
  if (at == std::string::npos) return "";
  std::size_t i = at + tag.size(), end = i;
  if (line[i] == '"') {
    for (end = i + 1; end < line.size() && line[end] != '"'; ++end) {
      if (line[end] == '\\') ++end;
    }
    return line.substr(i + 1, end - i - 1);
  }
  int depth = 0;
  for (; end < line.size(); ++end) {
    const char c = line[end];
    if (c == '[' || c == '{') ++depth;
    if ((c == ']' || c == '}') && depth-- == 0) break;
    if (c == ',' && depth == 0) break;
  }
  return line.substr(i, end - i);
}

class LifelongE2eTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lifelong_e2e_" + std::to_string(getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    StartDaemon(0);
  }
  void TearDown() override {
    daemon_.reset();
    if (!HasFailure()) fs::remove_all(dir_);
  }

  void StartDaemon(int port) {
    daemon_ = std::make_unique<YamordProcess>(
        kYamord, std::vector<std::string>{"--listen", "127.0.0.1:" + std::to_string(port), "--log-level", "warn",
                                          "--workers", "1"});
    port_ = daemon_->WaitForPort();
    ASSERT_GT(port_, 0) << "yamord did not start";
  }

  // A short scenario: `body` holds the world line and the changes.
  std::string Scenario(const std::string& name, const std::string& body) {
    const fs::path path = dir_ / (name + ".toml");
    std::ofstream(path) << "config = \"" << kSource << "/configs/lifelong/quadruped-walking.xml\"\nseed = 1\n"
                        << body;
    return path.string();
  }

  // The short-form command line: windows of two periods, two learning windows,
  // three relearning trials.
  std::vector<std::string> Args(const std::string& scenario, const std::string& out,
                                std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--host", "127.0.0.1:" + std::to_string(port_), "--scenario", scenario,
                                     "--out", out, "--window-periods", "2", "--learn-windows", "2", "--settle-periods", "0.5",
                                     "--trial-periods", "1.5", "--set", "max_evaluations=3", "--no-plot",
                                     "--quiet", "--log-level", "warn"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  // Runs yamor-lifelong to its end; returns its exit status.
  int Run(const std::vector<std::string>& args, std::string* stdout_text = nullptr) {
    YamordProcess life(kLifelong, args);
    const std::string text = life.ReadAll(seconds(50));
    if (stdout_text) *stdout_text = text;
    return life.WaitForExit(seconds(10));
  }

  std::vector<std::string> Events(const fs::path& out, const std::string& kind) {
    std::vector<std::string> lines;
    std::istringstream in(Read(out / "events.jsonl"));
    for (std::string line; std::getline(in, line);) {
      if (Field(line, "kind") == kind) lines.push_back(line);
    }
    return lines;
  }

  fs::path dir_;
  std::unique_ptr<YamordProcess> daemon_;
  int port_ = 0;
};

TEST_F(LifelongE2eTest, TransformationRebuildsTheNetworkAndStoresTheNewGait) {
  const std::string scenario = Scenario("transform", R"(world = "quadruped"
[[change]]
at = 12
do = "script"
file = ")" + kSource + R"(/configs/scripts/quadruped-transform.xml"
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "1"}), &text), 0) << text;
  EXPECT_NE(text.find("anomaly limit"), std::string::npos) << text;
  ASSERT_EQ(Events(out, "scenario_change").size(), 1u);
  const auto anomalies = Events(out, "anomaly");
  ASSERT_EQ(anomalies.size(), 1u);
  EXPECT_EQ(Field(anomalies[0], "trigger"), "module_disconnected") << anomalies[0];
  ASSERT_EQ(Events(out, "assessed").size(), 1u);
  EXPECT_EQ(Field(Events(out, "assessed")[0], "body_changed"), "true");
  ASSERT_EQ(Events(out, "relearn").size(), 1u);
  EXPECT_EQ(Field(Events(out, "relearn")[0], "how"), "rebuilt");
  ASSERT_EQ(Events(out, "relearned").size(), 1u) << Read(out / "events.jsonl");
  EXPECT_EQ(Field(Events(out, "relearned")[0], "trials"), "3");
  GaitDatabase db((out / "gaits.sqlite").string(), /*create=*/false);
  const auto gaits = db.All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_NE(gaits[0].morphology_key, gaits[1].morphology_key);
  EXPECT_EQ(gaits[1].predecessor, gaits[0].id);
  EXPECT_EQ(gaits[1].origin, "online");
  EXPECT_TRUE(fs::exists(out / "relearn-1" / "evaluations.csv"));
  // The timeline has walking windows before and the relearning trials.
  const std::string timeline = Read(out / "timeline.csv");
  EXPECT_NE(timeline.find(",walking,"), std::string::npos);
  EXPECT_NE(timeline.find(",relearning,"), std::string::npos);
  // Pictures of the key moments (issue 14), named in their events, when
  // this machine (the daemon's) has a renderer.
  bool renderer = true;
  try {
    yamor::render::Renderer probe;
  } catch (const yamor::Error&) {
    renderer = false;
  }
  if (renderer) {
    EXPECT_EQ(Field(anomalies[0], "frame"), "frames/anomaly-01.png") << anomalies[0];
    EXPECT_EQ(Field(Events(out, "relearned")[0], "frame"), "frames/relearned-01.png");
    for (const char* name : {"anomaly-01.png", "relearned-01.png"}) {
      EXPECT_EQ(Read(out / "frames" / name).substr(0, 4), "\x89PNG") << name;
    }
    EXPECT_NE(text.find("frames:"), std::string::npos) << text;
  } else {
    EXPECT_EQ(Field(anomalies[0], "frame"), "");
  }
}

TEST_F(LifelongE2eTest, UpsideDownIsSeenByTheAccelerometersAndRelearnedWithTheSameParameters) {
  const std::string scenario = Scenario("upside", R"(world = ")" + kSource + R"(/configs/lifelong/quadruped-extended.xml"
[[change]]
at = 25
do = "upside_down"
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "1"}), &text), 0) << text;
  const auto anomalies = Events(out, "anomaly");
  ASSERT_EQ(anomalies.size(), 1u) << Read(out / "events.jsonl");
  EXPECT_EQ(Field(anomalies[0], "trigger"), "orientation");
  EXPECT_EQ(Field(Events(out, "relearn")[0], "how"), "same parameters");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  const auto gaits = db.All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[0].orientation, Orientation::kUpright);
  EXPECT_EQ(gaits[1].orientation, Orientation::kUpsideDown);
  EXPECT_EQ(gaits[1].morphology_key, gaits[0].morphology_key);
}

// Thesis 7.5.2 as it was run: configs/lifelong/table.toml's world, the
// extended quadruped on a table (a static box), nothing scheduled. It walks
// to the edge, stalls with its legs over it (a velocity drop) or is already
// over it (its accelerometers see it on its back), relearns the same
// parameters, and the gait that comes out is an upside-down gait.
TEST_F(LifelongE2eTest, OffTheTableTheRobotLandsUpsideDownAndRelearns) {
  const std::string scenario = Scenario("table", R"(world = ")" + kSource +
                                                     R"(/configs/lifelong/quadruped-extended-table.xml"
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "1", "--max-time", "200"}), &text), 0) << text;
  const std::string events = Read(out / "events.jsonl");
  EXPECT_TRUE(Events(out, "scenario_change").empty());
  const auto anomalies = Events(out, "anomaly");
  ASSERT_EQ(anomalies.size(), 1u) << events;
  const std::string trigger = Field(anomalies[0], "trigger");
  EXPECT_TRUE(trigger == "velocity_drop" || trigger == "orientation") << anomalies[0];
  EXPECT_GT(std::stod(Field(anomalies[0], "time")), 20.0) << "it walked on the table first";
  ASSERT_EQ(Events(out, "assessed").size(), 1u);
  EXPECT_EQ(Field(Events(out, "assessed")[0], "body_changed"), "false");
  EXPECT_EQ(Field(Events(out, "relearn")[0], "how"), "same parameters");
  ASSERT_EQ(Events(out, "relearned").size(), 1u) << events;
  // Seen on its back at the anomaly, or turned over while relearning.
  if (trigger != "orientation") {
    ASSERT_EQ(Events(out, "orientation_changed").size(), 1u) << events;
    EXPECT_EQ(Field(Events(out, "orientation_changed")[0], "to"), "upside_down");
  }
  EXPECT_TRUE(Events(out, "orientation_not_watched").empty()) << events;
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  const auto gaits = db.All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[0].orientation, Orientation::kUpright);
  EXPECT_EQ(gaits[1].orientation, Orientation::kUpsideDown);
  EXPECT_EQ(gaits[1].morphology_key, gaits[0].morphology_key);
  EXPECT_NE(Read(out / "timeline.csv").find(",walking,"), std::string::npos);
}

TEST_F(LifelongE2eTest, ALimpMotorIsAnEventAndKeepsTheNetwork) {
  const std::string scenario = Scenario("limp", R"(world = "quadruped"
[[change]]
at = 12
do = "motor_defect"
module = 5
defect = "limp"
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "1", "--no-frames"}), &text), 0) << text;
  const auto anomalies = Events(out, "anomaly");
  ASSERT_EQ(anomalies.size(), 1u);
  EXPECT_EQ(Field(anomalies[0], "trigger"), "defect_set");
  EXPECT_EQ(Field(anomalies[0], "frame"), "") << "--no-frames";
  EXPECT_FALSE(fs::exists(out / "frames"));
  EXPECT_EQ(Field(Events(out, "assessed")[0], "body_changed"), "false");
  EXPECT_EQ(Field(Events(out, "relearn")[0], "how"), "same parameters");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  const auto gaits = db.All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[1].symptoms.defects, std::vector<std::string>{"motor 5 limp"});
}

TEST_F(LifelongE2eTest, ModelModeEvaluatesTheFaultyBodyInSimulationAndVerifiesOnTheRobot) {
  const std::string scenario = Scenario("model", R"(world = "quadruped"
[[change]]
at = 12
do = "motor_defect"
module = 5
defect = "limp"
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out,
                     {"--max-anomalies", "1", "--mode", "model", "--model-warmup", "1", "--model-duration", "2",
                      "--verify", "2", "--set", "max_evaluations=4"}),
                &text),
            0)
      << text;
  ASSERT_EQ(Events(out, "relearned").size(), 1u) << Read(out / "events.jsonl");
  const std::string relearned = Events(out, "relearned")[0];
  EXPECT_EQ(Field(relearned, "evaluations"), "4");
  EXPECT_EQ(Field(relearned, "trials"), "2");  // only the verifications are robot time
  EXPECT_EQ(Field(Events(out, "relearn")[0], "mode"), "model");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  ASSERT_EQ(db.All().size(), 2u);
  EXPECT_EQ(db.All()[1].origin, "model");
  // The simulated evaluations are in the relearning's results; the timeline
  // has the verifications only.
  const std::string evaluations = Read(out / "relearn-1" / "evaluations.csv");
  EXPECT_EQ(std::count(evaluations.begin(), evaluations.end(), '\n'), 5);  // header + 4
  const std::string timeline = Read(out / "timeline.csv");
  std::size_t verifications = 0;
  for (auto at = timeline.find(",relearning,verify,"); at != std::string::npos;
       at = timeline.find(",relearning,verify,", at + 1)) {
    ++verifications;
  }
  EXPECT_EQ(verifications, 2u) << timeline;
}

TEST_F(LifelongE2eTest, AModuleDefectRebuildsTheNetworkWithoutIt) {
  const std::string scenario = Scenario("dead", R"(world = "quadruped"
[[change]]
at = 12
do = "module_defect"
module = 5
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "1"}), &text), 0) << text;
  EXPECT_EQ(Field(Events(out, "anomaly")[0], "trigger"), "defect_set");
  EXPECT_EQ(Field(Events(out, "relearn")[0], "how"), "rebuilt");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  const auto gaits = db.All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_NE(gaits[1].morphology_key, gaits[0].morphology_key);
  EXPECT_EQ(gaits[1].config_xml.find("<cpglink to=\"5\""), std::string::npos) << "no coupling to the dead module";
}

TEST_F(LifelongE2eTest, AnInsertedModuleGetsAnOscillatorInTheRebuiltNetwork) {
  const std::string scenario = Scenario("insert", R"(world = ")" + kSource + R"(/configs/lifelong/quadruped-spare.xml"
[[change]]
at = 12
do = "connect"
module = 9
to = 5
)");
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "1"}), &text), 0) << text;
  EXPECT_EQ(Field(Events(out, "anomaly")[0], "trigger"), "module_connected");
  EXPECT_EQ(Field(Events(out, "relearn")[0], "how"), "rebuilt");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  const auto gaits = db.All();
  ASSERT_EQ(gaits.size(), 2u);
  EXPECT_EQ(gaits[0].config_xml.find("realid=\"9\""), std::string::npos);
  // Module 9 is configured, driven and coupled to knee 5.
  EXPECT_NE(gaits[1].config_xml.find("<module realid=\"9\" amplitude=\""), std::string::npos) << gaits[1].config_xml;
  EXPECT_EQ(gaits[1].config_xml.find("<module realid=\"9\" amplitude=\"0\""), std::string::npos) << gaits[1].config_xml;
  EXPECT_NE(gaits[1].config_xml.find("<cpglink to=\"9\""), std::string::npos);
  // The daemon now drives module 9; a second life on the same daemon opens
  // the scenario's world, where module 9 lies free, with its own starting
  // gait (the daemon's configuration would name a free module: refused).
  const fs::path again = dir_ / "again";
  ASSERT_EQ(Run(Args(scenario, again, {"--max-anomalies", "1"}), &text), 0) << text;
  EXPECT_EQ(Field(Events(again, "anomaly")[0], "trigger"), "module_connected");
}

TEST_F(LifelongE2eTest, BackOnTheOldGroundTheOldGaitIsRecalledNotRelearned) {
  // Sticky ground: relearned. Back on the normal ground the sticky-ground gait
  // is much faster (relearn-on-increase makes that an anomaly) and the old
  // gait comes back from the database without optimizing.
  const std::string scenario = Scenario("sticky", R"(world = "quadruped"
[[change]]
at = 25
do = "ground"
friction = 3.0
[[change]]
at = 95
do = "ground"
friction = 0.6
)");
  const fs::path out = dir_ / "life1";
  const std::string db = (dir_ / "gaits.sqlite").string();
  std::string text;
  ASSERT_EQ(Run(Args(scenario, out, {"--max-anomalies", "2", "--db", db, "--relearn-on-increase"}), &text), 0)
      << text;
  const auto anomalies = Events(out, "anomaly");
  ASSERT_EQ(anomalies.size(), 2u) << Read(out / "events.jsonl");
  EXPECT_EQ(Field(anomalies[0], "trigger"), "velocity_drop");
  EXPECT_EQ(Field(anomalies[1], "trigger"), "velocity_increase");
  ASSERT_EQ(Events(out, "relearned").size(), 1u);
  ASSERT_EQ(Events(out, "recalled").size(), 1u) << Read(out / "events.jsonl");
  EXPECT_EQ(Field(Events(out, "recalled")[0], "gait"), "1");
  EXPECT_EQ(Events(out, "relearn").size(), 1u);  // the second anomaly needed no optimization
  {
    GaitDatabase gaits(db, false);
    ASSERT_EQ(gaits.All().size(), 2u);
    EXPECT_EQ(gaits.All()[0].use_count, 2);  // started with, then recalled
    EXPECT_EQ(gaits.Switches(2, 1), 1);
  }
  // The database outlives the run: a new life knows its gait.
  const fs::path out2 = dir_ / "life2";
  ASSERT_EQ(Run(Args(scenario, out2, {"--max-time", "10", "--db", db}), &text), 0) << text;
  EXPECT_EQ(Field(Events(out2, "start")[0], "known"), "true");
}

TEST_F(LifelongE2eTest, TheDaemonGoingAwayIsAGapInTheTimeline) {
  const std::string scenario = Scenario("gap", "world = \"quadruped\"\n");
  const fs::path out = dir_ / "out";
  const int port = port_;
  YamordProcess life(kLifelong, Args(scenario, out, {"--max-time", "60"}));
  // Wait until it walks, then kill the daemon and start another on the same port.
  for (int i = 0; i < 300 && Events(out, "start").empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(Events(out, "start").size(), 1u);
  daemon_->Kill();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  StartDaemon(port);
  const std::string text = life.ReadAll(seconds(50));
  ASSERT_EQ(life.WaitForExit(seconds(10)), 0) << text;
  ASSERT_EQ(Events(out, "daemon_lost").size(), 1u) << Read(out / "events.jsonl");
  const auto back = Events(out, "reattached");
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(Field(back[0], "restarted"), "true");
  EXPECT_NE(Read(out / "timeline.csv").find("daemon lost"), std::string::npos);
  EXPECT_EQ(Field(Events(out, "end")[0], "reason"), "time limit");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  EXPECT_EQ(db.All().size(), 1u);
}

TEST_F(LifelongE2eTest, SigtermEndsTheLifeCleanly) {
  const std::string scenario = Scenario("term", "world = \"quadruped\"\n");
  const fs::path out = dir_ / "out";
  YamordProcess life(kLifelong, Args(scenario, out));
  for (int i = 0; i < 300 && Events(out, "start").empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_EQ(Events(out, "start").size(), 1u);
  life.Signal(SIGTERM);
  const std::string text = life.ReadAll(seconds(20));
  EXPECT_EQ(life.WaitForExit(seconds(10)), 130) << text;
  ASSERT_EQ(Events(out, "end").size(), 1u);
  EXPECT_EQ(Field(Events(out, "end")[0], "reason"), "stopped");
  GaitDatabase db((out / "gaits.sqlite").string(), false);
  EXPECT_EQ(db.All().size(), 1u);
}

// Issue 13 §2: `--listen` serves the yamor.v1.Lifelong status service: the
// status (state, velocity, threshold, anomalies, relearning progress, gait)
// and the event stream, the same events as events.jsonl.
TEST_F(LifelongE2eTest, ListenServesTheStatusAndTheEventStream) {
  const std::string scenario = Scenario("listen", R"(world = "quadruped"
[[change]]
at = 12
do = "motor_defect"
module = 5
defect = "limp"
)");
  const fs::path out = dir_ / "out";
  YamordProcess life(kLifelong, Args(scenario, out, {"--max-anomalies", "1", "--listen", "127.0.0.1:0"}));
  const std::string prefix = "yamor-lifelong: status on 127.0.0.1:";
  int port = 0;
  for (int i = 0; i < 20 && port == 0; ++i) {
    bool ended = false;
    const std::string line = life.ReadLine(seconds(30), &ended);
    if (line.rfind(prefix, 0) == 0) port = std::stoi(line.substr(prefix.size()));
    if (ended) break;
  }
  ASSERT_GT(port, 0) << "no status line";
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  auto stub = v1::Lifelong::NewStub(channel);

  // The stream from the start (replay), collected while the life goes on.
  std::vector<v1::LifeUpdate> updates;
  grpc::Status stream_status;
  grpc::ClientContext stream_context;
  stream_context.set_deadline(std::chrono::system_clock::now() + seconds(60));
  std::thread watcher([&] {
    v1::WatchLifeRequest request;
    request.set_replay(true);
    auto reader = stub->WatchLife(&stream_context, request);
    for (v1::LifeUpdate update; reader->Read(&update);) updates.push_back(update);
    stream_status = reader->Finish();
  });

  // Polled status: walking with a measured velocity and a threshold.
  bool walking_seen = false;
  for (int i = 0; i < 300 && !walking_seen; ++i) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + seconds(5));
    v1::LifeStatus status;
    const grpc::Status s = stub->GetLifeStatus(&context, google::protobuf::Empty(), &status);
    if (!s.ok()) break;  // the life ended already
    EXPECT_EQ(status.mode(), "online");
    EXPECT_EQ(status.robot(), "127.0.0.1:" + std::to_string(port_));
    EXPECT_EQ(status.relearn_budget(), 3u);
    if (status.state() == "walking" && status.velocity() > 0 && status.threshold() > 0) {
      walking_seen = true;
      EXPECT_GT(status.gait(), 0);
      EXPECT_GT(status.time(), 0);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(walking_seen);

  const std::string text = life.ReadAll(seconds(60));
  EXPECT_EQ(life.WaitForExit(seconds(10)), 0) << text;
  watcher.join();
  EXPECT_TRUE(stream_status.ok()) << stream_status.error_message();

  // The stream is events.jsonl, line for line, in order.
  std::vector<std::string> lines;
  std::istringstream in(Read(out / "events.jsonl"));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_EQ(updates.size(), lines.size());
  for (std::size_t i = 0; i < updates.size(); ++i) {
    EXPECT_EQ(updates[i].index(), i);
    EXPECT_EQ(updates[i].json(), lines[i]);
    EXPECT_EQ(updates[i].kind(), Field(lines[i], "kind"));
  }
  ASSERT_GE(updates.size(), 4u);
  EXPECT_EQ(updates.front().kind(), "start");
  EXPECT_EQ(updates.back().kind(), "end");
  bool anomaly = false, relearned = false;
  for (const v1::LifeUpdate& u : updates) {
    if (u.kind() == "anomaly") {
      anomaly = true;
      EXPECT_EQ(u.status().state(), "anomaly");
      EXPECT_EQ(u.status().anomalies(), 1u);
    }
    if (u.kind() == "relearned") {
      relearned = true;
      EXPECT_EQ(u.status().state(), "relearning");
      EXPECT_EQ(u.status().relearn_trials(), 3u);  // the relearning's progress: 3 of 3
      EXPECT_EQ(u.status().relearn_budget(), 3u);
    }
  }
  EXPECT_TRUE(anomaly);
  EXPECT_TRUE(relearned);
  // The service is gone with the life.
  grpc::ClientContext after;
  after.set_deadline(std::chrono::system_clock::now() + seconds(2));
  v1::LifeStatus gone;
  EXPECT_FALSE(stub->GetLifeStatus(&after, google::protobuf::Empty(), &gone).ok());
}

TEST_F(LifelongE2eTest, ListenOnABadAddressIsAClearError) {
  const std::string scenario = Scenario("badlisten", "world = \"quadruped\"\n");
  std::string text;
  for (const std::string bad : {"no-port-here", "127.0.0.1:99999", "127.0.0.1:", ":80", "127.0.0.1:http"}) {
    EXPECT_EQ(Run(Args(scenario, (dir_ / "out").string(), {"--listen", bad}), &text), 2) << bad << ": " << text;
  }
}

TEST_F(LifelongE2eTest, ADamagedDatabaseOrAMissingGaitIsAClearError) {
  const std::string scenario = Scenario("bad", "world = \"quadruped\"\n");
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  std::ofstream(out / "gaits.sqlite") << "not a database, a text file of some length ............................"
                                         "........................................................................";
  std::string text;
  EXPECT_EQ(Run(Args(scenario, out), &text), 1);
  const std::string missing = (dir_ / "none.xml").string();
  EXPECT_EQ(Run({"--host", "127.0.0.1:" + std::to_string(port_), "--config", missing, "--out", (dir_ / "o2").string()},
                &text),
            2);
}

// No false alarm: the robots of configs/ walk their configured gaits
// undisturbed with the default threshold and three-period windows (the short
// version of the 30-minute check in tools/bench/lifelong_bench.py). The dog
// and the wheel measure very unevenly (three-period windows from 0 to 7.5 and
// 1 to 23 cm/s): the noise floor of the threshold keeps them quiet.
class NoFalseAlarmTest : public LifelongE2eTest, public ::testing::WithParamInterface<const char*> {};

TEST_P(NoFalseAlarmTest, UndisturbedWalkingRaisesNoAnomaly) {
  const std::string robot = GetParam();
  const fs::path scenario = dir_ / "walk.toml";
  std::ofstream(scenario) << "world = \"" << robot << "\"\nconfig = \"" << kSource << "/configs/robots/" << robot
                          << ".xml\"\nseed = 1\n";
  const fs::path out = dir_ / "out";
  std::string text;
  ASSERT_EQ(Run({"--host", "127.0.0.1:" + std::to_string(port_), "--scenario", scenario.string(), "--out",
                 out.string(), "--max-time", "120", "--no-plot", "--quiet", "--log-level", "warn"},
                &text),
            0)
      << text;
  EXPECT_TRUE(Events(out, "anomaly").empty()) << Read(out / "timeline.csv");
  EXPECT_EQ(Field(Events(out, "end")[0], "reason"), "time limit");
}

INSTANTIATE_TEST_SUITE_P(Robots, NoFalseAlarmTest,
                         ::testing::Values("quadruped", "snake", "tripod", "dog", "trebuchet", "wheel"));

}  // namespace
}  // namespace yamor::lifelong
