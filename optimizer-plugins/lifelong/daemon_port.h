// The robot of one yamord as the lifelong runner sees it (RobotPort): the
// stateful API for configurations and walking, the framework's LiveEvaluator
// for measurements, a WatchState stream for events, GetMorphology for the
// body and GetAccelerometer for the orientation.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "optimizer-plugins/framework/host_pool.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "optimizer-plugins/framework/live_evaluator.h"
#include "optimizer-plugins/lifelong/robot_port.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::lifelong {

/// How the port talks to its daemon.
struct DaemonPortOptions {
  optimizer::LiveOptions live;  ///< Measurements (sample interval, RPC deadline).
  double rpc_deadline = 10;     ///< [s] of one ordinary RPC.
  double connect_timeout = 0;   ///< ConnectRobot's link timeout [s]; 0 = the daemon's.
  int accelerometer_samples = 16;  ///< Samples averaged per reading (1..16).
  double watch_period = 1;      ///< [s] WatchState period (events come at once regardless).
  double reattach_initial = 0.2;  ///< First wait between reattach attempts [s].
  double reattach_max = 5;      ///< Cap of the doubling wait [s].
  /// Morphology XML of the robot when the daemon cannot give one (a real
  /// robot: GetMorphology is UNIMPLEMENTED).
  std::string morphology_xml;
};

/// A RobotPort over one yamord.
///
/// Hooks: `before_motion` (set before use) runs before every measurement,
/// settle and relearning trial with the robot time; it returns true when it
/// changed the robot (a scenario's scheduled change), and the next
/// TakeEvents then waits up to 2 s for the daemon's events to arrive.
/// `on_restart` runs when a reattached daemon lost the robot (before the
/// robot is set up again).
///
/// Thread safety: the RobotPort methods from one thread; RequestStop from
/// any; the WatchState stream runs on its own thread.
class DaemonPort final : public RobotPort {
 public:
  /// Connects to `address` (no RPC yet); starts the event stream.
  DaemonPort(const optimizer::HostAddress& address, DaemonPortOptions options);
  ~DaemonPort() override;
  DaemonPort(const DaemonPort&) = delete;
  DaemonPort& operator=(const DaemonPort&) = delete;

  double Now() override;
  Window Measure(double periods) override;
  void Settle(double periods) override;
  std::vector<RobotEvent> TakeEvents() override;
  AccelReading ReadAccelerometer() override;
  std::pair<cpg::ModuleGraph, std::string> Body() override;
  void Walk(const std::string& config_xml) override;
  Reattachment Reattach(const std::string& config_xml, const std::function<bool()>& stop) override;
  void RequestStop() override;

  /// A new live evaluator on this daemon (the robot must be connected), for
  /// online relearning.
  std::unique_ptr<optimizer::LiveEvaluator> NewLiveEvaluator();
  /// Runs the before-motion hook (the relearner calls it before each trial).
  void BeforeMotion();

  /// Sets the hooks (see the class comment).
  void set_before_motion(std::function<bool(double)> hook) { before_motion_ = std::move(hook); }
  /// Sets the restart hook.
  void set_on_restart(std::function<void()> hook) { on_restart_ = std::move(hook); }

  /// The daemon's address.
  const optimizer::HostAddress& address() const { return address_; }
  /// The client of the daemon (for scenario changes and setup).
  client::HostClient& host() { return *host_; }
  /// Deadline of ordinary RPCs [s].
  double rpc_deadline() const { return options_.rpc_deadline; }
  /// True when the daemon runs a simulation (asked once per attachment).
  bool Simulated();

 private:
  void WatchLoop();
  void CheckStop() const;
  optimizer::LiveEvaluator& Live();

  optimizer::HostAddress address_;
  std::string name_;
  DaemonPortOptions options_;
  std::unique_ptr<client::HostClient> host_;
  // The event stream's client (same channel): the destructor cancels it alone.
  std::unique_ptr<client::HostClient> watch_host_;
  std::function<bool(double)> before_motion_;
  std::function<void()> on_restart_;
  std::atomic<bool> stop_{false};
  int central_ = -1;  // central module id (from GetMorphology)
  std::optional<bool> simulated_;

  std::mutex live_mu_;
  std::unique_ptr<optimizer::LiveEvaluator> live_;  // guarded by live_mu_ for RequestStop

  std::mutex events_mu_;
  std::condition_variable events_cv_;
  std::vector<RobotEvent> events_;                    // guarded by events_mu_
  bool await_events_ = false;                         // guarded by events_mu_
  bool shutdown_ = false;                             // guarded by events_mu_
  std::thread watch_;
};

}  // namespace yamor::lifelong
