// The live evaluator against real yamord daemons (path compiled in) on
// ephemeral ports: a live measurement agrees with Evaluate, candidates are
// really on the robot, refused parameters, stop, a daemon killed mid-batch,
// determinism in virtual time, free run on the wall clock.
#include "optimizer-plugins/framework/live_evaluator.h"

#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cmath>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "common/status.h"
#include "tests/support/code_of.h"
#include "tests/support/host_call.h"
#include "tests/support/yamord_process.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::optimizer {
namespace {

namespace v1 = yamor::v1;
using google::protobuf::Empty;
using std::chrono::seconds;
using ::yamor::testing::Call;
using ::yamor::testing::CodeOf;

const char* const kYamord = YAMORD_PATH;

// The quadruped's learned gait of configs/optimize/quadruped-2.xml over the
// built-in configuration (0.3 Hz: a CPG period of 10/3 s), and the same with
// legs that hardly move.
Candidate Learned() {
  Candidate c;
  for (int hip = 0; hip < 4; ++hip) {
    c.parameters.emplace_back("amplitude." + std::to_string(hip), 0.3345214399655798);
  }
  for (int knee = 5; knee < 9; ++knee) {
    c.parameters.emplace_back("amplitude." + std::to_string(knee), 1.48352986419518);
    c.parameters.emplace_back("offset." + std::to_string(knee), -0.37815467126543817);
  }
  const std::pair<const char*, double> phases[] = {
      {"phase.0.1", 0.989019909463457},   {"phase.1.0", -0.989019909463457},
      {"phase.1.2", 1.5126186850617522},  {"phase.2.1", -1.5126186850617522},
      {"phase.2.3", 2.0943951023931953},  {"phase.3.2", -2.0943951023931953},
      {"phase.3.0", 1.687151610261182},   {"phase.0.3", -1.687151610261182}};
  for (const auto& [name, value] : phases) c.parameters.emplace_back(name, value);
  return c;
}
Candidate Weak() {
  Candidate c = Learned();
  for (int id : {0, 1, 2, 3, 5, 6, 7, 8}) {
    c.parameters.emplace_back("amplitude." + std::to_string(id), 0.05);
  }
  return c;
}
constexpr double kPeriod = 1.0 / 0.3;

LiveOptions Short() {
  LiveOptions options;
  options.settle_periods = 1;
  options.measure_periods = 2;
  options.sample_interval = 0.25;
  return options;
}

// A yamord (default world: the quadruped with its built-in configuration)
// on 127.0.0.1:0, killed at the end.
class Daemon : public ::yamor::testing::YamordProcess {
 public:
  Daemon()
      : YamordProcess(kYamord, {"--listen", "127.0.0.1:0", "--log-level", "warn", "--workers", "1"}),
        port_(WaitForPort()),
        stub_(v1::Host::NewStub(grpc::CreateChannel(address().ToString(),
                                                    grpc::InsecureChannelCredentials()))) {}
  HostAddress address() const { return HostAddress{"127.0.0.1", port_}; }
  int port() const { return port_; }
  v1::Host::Stub& stub() { return *stub_; }

  // Connects the robot and switches everything on, keeping its configuration.
  void Walk() {
    v1::SaveConfigResponse saved;
    ASSERT_OK(Call(stub(), &v1::Host::Stub::SaveConfig, Empty(), &saved));
    PrepareLiveRobot(address(), saved.config_xml(), "built-in");
  }

  double ModuleValue(grpc::Status (v1::Host::Stub::*method)(grpc::ClientContext*,
                                                            const v1::ModuleRequest&,
                                                            v1::ValueResponse*),
                     int id) {
    v1::ModuleRequest request;
    request.set_module_id(static_cast<uint32_t>(id));
    v1::ValueResponse value;
    EXPECT_TRUE(Call(stub(), method, request, &value).ok());
    return value.value();
  }

 private:
  int port_;
  std::unique_ptr<v1::Host::Stub> stub_;
};

// Evaluate of `candidate` on the built-in quadruped (the daemon's world) from rest.
double EvaluateVelocity(Daemon& daemon, const Candidate& candidate, double warmup,
                        double duration) {
  v1::EvaluateRequest request;
  request.set_world("quadruped");  // the world at rest, not as the robot is now
  request.set_warmup(warmup);
  request.set_duration(duration);
  for (const auto& [name, value] : candidate.parameters) {
    auto* p = request.add_parameters();
    p->set_name(name);
    p->set_value(value);
  }
  v1::EvaluateResponse response;
  EXPECT_TRUE(Call(daemon.stub(), &v1::Host::Stub::Evaluate, request, &response).ok());
  return response.velocity();
}

// EvaluateBatch bounded in time (a hang fails the test instead of the suite).
std::vector<Evaluation> Guarded(LiveEvaluator& live, const std::vector<Candidate>& batch) {
  auto result = std::async(std::launch::async, [&] { return live.EvaluateBatch(batch); });
  if (result.wait_for(seconds(60)) != std::future_status::ready) {
    ADD_FAILURE() << "EvaluateBatch did not return within 60 s";
    live.RequestStop();
  }
  return result.get();
}

TEST(LiveEvaluatorTest, AKnownGaitMeasuresAsEvaluateDoes) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveEvaluator live(daemon.address(), Short());
  EXPECT_TRUE(live.Simulated());
  EXPECT_EQ(live.Capacity(), 1);
  const std::vector<Evaluation> results = Guarded(live, {Learned(), Weak(), Learned()});
  ASSERT_EQ(results.size(), 3u);
  // From rest, as Evaluate runs it: warm-up = the settling period, duration
  // = the two measured periods.
  const double from_rest = EvaluateVelocity(daemon, Learned(), kPeriod, 2 * kPeriod);
  ASSERT_GT(from_rest, 0.02);
  EXPECT_NEAR(results[0].velocity, from_rest, 0.2 * from_rest)
      << "live " << results[0].velocity << " vs Evaluate " << from_rest;
  // Walking already: Evaluate's steady state (thesis 6.2.1: 8 s + 12 s).
  const double steady = EvaluateVelocity(daemon, Learned(), 8.0, 12.0);
  EXPECT_NEAR(results[2].velocity, steady, 0.2 * steady)
      << "live " << results[2].velocity << " vs Evaluate " << steady;
  EXPECT_LT(results[1].velocity, 0.5 * results[0].velocity)
      << "still legs " << results[1].velocity << " vs " << results[0].velocity;
  for (const Evaluation& e : results) {
    EXPECT_EQ(e.host, daemon.address().ToString());
    EXPECT_FALSE(e.diverged);
    EXPECT_NEAR(e.robot_seconds, 3 * kPeriod, 0.1) << "1 + 2 periods";
    EXPECT_GT(e.wall_seconds, 0.0);
    EXPECT_NEAR(e.velocity, e.distance / (2 * kPeriod), 0.01 * e.velocity + 1e-9);
  }
  EXPECT_EQ(live.Trials(), 3);
  EXPECT_NEAR(live.RobotSeconds(),
              results[0].robot_seconds + results[1].robot_seconds + results[2].robot_seconds, 1e-9);

  // Measure changes nothing and samples the gait that runs now.
  const LiveMeasurement m = live.Measure(1);
  EXPECT_EQ(m.position_source, "simulation");
  EXPECT_DOUBLE_EQ(m.period, kPeriod);
  EXPECT_NEAR(m.end_time - m.start_time, kPeriod, 1e-3);
  EXPECT_EQ(m.samples, 15) << "every 0.25 s over 10/3 s, both ends";
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleAmplitude, 5), 1.48352986419518);
}

TEST(LiveEvaluatorTest, CandidatesAreReallyOnTheRobot) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveEvaluator live(daemon.address(), Short());
  // Limits above the current max: set in the order that keeps min < max.
  live.Apply(Candidate{{{"amplitude.5", 0.9},
                        {"offset.6", -0.2},
                        {"speed.7", 0.8},
                        {"minangle.0", 1.0},
                        {"maxangle.0", 1.2},
                        {"phase.0.5", 2.5},
                        {"weight.0.1", 0.7}}});
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleAmplitude, 5), 0.9);
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleOffset, 6), -0.2);
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleSpeed, 7), 0.8);
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleMinAngle, 0), 1.0);
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleMaxAngle, 0), 1.2);
  v1::CouplingRequest coupling;
  coupling.set_from_id(0);
  coupling.set_to_id(5);
  v1::ValueResponse value;
  ASSERT_OK(Call(daemon.stub(), &v1::Host::Stub::GetCouplingPhase, coupling, &value));
  EXPECT_DOUBLE_EQ(value.value(), 2.5);
  coupling.set_to_id(1);
  ASSERT_OK(Call(daemon.stub(), &v1::Host::Stub::GetCouplingWeight, coupling, &value));
  EXPECT_DOUBLE_EQ(value.value(), 0.7);
  // And back below the current min.
  live.Apply(Candidate{{{"maxangle.0", 0.5}, {"minangle.0", -0.5}}});
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleMinAngle, 0), -0.5);
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleMaxAngle, 0), 0.5);
  EXPECT_EQ(live.Trials(), 0) << "Apply is no trial";
}

TEST(LiveEvaluatorTest, RefusedParametersNameTheCandidateAndLeaveTheRobotUnchanged) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveEvaluator live(daemon.address(), Short());
  const double amplitude = 0.3345214399655798;  // candidate 0's, Learned()
  struct Case {
    std::string name;
    double value;
    StatusCode code;
  };
  const Case cases[] = {
      {"amplitude.42", 0.5, StatusCode::kNotFound},
      {"phase.0.8", 0.5, StatusCode::kNotFound},
      {"torque.3", 0.5, StatusCode::kInvalidArgument},
      {"amplitude.3", NAN, StatusCode::kInvalidArgument},
      {"amplitude.3", -1.0, StatusCode::kOutOfRange},
      {"speed.3", 99.0, StatusCode::kOutOfRange},
  };
  for (const Case& c : cases) {
    std::string message;
    EXPECT_EQ(CodeOf([&] {
                live.EvaluateBatch({Learned(), Candidate{{{"amplitude.0", 0.05}, {c.name, c.value}}}});
              },
                     &message),
              c.code)
        << c.name;
    EXPECT_NE(message.find("'" + c.name + "'"), std::string::npos) << message;
    EXPECT_NE(message.find("candidate 1"), std::string::npos) << message;
    EXPECT_NE(message.find(daemon.address().ToString()), std::string::npos) << message;
    EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleAmplitude, 0), amplitude)
        << "nothing of the refused candidate reached the robot";
  }
  EXPECT_EQ(live.Trials(), static_cast<long long>(std::size(cases))) << "candidate 0 each time";
}

TEST(LiveEvaluatorTest, RequestStopEndsTheTrialWithCancelled) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveOptions options = Short();
  options.measure_periods = 1000;  // would take minutes
  LiveEvaluator live(daemon.address(), options);
  auto batch = std::async(std::launch::async, [&] {
    return CodeOf([&] { live.EvaluateBatch({Learned(), Learned()}); });
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  live.RequestStop();
  ASSERT_EQ(batch.wait_for(seconds(20)), std::future_status::ready) << "stopped between samples";
  EXPECT_EQ(batch.get(), StatusCode::kCancelled);
  EXPECT_EQ(live.Trials(), 0);
  EXPECT_EQ(CodeOf([&] { live.EvaluateBatch({Learned()}); }), StatusCode::kCancelled);
  EXPECT_EQ(CodeOf([&] { live.Measure(); }), StatusCode::kCancelled);
}

TEST(LiveEvaluatorTest, ADaemonKilledMidBatchIsUnavailable) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveOptions options = Short();
  options.measure_periods = 1000;
  LiveEvaluator live(daemon.address(), options);
  std::string message;
  auto batch = std::async(std::launch::async, [&] {
    return CodeOf([&] { live.EvaluateBatch({Learned(), Learned()}); }, &message);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  daemon.Kill();
  ASSERT_EQ(batch.wait_for(seconds(30)), std::future_status::ready);
  EXPECT_EQ(batch.get(), StatusCode::kUnavailable) << message;
  EXPECT_NE(message.find(daemon.address().ToString()), std::string::npos) << message;
}

TEST(LiveEvaluatorTest, VirtualTimeIsDeterministic) {
  std::vector<double> runs[2];
  for (std::vector<double>& velocities : runs) {
    Daemon daemon;
    ASSERT_GT(daemon.port(), 0);
    ASSERT_NO_FATAL_FAILURE(daemon.Walk());
    LiveEvaluator live(daemon.address(), Short());
    for (const Evaluation& e : Guarded(live, {Learned(), Weak(), Learned()})) {
      velocities.push_back(e.velocity);
    }
  }
  ASSERT_EQ(runs[0].size(), 3u);
  EXPECT_EQ(runs[0], runs[1]);
  EXPECT_NE(runs[0][0], runs[0][2]) << "the robot did not start from rest the second time";
}

TEST(LiveEvaluatorTest, FreeRunMeasuresOnTheWallClock) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveEvaluator live(daemon.address(), Short());
  live.Apply(Learned());
  v1::SetFreeRunRequest free_run;
  free_run.set_real_time_factor(2.0);
  ASSERT_OK(Call(daemon.stub(), &v1::Host::Stub::SetFreeRun, free_run));
  const LiveMeasurement m = live.Measure(0.5);  // 5/3 s of robot time, ~5/6 s of wall time
  EXPECT_GE(m.end_time - m.start_time, 0.5 * kPeriod - 1e-6);
  EXPECT_GT(m.samples, 2);
  EXPECT_GT(m.velocity, 0.0);
  free_run.set_real_time_factor(0.0);
  ASSERT_OK(Call(daemon.stub(), &v1::Host::Stub::SetFreeRun, free_run));
}

TEST(LiveEvaluatorTest, AttachingChecksTheDaemonAndTheOptions) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  std::string message;
  EXPECT_EQ(CodeOf([&] { LiveEvaluator live(daemon.address()); }, &message),
            StatusCode::kFailedPrecondition)
      << "no robot connected yet";
  EXPECT_NE(message.find("ConnectRobot"), std::string::npos) << message;
  ASSERT_NO_FATAL_FAILURE(daemon.Walk());
  LiveOptions bad;
  bad.measure_periods = 0;
  EXPECT_EQ(CodeOf([&] { LiveEvaluator live(daemon.address(), bad); }),
            StatusCode::kInvalidArgument);
  bad = LiveOptions{};
  bad.sample_interval = NAN;
  EXPECT_EQ(CodeOf([&] { LiveEvaluator live(daemon.address(), bad); }),
            StatusCode::kInvalidArgument);
  const HostAddress gone = daemon.address();
  daemon.Kill();
  EXPECT_EQ(CodeOf([&] { LiveEvaluator live(gone); }, &message), StatusCode::kUnavailable);
  EXPECT_NE(message.find(gone.ToString()), std::string::npos) << message;
}

TEST(LiveEvaluatorTest, PrepareLoadsTheConfigurationAndRefusesABadOne) {
  Daemon daemon;
  ASSERT_GT(daemon.port(), 0);
  v1::SaveConfigResponse saved;
  ASSERT_OK(Call(daemon.stub(), &v1::Host::Stub::SaveConfig, Empty(), &saved));
  std::string xml = saved.config_xml();
  const std::string from = "amplitude=\"";
  const std::size_t at = xml.find(from);
  ASSERT_NE(at, std::string::npos);
  const std::size_t end = xml.find('"', at + from.size());
  xml.replace(at + from.size(), end - at - from.size(), "0.25");  // module 0's amplitude
  const LivePreparation first = PrepareLiveRobot(daemon.address(), xml, "test.xml");
  EXPECT_TRUE(first.connected_now);
  EXPECT_GT(first.links, 0);
  EXPECT_EQ(first.backend, "simulation");
  EXPECT_DOUBLE_EQ(daemon.ModuleValue(&v1::Host::Stub::GetModuleAmplitude, 0), 0.25);
  const LivePreparation again = PrepareLiveRobot(daemon.address(), xml, "test.xml");
  EXPECT_FALSE(again.connected_now) << "connected already: Refresh";
  std::string message;
  EXPECT_EQ(CodeOf([&] { PrepareLiveRobot(daemon.address(), "<yamorconfig>", "broken.xml"); },
                   &message),
            StatusCode::kInvalidArgument);
  EXPECT_NE(message.find("broken.xml"), std::string::npos) << message;
}

}  // namespace
}  // namespace yamor::optimizer
