#include "optimizer-plugins/framework/host_pool.h"

#include <google/protobuf/empty.pb.h>
#include <google/protobuf/unknown_field_set.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <spdlog/fmt/fmt.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string_view>
#include <thread>
#include <utility>

#include "common/log.h"
#include "common/status.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "yamor/v1/host.grpc.pb.h"
#include "yamor/v1/host.pb.h"

namespace yamor::optimizer {
namespace {

namespace v1 = yamor::v1;
using Clock = std::chrono::steady_clock;
using client::DeadlineAfter;
using client::DescribeStatus;

// ---- Host lists --------------------------------------------------------------

std::string Trim(std::string_view text) {
  const std::size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string_view::npos) return {};
  const std::size_t end = text.find_last_not_of(" \t\r\n");
  return std::string(text.substr(begin, end - begin + 1));
}

// One "HOST:PORT" or "[IPV6]:PORT"; `where` names the entry in errors.
HostAddress ParseEntry(std::string_view entry, const std::string& where) {
  const std::string text = Trim(entry);
  const auto bad = [&](const std::string& why) {
    return Error(StatusCode::kInvalidArgument, where + ": '" + text + "': " + why);
  };
  if (text.empty()) throw bad("empty entry; expected HOST:PORT");
  std::string host;
  std::string port;
  if (text.front() == '[') {
    const std::size_t close = text.find(']');
    if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':') {
      throw bad("expected [IPV6-ADDRESS]:PORT");
    }
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else {
    const std::size_t colon = text.rfind(':');
    if (colon == std::string::npos) throw bad("missing ':PORT'; expected HOST:PORT");
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (host.find(':') != std::string::npos) {
      throw bad("write IPv6 addresses as [ADDRESS]:PORT");
    }
  }
  if (host.empty()) throw bad("empty host; expected HOST:PORT");
  if (host.find_first_of(" \t,/[]@#") != std::string::npos) throw bad("invalid host name");
  if (port.empty() || port.size() > 5 ||
      port.find_first_not_of("0123456789") != std::string::npos) {
    throw bad("port must be a number 1..65535");
  }
  const int number = std::stoi(port);
  if (number < 1 || number > 65535) throw bad("port must be a number 1..65535");
  return HostAddress{.host = std::move(host), .port = number};
}

// ---- Helpers -------------------------------------------------------------------

Clock::duration Seconds(double seconds) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

// HealthCheckResponse { ServingStatus status = 1; }: the status number
// (0 UNKNOWN, 1 SERVING, 2 NOT_SERVING, 3 SERVICE_UNKNOWN); 0 is omitted on
// the wire. Debian ships no C++ health client, so the reply is read with
// UnknownFieldSet.
int ServingStatus(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  if (!buffer.Dump(&slices).ok()) return 0;
  std::string bytes;
  for (const grpc::Slice& s : slices) {
    bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  }
  google::protobuf::UnknownFieldSet fields;
  if (!fields.ParseFromString(bytes)) return 0;
  int status = 0;
  for (int i = 0; i < fields.field_count(); ++i) {
    if (fields.field(i).number() == 1 &&
        fields.field(i).type() == google::protobuf::UnknownField::TYPE_VARINT) {
      status = static_cast<int>(fields.field(i).varint());
    }
  }
  return status;
}

}  // namespace

std::string HostAddress::ToString() const {
  if (host.find(':') != std::string::npos) return "[" + host + "]:" + std::to_string(port);
  return host + ":" + std::to_string(port);
}

std::vector<HostAddress> ParseHosts(const std::string& spec) {
  std::vector<HostAddress> hosts;
  std::map<std::string, std::string> seen;  // "host:port" -> where it was first listed
  const auto add = [&](HostAddress address, const std::string& where) {
    const std::string name = address.ToString();
    const auto [it, inserted] = seen.emplace(name, where);
    if (!inserted) {
      throw Error(StatusCode::kInvalidArgument,
                  where + ": duplicate host " + name + " (also " + it->second + ")");
    }
    hosts.push_back(std::move(address));
  };
  if (!spec.empty() && spec.front() == '@') {
    const std::string path = spec.substr(1);
    if (path.empty()) {
      throw Error(StatusCode::kInvalidArgument, "host list '@': missing file name after '@'");
    }
    std::ifstream in(path);
    if (!in) throw Error(StatusCode::kNotFound, "cannot read host file '" + path + "'");
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      const std::size_t hash = line.find('#');
      if (hash != std::string::npos) line.erase(hash);
      if (Trim(line).empty()) continue;
      const std::string where = path + ":" + std::to_string(number);
      add(ParseEntry(line, where), where);
    }
    if (hosts.empty()) {
      throw Error(StatusCode::kInvalidArgument, "host file '" + path + "' lists no hosts");
    }
    return hosts;
  }
  if (Trim(spec).empty()) {
    throw Error(StatusCode::kInvalidArgument,
                "empty host list; expected HOST:PORT[,HOST:PORT...] or @FILE");
  }
  std::size_t start = 0;
  for (int index = 1;; ++index) {
    const std::size_t comma = spec.find(',', start);
    const std::string entry = spec.substr(start, comma == std::string::npos ? std::string::npos
                                                                            : comma - start);
    const std::string where = "host list entry " + std::to_string(index);
    add(ParseEntry(entry, where), where);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return hosts;
}

// ---- The pool --------------------------------------------------------------------

struct HostPool::Impl {
  // One EvaluateBatch call. Slots are written only under mu_.
  struct Batch {
    const std::vector<Candidate>* candidates = nullptr;  // valid while the batch is active
    uint64_t sequence = 0;                               // submission order, for re-queueing
    Clock::time_point started;
    std::vector<Evaluation> results;
    std::vector<char> filled;
    std::size_t remaining = 0;
    std::optional<Error> error;  // set once: the batch is over
  };

  // One evaluation waiting for (or running on) a host.
  struct Work {
    std::shared_ptr<Batch> batch;
    std::size_t index = 0;
    int attempts = 0;  // host failures met so far
  };

  struct HostState;

  // One Evaluate RPC. Every Call registered in Pump gets exactly one
  // OnEvaluated; a stale call's outcome is ignored (its work was re-queued
  // or its batch is over). Owned by running_calls_ until its callback
  // retires it, then by retired_ until a pool thread (the supervisor or the
  // destructor) drops it: a gRPC callback never holds the last reference to
  // a ClientContext (see Retire).
  struct Call {
    HostState* host = nullptr;
    Work work;
    grpc::ClientContext context;
    v1::EvaluateRequest request;
    v1::EvaluateResponse response;
    Clock::time_point started;
    bool stale = false;  // guarded by mu_
  };

  // One health check: Health/Check, then GetInfo, under one deadline.
  // Owned like a Call: by probes_, then by retired_.
  struct Probe {
    HostState* host = nullptr;
    grpc::ClientContext health_context;
    grpc::ClientContext info_context;
    grpc::ByteBuffer health_request;
    grpc::ByteBuffer health_response;
    google::protobuf::Empty empty;
    v1::GetInfoResponse info;
  };

  struct HostState {
    HostAddress address;
    std::string name;
    std::shared_ptr<grpc::Channel> channel;
    std::unique_ptr<v1::Host::Stub> stub;
    std::unique_ptr<grpc::GenericStub> generic;

    bool up = false;                       // guarded by mu_
    bool removed = false;                  // draining: no new work; guarded by mu_
    bool probing = false;                  // guarded by mu_
    bool checked = false;                  // first health check finished; guarded by mu_
    int capacity = 0;                      // guarded by mu_
    int in_flight = 0;                     // guarded by mu_
    long long completed = 0;               // guarded by mu_
    long long failures = 0;                // guarded by mu_
    std::string last_error;                // guarded by mu_
    int backoff = 0;                       // consecutive failures; guarded by mu_
    Clock::time_point next_check;          // guarded by mu_
    std::set<std::shared_ptr<Call>> calls; // live (non-stale) calls; guarded by mu_
  };

  Impl(std::vector<HostAddress> addresses, EvaluationSettings settings, PoolOptions options);
  ~Impl();

  std::vector<Evaluation> EvaluateBatch(const std::vector<Candidate>& batch);
  void RequestStop();
  int Capacity() const;
  std::vector<HostStatus> Status() const;
  void SetHosts(std::vector<HostAddress> addresses);
  FilmResult FilmCandidate(const Candidate& candidate, const FilmOptions& options,
                           const std::function<bool()>& cancelled);

 private:
  using CallList = std::vector<std::shared_ptr<Call>>;

  // Dispatches pending work to hosts with free slots. Never called with mu_
  // held: starting an RPC may run a gRPC callback inline.
  void Pump();
  HostState* PickHostLocked();
  void StartEvaluate(Call* call);
  void OnEvaluated(Call* call, const grpc::Status& status);
  void Supervise();
  void StartProbe(Probe* probe);
  void OnHealthChecked(Probe* probe, const grpc::Status& status);
  void FinishProbe(Probe* probe, bool ok, int capacity, const std::string& error);
  // Called last by every callback chain, holding no reference to a gRPC
  // object any more: moves the Call's or Probe's ownership to retired_ and
  // releases outstanding_ (the destructor waits for 0). Nothing of the
  // callback may run after it that touches the pool or drops a reference.
  void Retire(Call* call);
  void Retire(Probe* probe);
  // Drops the retired calls and probes (their ClientContexts) on the
  // calling pool thread; `lock` holds mu_ and is released meanwhile.
  void ReapLocked(std::unique_lock<std::mutex>& lock);

  // A host with its channel and stubs (no lock needed: touches no pool state).
  std::unique_ptr<HostState> MakeHost(HostAddress address) const;
  // Drops the drained hosts (removed, nothing in flight, no check running)
  // on the calling pool thread; `lock` holds mu_ and is released meanwhile.
  void ReapHostsLocked(std::unique_lock<std::mutex>& lock);

  void HostFailedLocked(HostState& host, const std::string& error, Work failed, CallList& cancel);
  void MarkDownLocked(HostState& host, const std::string& error, bool from_check);
  void FinishBatchLocked(Batch& batch, Error error, CallList& cancel);
  int UpCountLocked() const;
  double BackoffSeconds(int failures) const;

  const EvaluationSettings settings_;
  const PoolOptions options_;
  v1::EvaluateRequest base_request_;
  double deadline_seconds_ = 0;
  // Members and draining hosts, in the order they joined. Guarded by mu_
  // (the constructor fills it before the supervisor starts); a HostState is
  // destroyed only on a pool thread once nothing refers to it.
  std::vector<std::unique_ptr<HostState>> hosts_;

  mutable std::mutex mu_;
  std::condition_variable cv_;  // any state change below
  std::deque<Work> pending_;                     // guarded by mu_
  std::set<std::shared_ptr<Batch>> batches_;     // active batches; guarded by mu_
  // Every started Evaluate until its callback retires it; guarded by mu_.
  std::map<const Call*, std::shared_ptr<Call>> running_calls_;
  // Running checks until their callback chain retires them; guarded by mu_.
  std::map<const Probe*, std::shared_ptr<Probe>> probes_;
  // Finished calls and probes waiting to be dropped on a pool thread (never
  // on a gRPC callback thread, where dropping the last ClientContext could
  // outlive the pool and tear down a channel during process exit); guarded
  // by mu_.
  std::vector<std::shared_ptr<void>> retired_;
  uint64_t next_sequence_ = 0;                   // guarded by mu_
  std::size_t next_host_ = 0;                    // round-robin tie break; guarded by mu_
  int outstanding_ = 0;                          // RPC chains not yet finished; guarded by mu_
  Clock::time_point all_down_since_;             // valid while no host is up; guarded by mu_
  bool stop_ = false;                            // guarded by mu_
  bool shutting_down_ = false;                   // guarded by mu_
  std::thread supervisor_;
};

HostPool::Impl::Impl(std::vector<HostAddress> addresses, EvaluationSettings settings,
                     PoolOptions options)
    : settings_(std::move(settings)), options_(options) {
  const auto positive = [](double value, const char* name) {
    if (!(value > 0) || !std::isfinite(value)) {
      throw Error(StatusCode::kInvalidArgument,
                  fmt::format("host pool option {} must be > 0, got {}", name, value));
    }
  };
  positive(options_.health_timeout, "health_timeout");
  positive(options_.retry_initial, "retry_initial");
  positive(options_.retry_max, "retry_max");
  if (!(options_.give_up_after >= 0) || !std::isfinite(options_.give_up_after)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("host pool option give_up_after must be >= 0, got {}",
                            options_.give_up_after));
  }
  if (options_.max_attempts < 1) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("host pool option max_attempts must be >= 1, got {}",
                            options_.max_attempts));
  }
  if (!(settings_.deadline_seconds >= 0) || !std::isfinite(settings_.deadline_seconds)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("evaluation deadline_seconds must be >= 0, got {}",
                            settings_.deadline_seconds));
  }
  if (addresses.empty()) throw Error(StatusCode::kInvalidArgument, "the host pool needs a host");

  base_request_.set_config_xml(settings_.config_xml);
  base_request_.set_world(settings_.world);
  base_request_.set_morphology_xml(settings_.morphology_xml);
  base_request_.set_warmup(settings_.warmup);
  base_request_.set_duration(settings_.duration);
  base_request_.set_seed(settings_.seed);
  base_request_.set_time_step(settings_.time_step);
  for (const auto& [module, defect] : settings_.motor_defects) {
    if (module < 0) {
      throw Error(StatusCode::kNotFound, fmt::format("motor defect: module {} does not exist", module));
    }
    v1::SetMotorDefectRequest* d = base_request_.add_motor_defects();
    d->set_module_id(static_cast<uint32_t>(module));
    d->set_defect(defect == MotorDefect::kLimp    ? v1::MOTOR_LIMP
                  : defect == MotorDefect::kStuck ? v1::MOTOR_STUCK
                                                  : v1::MOTOR_OK);
  }
  for (int module : settings_.module_defects) {
    if (module < 0) {
      throw Error(StatusCode::kNotFound, fmt::format("module defect: module {} does not exist", module));
    }
    v1::SetModuleDefectRequest* d = base_request_.add_module_defects();
    d->set_module_id(static_cast<uint32_t>(module));
    d->set_defective(true);
  }
  if (settings_.ground_friction) base_request_.mutable_ground()->set_friction(*settings_.ground_friction);
  if (settings_.ground_slope) base_request_.mutable_ground()->set_slope(*settings_.ground_slope);
  if (settings_.ground_slope_direction) {
    base_request_.mutable_ground()->set_slope_direction(*settings_.ground_slope_direction);
  }
  base_request_.set_upside_down(settings_.upside_down);
  if (settings_.deadline_seconds > 0) {
    deadline_seconds_ = settings_.deadline_seconds;
  } else {
    // Generous: a busy host may run slower than real time, and startup
    // (world build, configuration over SNP) costs extra.
    const double warmup = settings_.warmup > 0 ? settings_.warmup : 8.0;
    const double duration = settings_.duration > 0 ? settings_.duration : 12.0;
    deadline_seconds_ = 10.0 * (warmup + duration) + 60.0;
  }

  const Clock::time_point now = Clock::now();
  std::set<std::string> names;
  for (HostAddress& address : addresses) {
    if (!names.insert(address.ToString()).second) {
      throw Error(StatusCode::kInvalidArgument, "duplicate host " + address.ToString());
    }
    hosts_.push_back(MakeHost(std::move(address)));
  }
  all_down_since_ = now;
  supervisor_ = std::thread([this] { Supervise(); });

  // Wait for every first check (each bounded by health_timeout) so that
  // Capacity() means something when the constructor returns.
  std::unique_lock lock(mu_);
  cv_.wait_for(lock, Seconds(2 * options_.health_timeout + 5), [this] {
    return std::all_of(hosts_.begin(), hosts_.end(), [](const auto& h) { return h->checked; });
  });
}

std::unique_ptr<HostPool::Impl::HostState> HostPool::Impl::MakeHost(HostAddress address) const {
  auto host = std::make_unique<HostState>();
  host->name = address.ToString();
  host->address = std::move(address);
  // Our own backoff decides when to retry a host.
  // The pool's own backoff decides when a host is tried again.
  host->channel = client::MakeChannel(host->name, {.reconnect_initial = options_.retry_initial,
                                                   .reconnect_max = options_.retry_max,
                                                   .own_connection = true});
  host->stub = v1::Host::NewStub(host->channel);
  host->generic = std::make_unique<grpc::GenericStub>(host->channel);
  host->next_check = Clock::now();
  return host;
}

void HostPool::Impl::SetHosts(std::vector<HostAddress> addresses) {
  if (addresses.empty()) {
    throw Error(StatusCode::kInvalidArgument, "the host pool needs a host");
  }
  std::set<std::string> names;
  for (const HostAddress& address : addresses) {
    if (!names.insert(address.ToString()).second) {
      throw Error(StatusCode::kInvalidArgument, "duplicate host " + address.ToString());
    }
  }
  std::vector<HostAddress> joining;
  {
    std::lock_guard lock(mu_);
    for (HostAddress& address : addresses) {
      const std::string name = address.ToString();
      if (std::none_of(hosts_.begin(), hosts_.end(),
                       [&](const auto& h) { return h->name == name; })) {
        joining.push_back(std::move(address));
      }
    }
  }
  // Channels are made outside the lock; one lost to a concurrent SetHosts
  // is dropped here, on the caller's thread.
  std::vector<std::unique_ptr<HostState>> fresh;
  for (HostAddress& address : joining) fresh.push_back(MakeHost(std::move(address)));
  {
    std::lock_guard lock(mu_);
    if (shutting_down_) return;
    const bool any_up = UpCountLocked() > 0;
    for (const auto& host : hosts_) {
      const bool removed = names.count(host->name) == 0;
      if (removed == host->removed) continue;
      host->removed = removed;
      if (removed) {
        Log().info("host {} removed from the list: draining ({} evaluations in flight)",
                   host->name, host->in_flight);
      } else {
        Log().info("host {} listed again", host->name);
      }
    }
    for (auto& host : fresh) {
      if (std::any_of(hosts_.begin(), hosts_.end(),
                      [&](const auto& h) { return h->name == host->name; })) {
        continue;
      }
      Log().info("host {} added to the list: checking it", host->name);
      hosts_.push_back(std::move(host));
    }
    if (any_up && UpCountLocked() == 0) all_down_since_ = Clock::now();
    cv_.notify_all();
  }
  Pump();  // a host listed again may have free slots at once
}

void HostPool::Impl::ReapHostsLocked(std::unique_lock<std::mutex>& lock) {
  std::vector<std::unique_ptr<HostState>> drained;
  for (auto it = hosts_.begin(); it != hosts_.end();) {
    HostState& host = **it;
    if (host.removed && host.in_flight == 0 && !host.probing) {
      Log().info("host {} drained and left the pool ({} evaluations done)", host.name,
                 host.completed);
      drained.push_back(std::move(*it));
      it = hosts_.erase(it);
    } else {
      ++it;
    }
  }
  if (drained.empty()) return;
  lock.unlock();
  drained.clear();  // channels and stubs end on this pool thread
  lock.lock();
}

HostPool::Impl::~Impl() {
  CallList cancel;
  std::vector<std::shared_ptr<Probe>> probes;
  {
    std::lock_guard lock(mu_);
    shutting_down_ = true;
    stop_ = true;
    for (const std::shared_ptr<Batch>& batch : batches_) {
      if (!batch->error) {
        FinishBatchLocked(*batch, Error(StatusCode::kCancelled, "host pool destroyed"), cancel);
      }
    }
    for (const auto& host : hosts_) {
      for (const std::shared_ptr<Call>& call : host->calls) {
        call->stale = true;
        cancel.push_back(call);
      }
      host->calls.clear();
    }
    for (const auto& [raw, probe] : probes_) probes.push_back(probe);
    cv_.notify_all();
  }
  for (const auto& call : cancel) call->context.TryCancel();
  for (const auto& probe : probes) {
    probe->health_context.TryCancel();
    probe->info_context.TryCancel();
  }
  cancel.clear();
  probes.clear();
  {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [this] { return outstanding_ == 0; });
  }
  supervisor_.join();
  // Every callback has retired: the contexts go first, on this thread, then
  // the stubs and channels (hosts_), so no gRPC thread ends a channel.
  retired_.clear();
  hosts_.clear();
}

std::vector<Evaluation> HostPool::Impl::EvaluateBatch(const std::vector<Candidate>& candidates) {
  auto batch = std::make_shared<Batch>();
  batch->candidates = &candidates;
  batch->started = Clock::now();
  batch->results.resize(candidates.size());
  batch->filled.assign(candidates.size(), 0);
  batch->remaining = candidates.size();
  {
    std::lock_guard lock(mu_);
    if (stop_) throw Error(StatusCode::kCancelled, "evaluation stopped");
    if (candidates.empty()) return {};
    batch->sequence = next_sequence_++;
    batches_.insert(batch);
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      pending_.push_back(Work{.batch = batch, .index = i});
    }
  }
  Pump();

  CallList cancel;
  std::unique_lock lock(mu_);
  while (!batch->error && batch->remaining > 0) {
    // A draining host still finishing evaluations is progress too.
    if (UpCountLocked() > 0 ||
        std::any_of(hosts_.begin(), hosts_.end(),
                    [](const auto& h) { return h->removed && h->up && h->in_flight > 0; })) {
      cv_.wait(lock);
      continue;
    }
    const Clock::time_point limit =
        std::max(all_down_since_, batch->started) + Seconds(options_.give_up_after);
    if (Clock::now() < limit) {
      cv_.wait_until(lock, limit);
      continue;
    }
    std::string why = fmt::format("no healthy host for {} s:", options_.give_up_after);
    for (const auto& host : hosts_) {
      why += " " + host->name + " (" + (host->last_error.empty() ? "no answer" : host->last_error) +
             ")";
    }
    FinishBatchLocked(*batch, Error(StatusCode::kUnavailable, why), cancel);
  }
  batches_.erase(batch);
  std::optional<Error> error = batch->error;
  std::vector<Evaluation> results = std::move(batch->results);
  lock.unlock();
  for (const auto& call : cancel) call->context.TryCancel();
  if (error) throw *error;
  return results;
}

void HostPool::Impl::RequestStop() {
  CallList cancel;
  {
    std::lock_guard lock(mu_);
    stop_ = true;
    for (const std::shared_ptr<Batch>& batch : batches_) {
      if (!batch->error) {
        FinishBatchLocked(*batch, Error(StatusCode::kCancelled, "evaluation stopped"), cancel);
      }
    }
    cv_.notify_all();
  }
  for (const auto& call : cancel) call->context.TryCancel();
}

int HostPool::Impl::Capacity() const {
  std::lock_guard lock(mu_);
  int capacity = 0;
  for (const auto& host : hosts_) {
    if (host->up && !host->removed) capacity += host->capacity;
  }
  return std::max(1, capacity);
}

std::vector<HostStatus> HostPool::Impl::Status() const {
  std::lock_guard lock(mu_);
  std::vector<HostStatus> out;
  for (const auto& host : hosts_) {
    out.push_back(HostStatus{.address = host->address,
                             .up = host->up,
                             .capacity = host->capacity,
                             .in_flight = host->in_flight,
                             .completed = host->completed,
                             .failures = host->failures,
                             .last_error = host->last_error,
                             .draining = host->removed});
  }
  return out;
}

// ---- Dispatch ----------------------------------------------------------------------

HostPool::Impl::HostState* HostPool::Impl::PickHostLocked() {
  // The host with the most free slots; ties rotate so equal hosts share work.
  HostState* best = nullptr;
  int best_free = 0;
  std::size_t best_index = 0;
  for (std::size_t k = 0; k < hosts_.size(); ++k) {
    const std::size_t i = (next_host_ + k) % hosts_.size();
    HostState& host = *hosts_[i];
    const int free = host.up && !host.removed ? host.capacity - host.in_flight : 0;
    if (free > best_free) {
      best = &host;
      best_free = free;
      best_index = i;
    }
  }
  if (best) next_host_ = best_index + 1;
  return best;
}

void HostPool::Impl::Pump() {
  CallList start;
  {
    std::lock_guard lock(mu_);
    if (shutting_down_) return;
    while (!pending_.empty()) {
      HostState* host = PickHostLocked();
      if (!host) break;
      auto call = std::make_shared<Call>();
      call->host = host;
      call->work = std::move(pending_.front());
      pending_.pop_front();
      // Built under mu_: the candidates live only while their batch is active.
      call->request = base_request_;
      for (const auto& [name, value] :
           (*call->work.batch->candidates)[call->work.index].parameters) {
        v1::ParameterValue* p = call->request.add_parameters();
        p->set_name(name);
        p->set_value(value);
      }
      call->context.set_deadline(DeadlineAfter(deadline_seconds_));
      ++host->in_flight;
      host->calls.insert(call);
      running_calls_.emplace(call.get(), call);
      ++outstanding_;
      start.push_back(std::move(call));
    }
  }
  for (const auto& call : start) StartEvaluate(call.get());
}

void HostPool::Impl::StartEvaluate(Call* call) {
  call->started = Clock::now();
  // The callback captures no owning reference: running_calls_ owns the call.
  call->host->stub->async()->Evaluate(
      &call->context, &call->request, &call->response,
      [this, call](grpc::Status status) { OnEvaluated(call, status); });
}

void HostPool::Impl::OnEvaluated(Call* raw, const grpc::Status& status) {
  {
    CallList cancel;
    {
      std::lock_guard lock(mu_);
      const std::shared_ptr<Call>& call = running_calls_.at(raw);
      HostState& host = *call->host;
      --host.in_flight;
      if (!call->stale) {
        host.calls.erase(call);
        Batch& batch = *call->work.batch;
        const std::size_t index = call->work.index;
        if (status.ok()) {
          YAMOR_CHECK(!batch.filled[index], "an evaluation slot was filled twice");
          const v1::EvaluateResponse& r = call->response;
          Evaluation& e = batch.results[index];
          e.velocity = r.velocity();
          e.distance = r.distance();
          e.diverged = r.diverged();
          e.divergence = r.divergence();
          if (!std::isfinite(e.velocity) || !std::isfinite(e.distance)) {
            e.velocity = 0.0;
            e.distance = 0.0;
            e.diverged = true;
            e.divergence = "host " + host.name + " returned a non-finite velocity or distance";
          }
          e.host = host.name;
          e.wall_seconds = r.wall_seconds() > 0
                               ? r.wall_seconds()
                               : std::chrono::duration<double>(Clock::now() - call->started).count();
          batch.filled[index] = 1;
          --batch.remaining;
          ++host.completed;
          host.backoff = 0;
        } else if (const Error error = client::ToError(
                       status, host.name,
                       "Evaluate of candidate " + FormatCandidate((*batch.candidates)[index]));
                   client::IsCallerError(error.code())) {
          FinishBatchLocked(batch, error, cancel);
        } else {
          HostFailedLocked(host, DescribeStatus(status), std::move(call->work), cancel);
        }
      }
      cv_.notify_all();
    }
    for (const auto& c : cancel) c->context.TryCancel();
  }  // the references in `cancel` are dropped before the call retires
  Pump();
  Retire(raw);
}

void HostPool::Impl::Retire(Call* call) {
  std::lock_guard lock(mu_);
  const auto it = running_calls_.find(call);
  YAMOR_CHECK(it != running_calls_.end(), "an Evaluate call finished twice");
  retired_.push_back(std::move(it->second));
  running_calls_.erase(it);
  --outstanding_;
  cv_.notify_all();
}

void HostPool::Impl::Retire(Probe* probe) {
  std::lock_guard lock(mu_);
  const auto it = probes_.find(probe);
  YAMOR_CHECK(it != probes_.end(), "a health check finished twice");
  retired_.push_back(std::move(it->second));
  probes_.erase(it);
  --outstanding_;
  cv_.notify_all();
}

void HostPool::Impl::ReapLocked(std::unique_lock<std::mutex>& lock) {
  if (retired_.empty()) return;
  std::vector<std::shared_ptr<void>> dead;
  dead.swap(retired_);
  lock.unlock();
  dead.clear();
  lock.lock();
}

void HostPool::Impl::HostFailedLocked(HostState& host, const std::string& error, Work failed,
                                      CallList& cancel) {
  // Everything the host was running goes back to the front of the queue;
  // its late replies are ignored.
  std::vector<Work> requeue;
  requeue.push_back(std::move(failed));
  for (const std::shared_ptr<Call>& call : host.calls) {
    call->stale = true;
    requeue.push_back(call->work);
    cancel.push_back(call);
  }
  host.calls.clear();
  MarkDownLocked(host, error, /*from_check=*/false);
  std::sort(requeue.begin(), requeue.end(), [](const Work& a, const Work& b) {
    return std::make_pair(a.batch->sequence, a.index) < std::make_pair(b.batch->sequence, b.index);
  });
  for (auto it = requeue.rbegin(); it != requeue.rend(); ++it) {
    Work& work = *it;
    if (work.batch->error) continue;
    if (++work.attempts >= options_.max_attempts) {
      FinishBatchLocked(*work.batch,
                        Error(StatusCode::kUnavailable,
                              fmt::format("candidate {} failed on hosts {} times; last: {}: {}",
                                          FormatCandidate((*work.batch->candidates)[work.index]),
                                          work.attempts, host.name, error)),
                        cancel);
      continue;
    }
    pending_.push_front(std::move(work));
  }
}

void HostPool::Impl::MarkDownLocked(HostState& host, const std::string& error, bool from_check) {
  const bool was_up = host.up;
  const bool first_check = from_check && !host.checked;
  host.up = false;
  ++host.failures;
  host.last_error = error;
  ++host.backoff;
  const double delay = BackoffSeconds(host.backoff);
  host.next_check = Clock::now() + Seconds(delay);
  if (was_up) {
    Log().warn("host {} down: {}; checking it again in {:.3g} s", host.name, error, delay);
  } else if (first_check) {
    Log().warn("host {} not available: {}; checking it again in {:.3g} s", host.name, error,
               delay);
  } else {
    Log().debug("host {} still down: {}; checking it again in {:.3g} s", host.name, error, delay);
  }
  if (was_up && UpCountLocked() == 0) all_down_since_ = Clock::now();
  cv_.notify_all();
}

void HostPool::Impl::FinishBatchLocked(Batch& batch, Error error, CallList& cancel) {
  if (batch.error) return;
  batch.error = std::move(error);
  pending_.erase(std::remove_if(pending_.begin(), pending_.end(),
                                [&](const Work& w) { return w.batch.get() == &batch; }),
                 pending_.end());
  for (const auto& host : hosts_) {
    for (auto it = host->calls.begin(); it != host->calls.end();) {
      if ((*it)->work.batch.get() == &batch) {
        (*it)->stale = true;
        cancel.push_back(*it);
        it = host->calls.erase(it);
      } else {
        ++it;
      }
    }
  }
  cv_.notify_all();
}

int HostPool::Impl::UpCountLocked() const {
  return static_cast<int>(std::count_if(hosts_.begin(), hosts_.end(),
                                       [](const auto& h) { return h->up && !h->removed; }));
}

double HostPool::Impl::BackoffSeconds(int failures) const {
  double delay = options_.retry_initial;
  for (int i = 1; i < failures && delay < options_.retry_max; ++i) delay *= 2;
  return std::min(delay, options_.retry_max);
}

// ---- Health checks -----------------------------------------------------------------

void HostPool::Impl::Supervise() {
  std::unique_lock lock(mu_);
  while (!shutting_down_) {
    ReapLocked(lock);
    if (shutting_down_) break;
    ReapHostsLocked(lock);
    if (shutting_down_) break;
    const Clock::time_point now = Clock::now();
    std::vector<Probe*> start;
    std::optional<Clock::time_point> wake;
    for (const auto& host : hosts_) {
      if (host->up || host->probing || host->removed) continue;
      if (host->next_check <= now) {
        auto probe = std::make_shared<Probe>();
        probe->host = host.get();
        // The first check fails fast on a refused connection; later ones
        // wait (until the deadline) for the channel to reconnect.
        const auto deadline = DeadlineAfter(options_.health_timeout);
        probe->health_context.set_deadline(deadline);
        probe->info_context.set_deadline(deadline);
        probe->health_context.set_wait_for_ready(host->checked);
        probe->info_context.set_wait_for_ready(host->checked);
        host->probing = true;
        probes_.emplace(probe.get(), probe);
        ++outstanding_;
        start.push_back(probe.get());
      } else if (!wake || host->next_check < *wake) {
        wake = host->next_check;
      }
    }
    if (!start.empty()) {
      lock.unlock();
      for (Probe* probe : start) StartProbe(probe);
      lock.lock();
      continue;
    }
    // Any notify wakes it: a host marked down, a call or probe retired.
    if (wake) {
      cv_.wait_until(lock, *wake);
    } else {
      cv_.wait(lock);
    }
  }
}

void HostPool::Impl::StartProbe(Probe* probe) {
  // HealthCheckRequest { service = "" }: the whole server; empty on the wire.
  grpc::Slice empty_message{std::string()};
  probe->health_request = grpc::ByteBuffer(&empty_message, 1);
  probe->host->generic->UnaryCall(
      &probe->health_context, "/grpc.health.v1.Health/Check", grpc::StubOptions(),
      &probe->health_request, &probe->health_response,
      [this, probe](grpc::Status status) { OnHealthChecked(probe, status); });
}

void HostPool::Impl::OnHealthChecked(Probe* probe, const grpc::Status& status) {
  if (status.ok()) {
    const int serving = ServingStatus(probe->health_response);
    if (serving != 1) {
      FinishProbe(probe, false, 0, fmt::format("health check: not serving (status {})", serving));
      return;
    }
  } else if (status.error_code() != grpc::StatusCode::UNIMPLEMENTED) {
    FinishProbe(probe, false, 0, "health check: " + DescribeStatus(status));
    return;
  }
  probe->host->stub->async()->GetInfo(
      &probe->info_context, &probe->empty, &probe->info, [this, probe](grpc::Status info_status) {
        if (info_status.ok()) {
          FinishProbe(probe, true, static_cast<int>(probe->info.worker_capacity()), "");
        } else {
          FinishProbe(probe, false, 0, "GetInfo: " + DescribeStatus(info_status));
        }
      });
}

void HostPool::Impl::FinishProbe(Probe* probe, bool ok, int capacity, const std::string& error) {
  {
    std::lock_guard lock(mu_);
    HostState& host = *probe->host;
    host.probing = false;
    if (!shutting_down_ && !host.removed) {
      if (ok) {
        host.up = true;
        host.capacity = std::max(1, capacity);
        Log().info("host {} up{}, capacity {}", host.name, host.checked ? " again" : "",
                   host.capacity);
      } else {
        MarkDownLocked(host, error, /*from_check=*/true);
      }
    }
    host.checked = true;
    cv_.notify_all();
  }
  Pump();
  Retire(probe);
}

// ---- HostPool ------------------------------------------------------------------------

// ---- Filming one candidate -----------------------------------------------------------

namespace {

// Largest filmed reply accepted: the daemon caps the frames at 512 MiB.
constexpr int kMaxFilmReplyBytes = 600 << 20;

}  // namespace

FilmResult HostPool::Impl::FilmCandidate(const Candidate& candidate, const FilmOptions& options,
                                         const std::function<bool()>& cancelled) {
  if (!(options.deadline_seconds >= 0) || !std::isfinite(options.deadline_seconds)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("film deadline_seconds must be >= 0, got {}", options.deadline_seconds));
  }
  v1::EvaluateRequest request = base_request_;
  for (const auto& [name, value] : candidate.parameters) {
    v1::ParameterValue* p = request.add_parameters();
    p->set_name(name);
    p->set_value(value);
  }
  v1::EvaluationFrames* frames = request.mutable_frames();
  // Sizes beyond int are sent as they are: the daemon names them.
  frames->set_width(static_cast<uint32_t>(std::max(0, options.width)));
  frames->set_height(static_cast<uint32_t>(std::max(0, options.height)));
  frames->set_frame_rate(options.frame_rate);
  frames->set_hide_labels(options.hide_labels);
  frames->set_hide_legend(options.hide_legend);
  frames->set_mp4(options.mp4);
  for (const uint32_t index : options.png_frames) frames->add_png_frames(index);
  v1::Camera* camera = frames->mutable_camera();
  camera->set_kind(v1::CAMERA_FOLLOW);
  if (options.camera_distance) camera->set_distance(*options.camera_distance);
  if (options.camera_elevation) camera->set_elevation(*options.camera_elevation);
  if (options.camera_azimuth) camera->set_azimuth(*options.camera_azimuth);
  const double deadline =
      options.deadline_seconds > 0 ? options.deadline_seconds : 3.0 * deadline_seconds_;

  // Hosts that are up first, then the rest (a host down for the batches
  // may have come back).
  std::vector<HostAddress> order;
  {
    std::lock_guard lock(mu_);
    for (int pass = 0; pass < 2; ++pass) {
      for (const auto& host : hosts_) {
        if (!host->removed && host->up == (pass == 0)) order.push_back(host->address);
      }
    }
  }
  std::string failures;
  for (const HostAddress& address : order) {
    const std::string name = address.ToString();
    // A channel of its own: the pool's channels and their calls stay as they are.
    client::HostClient host(name, deadline,
                            {.reconnect_initial = options_.retry_initial,
                             .reconnect_max = options_.retry_max,
                             .own_connection = true,
                             .max_receive_bytes = kMaxFilmReplyBytes});
    const Clock::time_point started = Clock::now();
    v1::EvaluateResponse response;
    try {
      response = host.Call(&v1::Host::Stub::Evaluate, request, "Evaluate (filming)",
                           {.cancelled = cancelled});
    } catch (const Error& e) {
      if (e.code() == StatusCode::kCancelled) throw Error(StatusCode::kCancelled, "filming cancelled");
      // A wrong request fails on every host; anything else may work on another.
      if (client::IsCallerError(e.code())) {
        throw Error(e.code(), "filming " + FormatCandidate(candidate) + ": " + e.what());
      }
      Log().warn("host pool: {} could not film the candidate: {}", name, e.what());
      failures += (failures.empty() ? "" : "; ") + std::string(e.what());
      continue;
    }
    FilmResult film;
    Evaluation& e = film.evaluation;
    e.velocity = response.velocity();
    e.distance = response.distance();
    e.diverged = response.diverged();
    e.divergence = response.divergence();
    e.host = name;
    e.wall_seconds = response.wall_seconds() > 0
                         ? response.wall_seconds()
                         : std::chrono::duration<double>(Clock::now() - started).count();
    film.frames.reserve(static_cast<std::size_t>(response.frames_size()));
    for (v1::VideoFrame& frame : *response.mutable_frames()) {
      film.frames.push_back(FilmFrame{
          .time = frame.time(), .png = std::move(*frame.mutable_png()), .index = frame.index()});
    }
    film.mp4 = std::move(*response.mutable_mp4());
    film.mp4_frames = static_cast<int>(response.mp4_frames());
    film.video_note = response.video_note();
    return film;
  }
  throw Error(StatusCode::kUnavailable,
              "no host could film " + FormatCandidate(candidate) +
                  (failures.empty() ? std::string(": the pool has no host") : ": " + failures));
}

HostPool::HostPool(std::vector<HostAddress> hosts, EvaluationSettings settings,
                   PoolOptions options)
    : impl_(std::make_unique<Impl>(std::move(hosts), std::move(settings), options)) {}

HostPool::~HostPool() = default;

std::vector<Evaluation> HostPool::EvaluateBatch(const std::vector<Candidate>& batch) {
  return impl_->EvaluateBatch(batch);
}

void HostPool::RequestStop() { impl_->RequestStop(); }

int HostPool::Capacity() const { return impl_->Capacity(); }

std::vector<HostStatus> HostPool::Status() const { return impl_->Status(); }

void HostPool::SetHosts(std::vector<HostAddress> hosts) { impl_->SetHosts(std::move(hosts)); }

FilmResult HostPool::FilmCandidate(const Candidate& candidate, const FilmOptions& options,
                                   const std::function<bool()>& cancelled) {
  return impl_->FilmCandidate(candidate, options, cancelled);
}

// ---- HostListWatcher -------------------------------------------------------------------

// Shared by the watcher and its thread. Thread safety: guarded by mu.
struct HostListWatcher::State {
  std::mutex mu;
  std::condition_variable cv;
  bool stop = false;
  long long applied = 0;
};

namespace {

// What changes when a file is rewritten in place or replaced by a rename.
struct FileSignature {
  bool exists = false;
  std::int64_t mtime_ns = 0;
  std::int64_t size = 0;
  std::uint64_t inode = 0;
  bool operator==(const FileSignature&) const = default;
};

FileSignature SignatureOf(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return {};
  return FileSignature{.exists = true,
                       .mtime_ns = static_cast<std::int64_t>(info.st_mtim.tv_sec) * 1000000000 +
                                   info.st_mtim.tv_nsec,
                       .size = static_cast<std::int64_t>(info.st_size),
                       .inode = static_cast<std::uint64_t>(info.st_ino)};
}

}  // namespace

HostListWatcher::HostListWatcher(std::string path, HostPool& pool, double poll_seconds)
    : state_(std::make_shared<State>()) {
  if (!(poll_seconds > 0) || !std::isfinite(poll_seconds)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("host list poll interval must be > 0 s, got {}", poll_seconds));
  }
  // Nothing counts as applied yet: the first settled poll reads the file and
  // changes the pool only if the file no longer lists the pool's hosts (it
  // may have changed since the pool read it).
  const FileSignature start = SignatureOf(path);
  std::vector<std::string> current;
  for (const HostStatus& s : pool.Status()) {
    if (!s.draining) current.push_back(s.address.ToString());
  }
  std::sort(current.begin(), current.end());
  thread_ = std::thread([state = state_, path = std::move(path), pool = &pool, poll_seconds,
                         previous = start, current = std::move(current)]() mutable {
    FileSignature applied;
    std::unique_lock lock(state->mu);
    while (!state->stop) {
      state->cv.wait_for(lock, Seconds(poll_seconds), [&] { return state->stop; });
      if (state->stop) break;
      lock.unlock();
      const FileSignature now = SignatureOf(path);
      // Apply a change once it held still for a poll: an editor writing in
      // place is not read half-way.
      const bool settled = now == previous && !(now == applied);
      previous = now;
      if (settled) {
        applied = now;
        try {
          std::vector<HostAddress> hosts = ParseHosts("@" + path);
          std::vector<std::string> names;
          for (const HostAddress& h : hosts) names.push_back(h.ToString());
          std::sort(names.begin(), names.end());
          if (names != current) {
            Log().info("host list {} changed: {} hosts", path, names.size());
            pool->SetHosts(std::move(hosts));
            current = std::move(names);
            std::lock_guard count(state->mu);
            ++state->applied;
          }
        } catch (const std::exception& e) {
          Log().warn("host list {} not applied ({}); keeping the current hosts", path, e.what());
        }
      }
      lock.lock();
    }
  });
}

HostListWatcher::~HostListWatcher() {
  {
    std::lock_guard lock(state_->mu);
    state_->stop = true;
  }
  state_->cv.notify_all();
  thread_.join();
}

long long HostListWatcher::Applied() const {
  std::lock_guard lock(state_->mu);
  return state_->applied;
}

}  // namespace yamor::optimizer
