#include "tools/characterize/board_recorder.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <thread>

#include "common/format.h"
#include "common/status.h"
#include "optimizer-plugins/framework/host_rpc.h"
#include "yamor/v1/host.grpc.pb.h"

namespace yamor::characterize {
namespace {

constexpr int kReplySamples = 16;  // the most one ReadAccelerometer returns (docs/snp.md)

class Daemon {
 public:
  explicit Daemon(const BoardRecording& r) : recording_(r), host_(r.host, r.rpc_deadline) {}

  template <typename Request, typename Response>
  Response Call(const char* name, client::HostClient::Unary<Request, Response> method,
                const Request& request, double extra_seconds = 0) {
    return host_.Call(method, request,
                      std::string(name) + " (module " + std::to_string(recording_.module_id) + ")",
                      {.deadline = recording_.rpc_deadline + extra_seconds});
  }

  std::vector<std::array<int, 3>> Read() {
    v1::GetAccelerometerRequest request;
    request.set_module_id(static_cast<uint32_t>(recording_.module_id));
    request.set_samples(kReplySamples);
    const auto reply = Call("GetAccelerometer", &v1::Host::Stub::GetAccelerometer, request);
    std::vector<std::array<int, 3>> counts;
    for (const auto& s : reply.samples()) counts.push_back({s.x(), s.y(), s.z()});
    return counts;
  }

 private:
  const BoardRecording& recording_;
  client::HostClient host_;
};

void Validate(const BoardRecording& r) {
  auto positive = [](const char* name, double value) {
    if (!(std::isfinite(value) && value > 0)) {
      throw Error(StatusCode::kInvalidArgument,
                  std::string("record ") + name + " must be finite and > 0, got " +
                      FormatDouble(value));
    }
  };
  positive("seconds", r.seconds);
  positive("sample_period", r.sample_period);
  positive("rpc_deadline", r.rpc_deadline);
  if (r.host.empty()) throw Error(StatusCode::kInvalidArgument, "record host is empty");
}

}  // namespace

std::vector<LoggedReading> RecordBoard(const BoardRecording& recording) {
  Validate(recording);
  Daemon daemon(recording);
  const google::protobuf::Empty empty;
  const bool simulated =
      daemon.Call("SimulationModeEnabled", &v1::Host::Stub::SimulationModeEnabled, empty)
          .enabled();
  const double chunk = kReplySamples * recording.sample_period;
  std::vector<LoggedReading> out;
  const auto wall_start = std::chrono::steady_clock::now();
  double previous_time = -1;
  while (out.empty() || out.back().time - out.front().time < recording.seconds) {
    double now = 0;
    if (simulated) {
      v1::SleepRequest sleep;
      sleep.set_seconds(chunk);
      now = daemon.Call("Sleep", &v1::Host::Stub::Sleep, sleep, 10 * chunk).time();
    } else {
      std::this_thread::sleep_for(std::chrono::duration<double>(chunk));
      now = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    }
    const std::vector<std::array<int, 3>> counts = daemon.Read();
    // The newest reading is `now`; the others one sample period apart before it.
    for (size_t i = 0; i < counts.size(); ++i) {
      const double t = now - double(counts.size() - 1 - i) * recording.sample_period;
      if (t <= previous_time + 1e-9) continue;  // already recorded (a short history)
      out.push_back(LoggedReading{.time = t, .counts = counts[i]});
      previous_time = t;
    }
  }
  return out;
}

std::string LoggedReadingsCsv(const std::vector<LoggedReading>& readings) {
  std::ostringstream out;
  out << "time,count_x,count_y,count_z\n";
  for (const LoggedReading& r : readings) {
    out << FormatDouble(r.time) << ',' << r.counts[0] << ',' << r.counts[1] << ',' << r.counts[2]
        << '\n';
  }
  return out.str();
}

}  // namespace yamor::characterize
