#include "optimizer-plugins/lifelong/status_service.h"

#include <grpcpp/grpcpp.h>

#include <atomic>

#include "common/log.h"
#include "common/status.h"
#include "optimizer-plugins/lifelong/timeline.h"
#include "yamor/v1/lifelong.grpc.pb.h"

namespace yamor::lifelong {

v1::LifeStatus ToProto(const LifeStatus& s, const StatusContext& context, bool ended) {
  v1::LifeStatus out;
  out.set_state(s.state);
  out.set_time(s.time);
  out.set_velocity(s.velocity);
  out.set_ema(s.ema);
  out.set_threshold(s.threshold);
  out.set_gait(s.gait);
  out.set_anomalies(static_cast<uint32_t>(s.anomalies));
  out.set_recalls(static_cast<uint32_t>(s.recalls));
  out.set_relearns(static_cast<uint32_t>(s.relearns));
  out.set_trials(static_cast<uint64_t>(s.trials));
  out.set_gaps(static_cast<uint32_t>(s.gaps));
  out.set_detail(s.detail);
  out.set_relearn_trials(static_cast<uint64_t>(s.relearn_trials));
  out.set_relearn_budget(context.relearn_budget);
  out.set_mode(context.mode);
  out.set_robot(context.robot);
  out.set_ended(ended);
  return out;
}

LifeBroadcast::LifeBroadcast(LifeLog& inner) : inner_(inner) {}

void LifeBroadcast::set_status(std::function<LifeStatus()> status) {
  std::lock_guard lock(mu_);
  status_ = std::move(status);
}

LifeStatus LifeBroadcast::Status() const {
  std::function<LifeStatus()> status;
  {
    std::lock_guard lock(mu_);
    status = status_;
  }
  return status ? status() : LifeStatus{};
}

void LifeBroadcast::Row(const TimelineRow& row) { inner_.Row(row); }

void LifeBroadcast::Event(const LifeEvent& event) {
  inner_.Event(event);
  const LifeStatus status = Status();
  {
    std::lock_guard lock(mu_);
    events_.push_back(BroadcastEvent{.index = next_++, .event = event, .status = status});
    while (events_.size() > kMaxKeptEvents) events_.pop_front();
  }
  changed_.notify_all();
}

void LifeBroadcast::End() {
  {
    std::lock_guard lock(mu_);
    ended_ = true;
  }
  changed_.notify_all();
}

bool LifeBroadcast::ended() const {
  std::lock_guard lock(mu_);
  return ended_;
}

std::uint64_t LifeBroadcast::next_index() const {
  std::lock_guard lock(mu_);
  return next_;
}

std::vector<BroadcastEvent> LifeBroadcast::WaitFrom(std::uint64_t from, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mu_);
  changed_.wait_for(lock, timeout, [&] { return ended_ || next_ > from; });
  std::vector<BroadcastEvent> out;
  for (const BroadcastEvent& e : events_) {
    if (e.index >= from) out.push_back(e);
  }
  return out;
}

class StatusServer::Service final : public v1::Lifelong::Service {
 public:
  Service(LifeBroadcast& broadcast, StatusContext context) : broadcast_(broadcast), context_(std::move(context)) {}

  grpc::Status GetLifeStatus(grpc::ServerContext*, const google::protobuf::Empty*, v1::LifeStatus* out) override {
    try {
      *out = ToProto(broadcast_.Status(), context_, broadcast_.ended());
      return grpc::Status::OK;
    } catch (const std::exception& e) {
      Log().warn("status service: GetLifeStatus failed: {}", e.what());
      return grpc::Status(grpc::StatusCode::INTERNAL, e.what());
    }
  }

  grpc::Status WatchLife(grpc::ServerContext* context, const v1::WatchLifeRequest* request,
                         grpc::ServerWriter<v1::LifeUpdate>* writer) override {
    try {
      std::uint64_t next = request->replay() ? 0 : broadcast_.next_index();
      while (!context->IsCancelled()) {
        if (stopping_.load()) return grpc::Status(grpc::StatusCode::UNAVAILABLE, "the status service is stopping");
        const bool ended = broadcast_.ended();
        const std::vector<BroadcastEvent> events = broadcast_.WaitFrom(next, std::chrono::milliseconds(200));
        for (const BroadcastEvent& e : events) {
          v1::LifeUpdate update;
          update.set_index(e.index);
          update.set_time(e.event.time);
          update.set_kind(e.event.kind);
          update.set_json(EventLine(e.event));
          *update.mutable_status() = ToProto(e.status, context_, false);
          if (!writer->Write(update)) return grpc::Status::OK;  // the client went away
          next = e.index + 1;
        }
        // Everything logged before the end has been sent.
        if (ended && next >= broadcast_.next_index()) return grpc::Status::OK;
      }
      return grpc::Status(grpc::StatusCode::CANCELLED, "cancelled by the client");
    } catch (const std::exception& e) {
      Log().warn("status service: WatchLife failed: {}", e.what());
      return grpc::Status(grpc::StatusCode::INTERNAL, e.what());
    }
  }

  void Stop() { stopping_.store(true); }

 private:
  LifeBroadcast& broadcast_;
  StatusContext context_;
  std::atomic<bool> stopping_{false};
};

StatusServer::StatusServer(const std::string& listen, LifeBroadcast& broadcast, StatusContext context)
    : service_(std::make_unique<Service>(broadcast, std::move(context))) {
  // gRPC reads any number as a port (99999 binds somewhere): check first.
  const std::size_t colon = listen.rfind(':');
  const std::string port_text = colon == std::string::npos ? "" : listen.substr(colon + 1);
  const bool digits = !port_text.empty() && port_text.size() <= 5 &&
                      port_text.find_first_not_of("0123456789") == std::string::npos;
  if (colon == std::string::npos || colon == 0 || !digits || std::stoi(port_text) > 65535) {
    throw Error(StatusCode::kInvalidArgument,
                "--listen \"" + listen + "\" is not HOST:PORT with a port in 0..65535");
  }
  grpc::ServerBuilder builder;
  builder.AddListeningPort(listen, grpc::InsecureServerCredentials(), &port_);
  builder.RegisterService(service_.get());
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0) {
    server_.reset();
    throw Error(StatusCode::kUnavailable, "the status service cannot listen on " + listen);
  }
}

StatusServer::~StatusServer() { Shutdown(std::chrono::milliseconds(0)); }

void StatusServer::Shutdown(std::chrono::milliseconds grace) {
  if (!server_) return;
  server_->Shutdown(std::chrono::system_clock::now() + grace);
  service_->Stop();
  server_->Wait();
  server_.reset();
}

}  // namespace yamor::lifelong
