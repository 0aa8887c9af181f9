// RobotDriver over a scripted backend: the exact SNP frames it sends.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "common/status.h"
#include "host/driver.h"
#include "tests/support/code_of.h"
#include "tests/host/fake_backend.h"
#include "tests/host/test_util.h"

namespace yamor::host {
namespace {

using snp::Tristate;
using testing::FakeBackend;
using testing::QuadrupedConfig;
using testing::SmallConfig;
using testing::ToBridge;
using testing::ToModule;

using ::yamor::testing::CodeOf;

class DriverFakeTest : public ::testing::Test {
 protected:
  FakeBackend* Attach(bool simulation, DriverOptions options = {},
                      cpg::RobotConfig config = SmallConfig()) {
    driver_.reset();  // a tracker takes one driver's handler at a time
    driver_ = std::make_unique<RobotDriver>(std::move(options), std::move(config));
    auto fake = std::make_unique<FakeBackend>(simulation);
    FakeBackend* raw = fake.get();
    driver_->AttachBackend(std::move(fake), "fake");
    raw->sent.clear();  // what the simulation is (GetSimInfo, ReadMorphology) is asked at attach
    return raw;
  }
  // Connects (links only) and forgets the frames that took.
  void Connect(FakeBackend* fake) {
    driver_->ConnectRobot(0.0, /*links_only=*/true, nullptr);
    fake->sent.clear();
  }
  static DriverOptions Mapped(std::map<int, int> map) {
    DriverOptions options;
    options.id_map = IdMap(std::move(map));
    return options;
  }

  std::unique_ptr<RobotDriver> driver_;
};

TEST_F(DriverFakeTest, SetAmplitudeIsQueuedUntilFlushThenOneSetOscillatorToTheMappedId) {
  FakeBackend* fake = Attach(/*simulation=*/true, Mapped({{1, 11}, {3, 13}}));
  Connect(fake);
  driver_->SetModuleValue(1, ModuleField::kAmplitude, 0.75);
  EXPECT_TRUE(fake->sent.empty()) << "sent before Flush";
  EXPECT_EQ(driver_->PendingChanges(), 1);
  EXPECT_DOUBLE_EQ(driver_->GetModuleValue(1, ModuleField::kAmplitude), 0.75);
  EXPECT_EQ(driver_->Flush(), 1);
  const std::vector<snp::Frame> expected = {ToModule(11, snp::SetOscillator{.amplitude = 0.75f})};
  EXPECT_EQ(fake->sent, expected);
  EXPECT_EQ(driver_->PendingChanges(), 0);
  fake->sent.clear();
  EXPECT_EQ(driver_->Flush(), 0);
  EXPECT_TRUE(fake->sent.empty());
}

TEST_F(DriverFakeTest, QueuedChangesOfAModuleShareFramesInModuleOrder) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  driver_->SetModuleValue(2, ModuleField::kSpeed, 0.8);
  driver_->SetModuleValue(1, ModuleField::kAmplitude, 0.6);
  driver_->SetModuleValue(1, ModuleField::kSpeed, 0.7);
  driver_->SetModuleValue(1, ModuleField::kMinAngle, -0.9);
  driver_->SetCouplingValue(1, 2, CouplingField::kPhase, 1.25);
  EXPECT_EQ(driver_->Flush(), 4);
  const std::vector<snp::Frame> expected = {
      ToModule(1, snp::SetOscillator{.amplitude = 0.6f, .speed = 0.7f}),
      ToModule(1, snp::SetLimits{.min_angle = -0.9f, .max_angle = 1.0f}),
      ToModule(1, snp::SetCoupling{.to = 2, .phase = 1.25f, .weight = 1.0f}),
      ToModule(2, snp::SetOscillator{.speed = 0.8f}),
  };
  EXPECT_EQ(fake->sent, expected);
}

TEST_F(DriverFakeTest, RefreshResendsEveryParameterAndCoupling) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  driver_->SetModuleValue(3, ModuleField::kOffset, 0.2);
  const int frames = driver_->Refresh();
  std::vector<snp::Frame> expected;
  const cpg::RobotConfig config = driver_->Config();
  for (const cpg::ModuleParams& m : config.modules) {
    expected.push_back(ToModule(m.id, snp::SetOscillator{.amplitude = float(m.amplitude),
                                                         .offset = float(m.offset),
                                                         .speed = float(m.speed)}));
    expected.push_back(ToModule(m.id, snp::SetLimits{.min_angle = float(m.min_angle),
                                                     .max_angle = float(m.max_angle)}));
    expected.push_back(ToModule(m.id, snp::ClearCouplings{}));
    for (const cpg::Coupling& c : config.couplings) {
      if (c.from != m.id) continue;
      expected.push_back(ToModule(m.id, snp::SetCoupling{.to = uint8_t(c.to),
                                                         .phase = float(c.phase),
                                                         .weight = float(c.weight)}));
    }
  }
  EXPECT_EQ(fake->sent, expected);
  EXPECT_EQ(frames, static_cast<int>(expected.size()));
  EXPECT_EQ(expected.size(), 4u * 3u + 2u);
  EXPECT_EQ(driver_->PendingChanges(), 0) << "Refresh sends the queue too";
  EXPECT_FLOAT_EQ(std::get<snp::SetOscillator>(snp::DecodeMessage(fake->sent[11])).offset.value(),
                  0.2f);
}

TEST_F(DriverFakeTest, RemoveAllCouplingsThenAddSendsClearBeforeTheNewCoupling) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  driver_->RemoveAllCouplings();
  driver_->AddCoupling(2, 3, 0.5, 1.5);
  EXPECT_EQ(CodeOf([&] { driver_->GetCouplingValue(1, 2, CouplingField::kPhase); }),
            StatusCode::kNotFound);
  driver_->Flush();
  const std::vector<snp::Frame> expected = {
      ToModule(0, snp::ClearCouplings{}),
      ToModule(1, snp::ClearCouplings{}),
      ToModule(2, snp::ClearCouplings{}),
      ToModule(2, snp::SetCoupling{.to = 3, .phase = 0.5f, .weight = 1.5f}),
      ToModule(3, snp::ClearCouplings{}),
  };
  EXPECT_EQ(fake->sent, expected);
}

TEST_F(DriverFakeTest, ConnectRobotLinksTheTreeInOrderThenSendsTheConfiguration) {
  FakeBackend* fake = Attach(true, {}, QuadrupedConfig());
  const ConnectResult result = driver_->ConnectRobot(0.0, /*links_only=*/false, nullptr);
  std::vector<snp::Frame> links(fake->sent.begin(), fake->sent.begin() + 9);
  const std::vector<snp::Frame> expected = {
      ToBridge(snp::SetMasterNode{.module = 4}),
      ToModule(4, snp::ConnectRequest{.child = 0}), ToModule(4, snp::ConnectRequest{.child = 1}),
      ToModule(4, snp::ConnectRequest{.child = 2}), ToModule(4, snp::ConnectRequest{.child = 3}),
      ToModule(0, snp::ConnectRequest{.child = 5}), ToModule(1, snp::ConnectRequest{.child = 6}),
      ToModule(2, snp::ConnectRequest{.child = 7}), ToModule(3, snp::ConnectRequest{.child = 8}),
  };
  EXPECT_EQ(links, expected);
  EXPECT_EQ(result.links, 8);
  // 9 modules x (oscillator, limits, clear) + 16 couplings after the links.
  EXPECT_EQ(result.frames_sent, 9 + 27 + 16);
  EXPECT_EQ(fake->sent.size(), 9u + 27u + 16u);
  EXPECT_TRUE(driver_->Info().connected);
}

TEST_F(DriverFakeTest, ConnectRobotNamesTheLinkThatTimedOutAndStopsThere) {
  FakeBackend* fake = Attach(true, {}, QuadrupedConfig());
  fake->silent_links.insert({2, 7});
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->ConnectRobot(0.0, false, nullptr); }, &message),
            StatusCode::kUnavailable);
  EXPECT_NE(message.find("link 2 -> 7 timed out after 2 s"), std::string::npos) << message;
  EXPECT_NE(message.find("6 of 8 links up"), std::string::npos) << message;
  EXPECT_EQ(fake->sent.back(), ToModule(2, snp::ConnectRequest{.child = 7}))
      << "nothing is sent after the failed link";
  EXPECT_FALSE(driver_->Info().connected);
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }), StatusCode::kFailedPrecondition);

  EXPECT_EQ(CodeOf([&] { driver_->ConnectRobot(0.5, false, nullptr); }, &message),
            StatusCode::kUnavailable);
  EXPECT_NE(message.find("link 2 -> 7 timed out after 0.5 s"), std::string::npos) << message;

  fake->silent_links.clear();
  fake->failed_links.insert({1, 6});
  EXPECT_EQ(CodeOf([&] { driver_->ConnectRobot(0.0, false, nullptr); }, &message),
            StatusCode::kUnavailable);
  EXPECT_NE(message.find("link 1 -> 6 failed"), std::string::npos) << message;

  fake->failed_links.clear();
  EXPECT_EQ(CodeOf([&] { driver_->ConnectRobot(0.0, false, nullptr); }), StatusCode::kOk);
}

TEST_F(DriverFakeTest, ConnectRobotRetriesALinkThatMissesAndNamesTheAttempts) {
  FakeBackend* fake = Attach(true, {}, QuadrupedConfig());
  fake->flaky_links[{2, 7}] = 2;  // two misses: the third and last attempt works
  const ConnectResult result = driver_->ConnectRobot(0.0, /*links_only=*/true, nullptr);
  EXPECT_EQ(result.links, 8);
  int requests = 0;
  for (const snp::Frame& f : fake->sent) {
    if (f == ToModule(2, snp::ConnectRequest{.child = 7})) ++requests;
  }
  EXPECT_EQ(requests, 3);
  EXPECT_TRUE(driver_->Info().connected);

  fake->sent.clear();
  fake->flaky_links[{2, 7}] = 3;  // one miss more than the retries allow
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->ConnectRobot(0.0, true, nullptr); }, &message),
            StatusCode::kUnavailable);
  EXPECT_NE(message.find("link 2 -> 7 timed out after 2 s (3 attempts)"), std::string::npos)
      << message;
  requests = 0;
  for (const snp::Frame& f : fake->sent) {
    if (f == ToModule(2, snp::ConnectRequest{.child = 7})) ++requests;
  }
  EXPECT_EQ(requests, 3) << "bounded: 1 + link_retries requests, then give up";
}

TEST_F(DriverFakeTest, AReopenedLinkFailsTheCallAndRefreshRelinksAndRestoresTheRobot) {
  FakeBackend* fake = Attach(true, {}, QuadrupedConfig());
  driver_->ConnectRobot(0.0, false, nullptr);
  driver_->SendControlMessage(ControlMessage{.cpg = snp::Tristate::kOn,
                                             .motors = snp::Tristate::kOn, .all = true});
  std::map<int, snp::Control> switched;  // what the control message sent, per module
  for (const snp::Frame& f : fake->sent) {
    const snp::Message m = snp::DecodeMessage(f);
    if (const auto* c = std::get_if<snp::Control>(&m)) switched[f.destination.id] = *c;
  }
  driver_->SetMotorDefect(3, MotorDefect::kStuck);
  const size_t before = fake->sent.size();

  fake->generation = 2;  // the peer went away and the backend reopened the link
  driver_->SetModuleValue(0, ModuleField::kAmplitude, 0.3);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }, &message), StatusCode::kUnavailable);
  EXPECT_NE(message.find("lost and reopened"), std::string::npos) << message;
  EXPECT_NE(message.find("Refresh"), std::string::npos) << message;
  EXPECT_FALSE(driver_->Info().connected);
  EXPECT_EQ(fake->sent.size(), before + 1) << "nothing more after the frame that found the loss";
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }), StatusCode::kFailedPrecondition)
      << "not linked any more until Refresh";

  fake->sent.clear();
  const int frames = driver_->Refresh();
  EXPECT_TRUE(driver_->Info().connected);
  const std::vector<snp::Message> sent = fake->SentMessages();
  EXPECT_EQ(frames, static_cast<int>(sent.size()));
  int links = 0, controls = 0, faults = 0;
  for (size_t i = 0; i < sent.size(); ++i) {
    if (std::holds_alternative<snp::ConnectRequest>(sent[i])) ++links;
    if (const auto* c = std::get_if<snp::Control>(&sent[i])) {
      ++controls;
      const int id = fake->sent[i].destination.id;
      snp::Control expected = switched.at(id);
      // Module 3's motor is defect since: its motor-on is not restored.
      if (id == 3) expected.motors = snp::Tristate::kUnchanged;
      EXPECT_EQ(*c, expected) << "module " << id;
    }
    if (std::holds_alternative<snp::SetMotorFault>(sent[i])) ++faults;
  }
  EXPECT_EQ(links, 8);
  EXPECT_EQ(controls, 9);
  EXPECT_EQ(faults, 1);
  EXPECT_EQ(driver_->GetModuleValue(0, ModuleField::kAmplitude), 0.3)
      << "the configuration survives the loss";
  EXPECT_EQ(driver_->PendingChanges(), 0) << "Refresh sent everything";
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }), StatusCode::kOk);
}

TEST_F(DriverFakeTest, FreeRunSurvivesAnyExceptionStopsAndSaysWhy) {
  for (const bool yamor_error : {true, false}) {
    FakeBackend* fake = Attach(true, {}, QuadrupedConfig());
    WatchCursor cursor = driver_->BeginWatch();
    fake->on_send = [yamor_error](const snp::Frame& f) {
      if (f.type != snp::MessageType::kStep) return;
      if (yamor_error) throw Error(StatusCode::kUnavailable, "the link went away");
      throw std::runtime_error("something unexpected");
    };
    driver_->SetFreeRun(1.0);
    bool stopped = false;
    std::string detail;
    for (int i = 0; i < 200 && !stopped; ++i) {
      if (auto update = driver_->WaitForState(cursor, 0.0, std::chrono::milliseconds(50))) {
        for (const StateEvent& e : update->events) {
          if (e.kind == "free_run_stopped") {
            stopped = true;
            detail = e.detail;
          }
        }
      }
    }
    driver_->EndWatch();
    EXPECT_TRUE(stopped) << "a free_run_stopped event";
    EXPECT_NE(detail.find(yamor_error ? "the link went away" : "something unexpected"),
              std::string::npos)
        << detail;
    EXPECT_EQ(driver_->Info().free_run_factor, 0.0);
    fake->on_send = nullptr;
    EXPECT_EQ(CodeOf([&] { driver_->Sleep(0.1, false, nullptr); }), StatusCode::kOk)
        << "the driver keeps serving";
  }
}

// A PositionTracker stand-in: a fixed position, "lost" on demand; records
// the window each CapturedBetween asked for; Emit plays a sample arriving.
class FakeTracker final : public PositionTracker {
 public:
  const std::string& name() const override { return name_; }
  TrackedPose Latest() const override {
    if (lost) throw Error(StatusCode::kUnavailable, name_ + ": sample 9 is 2 s old");
    return pose;
  }
  TrackedPose CapturedBetween(double earliest, const std::function<double()>& latest) const override {
    asked_earliest = earliest;
    asked_latest = latest();
    if (lost) throw Error(StatusCode::kUnavailable, name_ + ": no frame with the LED");
    TrackedPose p = pose;
    p.camera_time = earliest;
    return p;
  }
  void SetHandler(std::function<void(const TrackedPose&)> handler) override {
    std::lock_guard lock(mutex_);
    handler_ = std::move(handler);
  }
  // Calls the handler as the tracker's thread would; false when none is set.
  bool Emit(const TrackedPose& p) {
    std::lock_guard lock(mutex_);
    if (!handler_) return false;
    handler_(p);
    return true;
  }

  TrackedPose pose{.position = {0.25, -0.5, 0.06}, .camera_time = 3.0,
                   .arrival = std::chrono::steady_clock::now()};
  bool lost = false;
  mutable double asked_earliest = -1;
  mutable double asked_latest = -1;

 private:
  const std::string name_ = "led-tracker 127.0.0.1:2225";
  std::mutex mutex_;
  std::function<void(const TrackedPose&)> handler_;
};

TEST_F(DriverFakeTest, ARealRobotsPositionComesFromTheTrackerNeverStale) {
  std::string message;
  Attach(/*simulation=*/false);
  EXPECT_EQ(CodeOf([&] { driver_->RobotPosition(); }, &message), StatusCode::kUnimplemented);
  EXPECT_NE(message.find("--led-tracker"), std::string::npos) << message;

  auto tracker = std::make_shared<FakeTracker>();
  DriverOptions options;
  options.tracker = tracker;
  Attach(/*simulation=*/false, options);
  tracker->pose.arrival = std::chrono::steady_clock::now();
  const RobotPose pose = driver_->RobotPosition();
  EXPECT_EQ(pose.source, "led-tracker");
  EXPECT_EQ(pose.position, (std::array<double, 3>{0.25, -0.5, 0.06}));
  EXPECT_GE(pose.time, 0.0) << "in seconds since the backend was attached";
  EXPECT_LT(pose.time, 60.0);
  EXPECT_EQ(CodeOf([&] { driver_->SimulatedPosition(); }), StatusCode::kUnimplemented);
  tracker->lost = true;
  EXPECT_EQ(CodeOf([&] { driver_->RobotPosition(); }, &message), StatusCode::kUnavailable);
  EXPECT_NE(message.find("led-tracker"), std::string::npos) << message;
}

TEST_F(DriverFakeTest, ASimulationsPositionComesFromTheTrackerWhenItIsTheSource) {
  auto tracker = std::make_shared<FakeTracker>();
  DriverOptions options;
  options.tracker = tracker;
  options.position_from_tracker = true;
  FakeBackend* fake = Attach(/*simulation=*/true, options);
  fake->time = 2.5;
  const RobotPose pose = driver_->RobotPosition();
  EXPECT_EQ(pose.source, "led-tracker");
  EXPECT_EQ(pose.position, (std::array<double, 3>{0.25, -0.5, 0.06}));
  EXPECT_DOUBLE_EQ(tracker->asked_earliest, 2.5) << "a frame captured at the present simulation time";
  EXPECT_DOUBLE_EQ(tracker->asked_latest, 2.5) << "and none from after it (before a reset)";
  EXPECT_DOUBLE_EQ(pose.time, 2.5) << "the capture time, on the simulation's clock";

  const RobotPose truth = driver_->SimulatedPosition();
  EXPECT_EQ(truth.source, "simulation");
  EXPECT_DOUBLE_EQ(truth.position[0], 0.025) << "the fake bridge's own position";

  tracker->lost = true;
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->RobotPosition(); }, &message), StatusCode::kUnavailable);
  EXPECT_NE(message.find("led-tracker"), std::string::npos) << message;

  // Without the option the simulation's own position is reported.
  options.position_from_tracker = false;
  Attach(/*simulation=*/true, options);
  EXPECT_EQ(driver_->RobotPosition().source, "simulation");
}

TEST_F(DriverFakeTest, TheTrackerAsSourceNeedsATracker) {
  DriverOptions options;
  options.position_from_tracker = true;
  EXPECT_EQ(CodeOf([&] { RobotDriver(options, SmallConfig()); }), StatusCode::kInvalidArgument);
}

TEST_F(DriverFakeTest, WatchStateVelocityComesFromTrackedPositions) {
  auto tracker = std::make_shared<FakeTracker>();
  DriverOptions options;
  options.tracker = tracker;
  options.position_from_tracker = true;
  Attach(/*simulation=*/true, options);
  WatchCursor cursor = driver_->BeginWatch();
  driver_->Sleep(1.0, false, nullptr);  // the simulation clock reaches 1 s
  auto sample = [](double t, double x) {
    return TrackedPose{.position = {x, 0.0, 0.06}, .camera_time = t,
                       .arrival = std::chrono::steady_clock::now()};
  };
  ASSERT_TRUE(tracker->Emit(sample(0.5, 0.10)));
  std::optional<StateUpdate> first = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  while (first && first->pose.source != "led-tracker") {
    first = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  }
  ASSERT_TRUE(first.has_value());
  EXPECT_DOUBLE_EQ(first->pose.time, 0.5);
  ASSERT_TRUE(tracker->Emit(sample(1.0, 0.15)));
  std::optional<StateUpdate> next = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->pose.source, "led-tracker");
  EXPECT_NEAR(next->velocity[0], 0.1, 1e-12) << "(0.15 - 0.10) m / 0.5 s";
  // A frame from after the simulation's present is from before a reset: dropped.
  ASSERT_TRUE(tracker->Emit(sample(7.0, 5.0)));
  EXPECT_FALSE(driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0)).has_value());
  driver_->EndWatch();

  // A real robot: time since the robot was attached, from the host's clock.
  Attach(/*simulation=*/false, options);
  cursor = driver_->BeginWatch();
  ASSERT_TRUE(tracker->Emit(sample(123.0, 0.2)));
  std::optional<StateUpdate> real = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  while (real && real->pose.source != "led-tracker") {
    real = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  }
  ASSERT_TRUE(real.has_value());
  EXPECT_GE(real->pose.time, 0.0);
  EXPECT_LT(real->pose.time, 60.0);
  driver_->EndWatch();
  driver_.reset();
  EXPECT_FALSE(tracker->Emit(sample(1.0, 0.0))) << "the driver removed its handler";
}

TEST_F(DriverFakeTest, ConnectRobotRefusesATreeNotRootedAtTheMasterSetting) {
  DriverOptions options;
  options.master = 2;
  Attach(true, options);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->ConnectRobot(0.0, false, nullptr); }, &message),
            StatusCode::kFailedPrecondition);
  EXPECT_NE(message.find("master node setting is 2"), std::string::npos) << message;
}

TEST_F(DriverFakeTest, IdMappingAppliesToLinksAndCouplingTargetsInSimulation) {
  FakeBackend* fake = Attach(true, Mapped({{1, 11}, {2, 12}, {3, 13}}));
  driver_->ConnectRobot(0.0, true, nullptr);
  const std::vector<snp::Frame> expected = {
      ToBridge(snp::SetMasterNode{.module = 0}),
      ToModule(0, snp::ConnectRequest{.child = 11}),
      ToModule(0, snp::ConnectRequest{.child = 12}),
      ToModule(11, snp::ConnectRequest{.child = 13}),
  };
  EXPECT_EQ(fake->sent, expected);
  fake->sent.clear();
  driver_->SetCouplingValue(1, 2, CouplingField::kWeight, 3.0);
  driver_->Flush();
  const std::vector<snp::Frame> coupling = {
      ToModule(11, snp::SetCoupling{.to = 12, .phase = 1.5f, .weight = 3.0f})};
  EXPECT_EQ(fake->sent, coupling);
}

TEST_F(DriverFakeTest, RealRobotIdsAreNotMapped) {
  FakeBackend* fake = Attach(false, Mapped({{1, 11}, {2, 12}, {3, 13}}));
  driver_->ConnectRobot(0.0, true, nullptr);
  const std::vector<snp::Frame> expected = {
      ToModule(0, snp::ConnectRequest{.child = 1}),
      ToModule(0, snp::ConnectRequest{.child = 2}),
      ToModule(1, snp::ConnectRequest{.child = 3}),
  };
  EXPECT_EQ(fake->sent, expected) << "no SetMasterNode and no mapping on hardware";
}

TEST_F(DriverFakeTest, ControlMessageCarriesTheTristates) {
  FakeBackend* fake = Attach(true, Mapped({{3, 13}}));
  Connect(fake);
  driver_->SendControlMessage(ControlMessage{.uart = Tristate::kOn,
                                             .cpg = Tristate::kUnchanged,
                                             .motors = Tristate::kOff,
                                             .module_ids = {3, 2, 3}});
  const snp::Control control{.uart = Tristate::kOn, .motors = Tristate::kOff};
  std::vector<snp::Frame> expected = {ToModule(13, control), ToModule(2, control)};
  EXPECT_EQ(fake->sent, expected);

  fake->sent.clear();
  const snp::Control all_on{Tristate::kOn, Tristate::kOn, Tristate::kOn};
  driver_->SendControlMessage(ControlMessage{Tristate::kOn, Tristate::kOn, Tristate::kOn, {}, true});
  // Module 0 is inactive (all-zero oscillator): "all" leaves its motor alone.
  const snp::Control no_motor{.uart = Tristate::kOn, .cpg = Tristate::kOn};
  expected = {ToModule(0, no_motor), ToModule(1, all_on), ToModule(2, all_on),
              ToModule(13, all_on)};
  EXPECT_EQ(fake->sent, expected);

  // Named, it is powered.
  fake->sent.clear();
  driver_->SendControlMessage(ControlMessage{.motors = Tristate::kOn, .module_ids = {0}});
  expected = {ToModule(0, snp::Control{.motors = Tristate::kOn})};
  EXPECT_EQ(fake->sent, expected);
}

TEST_F(DriverFakeTest, ADefectMotorNeverGetsMotorOn) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  driver_->SetMotorDefect(2, MotorDefect::kLimp);
  std::vector<snp::Frame> expected = {ToModule(2, snp::Control{.motors = Tristate::kOff})};
  EXPECT_EQ(fake->sent, expected) << "a defect motor is switched off at once";

  fake->sent.clear();
  driver_->SendControlMessage(
      ControlMessage{Tristate::kUnchanged, Tristate::kOn, Tristate::kOn, {}, true});
  const snp::Control on{.cpg = Tristate::kOn, .motors = Tristate::kOn};
  expected = {ToModule(0, snp::Control{.cpg = Tristate::kOn}),  // inactive
              ToModule(1, on), ToModule(2, snp::Control{.cpg = Tristate::kOn}), ToModule(3, on)};
  EXPECT_EQ(fake->sent, expected);

  fake->sent.clear();
  driver_->SendControlMessage(ControlMessage{.motors = Tristate::kOn, .module_ids = {2}});
  EXPECT_TRUE(fake->sent.empty()) << "nothing left to send to module 2";

  driver_->SendControlMessage(ControlMessage{.motors = Tristate::kOff, .module_ids = {2}});
  EXPECT_EQ(fake->sent.size(), 1u) << "motor-off still goes through";

  fake->sent.clear();
  driver_->SetMotorDefect(2, MotorDefect::kNone);
  driver_->SendControlMessage(ControlMessage{.motors = Tristate::kOn, .module_ids = {2}});
  expected = {ToModule(2, snp::Control{.motors = Tristate::kOn})};
  EXPECT_EQ(fake->sent, expected) << "repaired: motor-on is forwarded again";
}

TEST_F(DriverFakeTest, ARefusedFrameKeepsTheUnsentChangesQueued) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  fake->refusals[{2, snp::MessageType::kSetOscillator}] = StatusCode::kOutOfRange;
  driver_->SetModuleValue(1, ModuleField::kAmplitude, 0.1);
  driver_->SetModuleValue(2, ModuleField::kAmplitude, 0.2);
  driver_->SetModuleValue(3, ModuleField::kAmplitude, 0.3);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }, &message), StatusCode::kOutOfRange);
  EXPECT_NE(message.find("module 2 refused SetOscillator"), std::string::npos) << message;
  EXPECT_NE(message.find("2 queued changes not sent"), std::string::npos) << message;
  EXPECT_EQ(driver_->PendingChanges(), 2);
  fake->refusals.clear();
  fake->sent.clear();
  EXPECT_EQ(driver_->Flush(), 2);
  const std::vector<snp::Frame> expected = {ToModule(2, snp::SetOscillator{.amplitude = 0.2f}),
                                            ToModule(3, snp::SetOscillator{.amplitude = 0.3f})};
  EXPECT_EQ(fake->sent, expected);
}

TEST_F(DriverFakeTest, ASilentModuleIsUnavailable) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  fake->silent_modules.insert(3);
  driver_->SetModuleValue(3, ModuleField::kSpeed, 1.0);
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }, &message), StatusCode::kUnavailable);
  EXPECT_NE(message.find("module 3 did not answer SetOscillator"), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { driver_->GetServoAngles({3}); }), StatusCode::kUnavailable);
}

TEST_F(DriverFakeTest, CallErrorsCarryTheirCodes) {
  RobotDriver idle({}, SmallConfig());
  EXPECT_EQ(CodeOf([&] { idle.Flush(); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { idle.Sleep(1.0, false, nullptr); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { idle.ConnectRobot(0, false, nullptr); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { idle.ElapsedTime(); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { idle.GetMorphology(); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { idle.SetModuleValue(1, ModuleField::kAmplitude, 0.3); }), StatusCode::kOk)
      << "the configuration can be edited without a robot";

  Attach(false);
  EXPECT_EQ(CodeOf([&] { driver_->Flush(); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { driver_->Refresh(); }), StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { driver_->SendControlMessage({.motors = Tristate::kOn, .all = true}); }),
            StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf([&] { driver_->SetModuleValue(9, ModuleField::kAmplitude, 0.1); }),
            StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { driver_->SetModuleValue(1, ModuleField::kAmplitude, NAN); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { driver_->SetModuleValue(1, ModuleField::kSpeed, INFINITY); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { driver_->SetModuleValue(1, ModuleField::kAmplitude, -0.1); }),
            StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { driver_->SetModuleValue(1, ModuleField::kMinAngle, 1.5); }),
            StatusCode::kOutOfRange);
  EXPECT_DOUBLE_EQ(driver_->GetModuleValue(1, ModuleField::kMinAngle), -1.0) << "unchanged";
  EXPECT_EQ(CodeOf([&] { driver_->GetCouplingValue(0, 1, CouplingField::kWeight); }),
            StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { driver_->AddCoupling(1, 1, 0, 1); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { driver_->AddCoupling(1, 9, 0, 1); }), StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { driver_->SendControlMessage({.motors = Tristate::kOn}); }),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { driver_->SendControlMessage({.motors = Tristate::kOn, .module_ids = {7}}); }),
            StatusCode::kNotFound);
  EXPECT_EQ(CodeOf([&] { driver_->Sleep(-1.0, false, nullptr); }), StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { driver_->Sleep(NAN, false, nullptr); }), StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf([&] { driver_->GetAccelerometer(1, 17); }), StatusCode::kOutOfRange);
  EXPECT_EQ(CodeOf([&] { driver_->SetFreeRun(1.0); }), StatusCode::kFailedPrecondition)
      << "free-run needs a simulation";
}

TEST_F(DriverFakeTest, BridgeOnlyCallsFailClearlyOnHardware) {
  Attach(false);
  std::string message;
  EXPECT_EQ(CodeOf([&] {
              driver_->ConnectModules(1, snp::Connector::kFront, 2, snp::Connector::kTop, 90);
            }, &message),
            StatusCode::kUnimplemented);
  EXPECT_NE(message.find("manual assembly required"), std::string::npos) << message;
  EXPECT_EQ(CodeOf([&] { driver_->RobotPosition(); }), StatusCode::kUnimplemented);
  EXPECT_EQ(CodeOf([&] { driver_->SetModuleDefect(1, true); }), StatusCode::kUnimplemented);
  EXPECT_EQ(CodeOf([&] { driver_->SetGround({.friction = 0.5}); }), StatusCode::kUnimplemented);
  EXPECT_FALSE(driver_->SimulationModeEnabled());
}

TEST_F(DriverFakeTest, VirtualSleepStepsTheSimulationInChunks) {
  FakeBackend* fake = Attach(true);
  EXPECT_DOUBLE_EQ(driver_->Sleep(0.12, false, nullptr), 0.12);
  ASSERT_EQ(fake->sent.size(), 3u);
  const double chunks[] = {0.05, 0.05, 0.02};
  for (int i = 0; i < 3; ++i) {
    const auto step = std::get<snp::Step>(snp::DecodeMessage(fake->sent[i]));
    EXPECT_NEAR(step.duration, chunks[i], 1e-12) << i;
  }
  EXPECT_DOUBLE_EQ(driver_->ElapsedTime(), 0.12);
}

TEST_F(DriverFakeTest, VirtualSleepHonoursCancellationBetweenChunks) {
  FakeBackend* fake = Attach(true);
  int checks = 0;
  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->Sleep(10.0, false, [&] { return ++checks > 3; }); }, &message),
            StatusCode::kCancelled);
  EXPECT_EQ(fake->sent.size(), 3u) << "three chunks, then the cancellation";
  EXPECT_NE(message.find("cancelled at t = 0.15 s"), std::string::npos) << message;
}

TEST_F(DriverFakeTest, RealTimeSleepWaitsOnTheClockAndStopsOnShutdown) {
  FakeBackend* fake = Attach(false);
  driver_->Sleep(0.02, false, nullptr);
  EXPECT_TRUE(fake->sent.empty()) << "no Step on hardware";
  EXPECT_EQ(CodeOf([&] { driver_->Sleep(100.0, false, [] { return true; }); }),
            StatusCode::kCancelled);
  std::atomic<int> code{-1};
  std::thread sleeper([&] {
    code = static_cast<int>(CodeOf([&] { driver_->Sleep(100.0, true, nullptr); }));
  });
  driver_->Shutdown();
  sleeper.join();
  EXPECT_EQ(code.load(), static_cast<int>(StatusCode::kUnavailable));
}

TEST_F(DriverFakeTest, ServoAnglesAndAccelerometerAreReadOverSnp) {
  FakeBackend* fake = Attach(true, Mapped({{3, 13}}));
  EXPECT_EQ(CodeOf([&] { driver_->GetServoAngles({}); }), StatusCode::kFailedPrecondition);
  Connect(fake);
  const auto angles = driver_->GetServoAngles({});
  ASSERT_EQ(angles.size(), 4u);
  EXPECT_EQ(angles[3].first, 3) << "real ids come back";
  EXPECT_FLOAT_EQ(static_cast<float>(angles[3].second), 0.25f);
  EXPECT_EQ(fake->sent.back(), ToModule(13, snp::ReadServoAngle{}));
  const auto samples = driver_->GetAccelerometer(3, 2);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[1].counts[2], 761);
  EXPECT_NEAR(samples[1].acceleration[2], (761 - 512) * 0.0395, 1e-12);
  EXPECT_EQ(fake->sent.back(), ToModule(13, snp::ReadAccelerometer{.sample_count = 2}));
  EXPECT_EQ(CodeOf([&] { driver_->GetServoAngles({8}); }), StatusCode::kNotFound);
}

TEST_F(DriverFakeTest, LoadConfigQueuesEverythingAndKeepsTheLinksWhenTheTreeIsTheSame) {
  FakeBackend* fake = Attach(false);
  Connect(fake);
  std::string xml = testing::kSmallConfigXml;
  xml.replace(xml.find("amplitude=\"0.3\""), 15, "amplitude=\"0.4\"");
  driver_->LoadConfig(xml, "edited.xml");
  EXPECT_TRUE(driver_->Info().connected);
  EXPECT_EQ(driver_->PendingChanges(), 4 * 3 + 2);
  EXPECT_EQ(driver_->Flush(), 4 * 3 + 2);
  EXPECT_DOUBLE_EQ(driver_->GetModuleValue(3, ModuleField::kAmplitude), 0.4);

  std::string message;
  EXPECT_EQ(CodeOf([&] { driver_->LoadConfig("<yamorconfig>\n<modulelist>\n<module realid=\"x\"/>",
                                             "broken.xml"); }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_NE(message.find("broken.xml"), std::string::npos) << message;
  EXPECT_DOUBLE_EQ(driver_->GetModuleValue(3, ModuleField::kAmplitude), 0.4) << "unchanged";

  driver_->LoadConfig(cpg::WriteConfigXml(QuadrupedConfig()), "quadruped.xml");
  EXPECT_FALSE(driver_->Info().connected) << "another tree must be connected again";
  EXPECT_EQ(driver_->GetAllModulesId().size(), 9u);
}

TEST_F(DriverFakeTest, TransformationScriptsAreValidatedBeforeRunning) {
  FakeBackend* fake = Attach(true);
  std::string message;
  EXPECT_EQ(CodeOf([&] {
              driver_->RunTransformationScript(
                  "<script>\n<pause delay=\"100\"/>\n<explode/>\n</script>", nullptr);
            }, &message),
            StatusCode::kInvalidArgument);
  EXPECT_NE(message.find("script:3"), std::string::npos) << message;
  EXPECT_TRUE(fake->sent.empty()) << "nothing ran";
  EXPECT_EQ(CodeOf([&] {
              driver_->RunTransformationScript(
                  "<script><connect idfrom=\"1\" connfrom=\"side\" idto=\"2\" connto=\"top\"/></script>",
                  nullptr);
            }),
            StatusCode::kInvalidArgument);
  driver_->RunTransformationScript("<script><pause delay=\"100\"/></script>", nullptr);
  EXPECT_EQ(fake->sent.size(), 2u) << "a 0.1 s pause is two 0.05 s steps";
  EXPECT_EQ(CodeOf([&] {
              driver_->RunTransformationScript(
                  "<script><disconnect id=\"3\"/></script>", nullptr);
            }),
            StatusCode::kUnimplemented);
  EXPECT_EQ(fake->sent.back(), ToBridge(snp::DisconnectModule{.module = 3}));
}

TEST_F(DriverFakeTest, WatchersSeeSamplesAndEvents) {
  Attach(true);
  WatchCursor cursor = driver_->BeginWatch();
  std::optional<StateUpdate> first = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  ASSERT_TRUE(first.has_value()) << "the first update is immediate";
  driver_->Sleep(0.5, false, nullptr);
  std::optional<StateUpdate> next = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  ASSERT_TRUE(next.has_value());
  EXPECT_DOUBLE_EQ(next->pose.time, 0.5);
  EXPECT_NEAR(next->velocity[0], 0.01, 1e-9) << "the fake moves 1 cm per second";
  EXPECT_FALSE(driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0)).has_value());
  driver_->SetMotorDefect(1, MotorDefect::kStuck);
  std::optional<StateUpdate> event = driver_->WaitForState(cursor, 0.1, std::chrono::milliseconds(0));
  ASSERT_TRUE(event.has_value());
  ASSERT_EQ(event->events.size(), 1u);
  EXPECT_EQ(event->events[0].kind, "defect_set");
  EXPECT_EQ(event->events[0].module_id, 1);
  driver_->EndWatch();
}

}  // namespace
}  // namespace yamor::host
