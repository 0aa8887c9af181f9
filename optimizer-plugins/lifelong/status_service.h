// The status service of yamor-lifelong (`--listen ADDR:PORT`,
// proto/yamor/v1/lifelong.proto): the life's status and its event stream over
// gRPC, so a person or `yamorctl life` can watch a living robot.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "optimizer-plugins/lifelong/life_cycle.h"
#include "optimizer-plugins/lifelong/robot_port.h"
#include "yamor/v1/lifelong.pb.h"

namespace grpc {
class Server;
}  // namespace grpc

namespace yamor::lifelong {

/// Most events a LifeBroadcast keeps for replay.
inline constexpr std::size_t kMaxKeptEvents = 1000;

/// What the service says beside the life's own status.
struct StatusContext {
  std::string mode;                ///< Relearning mode ("online" or "model").
  std::string robot;               ///< The robot's daemon (HOST:PORT).
  std::uint64_t relearn_budget = 0;  ///< max_evaluations of a relearning.
};

/// The status message for `status` in `context`; `ended` once life is over.
v1::LifeStatus ToProto(const LifeStatus& status, const StatusContext& context, bool ended);

/// One logged event as watchers get it.
struct BroadcastEvent {
  std::uint64_t index = 0;  ///< 0, 1, ... in logging order.
  LifeEvent event;          ///< The event.
  LifeStatus status;        ///< The life's status when it was logged.
};

/// A LifeLog that passes everything on to `inner` and keeps the events
/// (the last kMaxKeptEvents) for the status service's watchers.
///
/// Thread safety: Row and Event from the runner's thread (as LifeLog);
/// everything else from any thread.
class LifeBroadcast final : public LifeLog {
 public:
  /// `inner` outlives the object. `status` (set later with set_status, may
  /// be empty) gives the status stored with each event.
  explicit LifeBroadcast(LifeLog& inner);

  /// The status source (LifeCycle::Status); call before the life starts.
  void set_status(std::function<LifeStatus()> status);
  /// The current status (a default one before set_status).
  LifeStatus Status() const;

  void Row(const TimelineRow& row) override;
  void Event(const LifeEvent& event) override;

  /// Marks the life over: watchers get what is left and end.
  void End();
  /// True after End().
  bool ended() const;
  /// Index the next event will get.
  std::uint64_t next_index() const;
  /// The kept events from index `from` on (from the oldest kept when `from`
  /// is older), waiting up to `timeout` for one when there is none yet.
  std::vector<BroadcastEvent> WaitFrom(std::uint64_t from, std::chrono::milliseconds timeout) const;

 private:
  LifeLog& inner_;
  mutable std::mutex mu_;
  mutable std::condition_variable changed_;
  std::function<LifeStatus()> status_;  // guarded by mu_
  std::deque<BroadcastEvent> events_;   // guarded by mu_
  std::uint64_t next_ = 0;              // guarded by mu_
  bool ended_ = false;                  // guarded by mu_
};

/// The gRPC server of the yamor.v1.Lifelong service.
///
/// Thread safety: construct and Shutdown from one thread; the server's own
/// threads only read the broadcast.
class StatusServer {
 public:
  /// Listens on `listen` (HOST:PORT; port 0 picks a free one).
  /// `broadcast` outlives the server. Throws yamor::Error kUnavailable naming
  /// the address when it cannot listen there.
  StatusServer(const std::string& listen, LifeBroadcast& broadcast, StatusContext context);
  ~StatusServer();
  StatusServer(const StatusServer&) = delete;
  StatusServer& operator=(const StatusServer&) = delete;

  /// The port it listens on.
  int port() const { return port_; }
  /// Stops: streams still open get up to `grace` to finish, then are cancelled.
  void Shutdown(std::chrono::milliseconds grace = std::chrono::milliseconds(2000));

 private:
  class Service;
  std::unique_ptr<Service> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace yamor::lifelong
