// A scripted Backend for driver tests: records every frame the driver sends
// and answers like an obliging robot (and, when it plays a simulation, like
// the bridge), except where a test scripts silence or refusal.
#pragma once

#include <deque>
#include <functional>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "host/backend.h"
#include "proto/snp/messages.h"

namespace yamor::host::testing {

/// Thread-safety: none (the driver serialises calls; tests read after).
class FakeBackend final : public Backend {
 public:
  /// A fake robot; `simulation` makes it answer bridge commands as a simulation.
  explicit FakeBackend(bool simulation) : simulation_(simulation) {}

  void Send(const snp::Frame& frame) override {
    sent.push_back(frame);
    for (snp::Frame& reply : Answer(frame)) inbox_.push_back(std::move(reply));
  }
  std::optional<snp::Frame> Receive(std::chrono::milliseconds) override {
    if (inbox_.empty()) return std::nullopt;
    snp::Frame f = inbox_.front();
    inbox_.pop_front();
    return f;
  }
  bool IsSimulation() const override { return simulation_; }
  std::string Name() const override { return "fake"; }
  uint64_t Generation() const override { return generation; }

  /// Backend::Generation: a test bumps it to play a link lost and reopened.
  uint64_t generation = 1;

  /// Every frame sent, in order.
  std::vector<snp::Frame> sent;
  /// ConnectRequests parent -> child (wire ids) that get no answer.
  std::set<std::pair<int, int>> silent_links;
  /// ConnectRequests parent -> child (wire ids) that get no answer this many
  /// more times, then work (a radio link that misses).
  std::map<std::pair<int, int>, int> flaky_links;
  /// ConnectRequests parent -> child (wire ids) answered "failed".
  std::set<std::pair<int, int>> failed_links;
  /// (module wire id, message type) refused with this code.
  std::map<std::pair<int, snp::MessageType>, StatusCode> refusals;
  /// Modules (wire ids) that never answer anything.
  std::set<int> silent_modules;
  /// Simulated time answered to GetSimTime / Step.
  double time = 0.0;
  /// Called for each frame before the default answer (e.g. to cancel).
  std::function<void(const snp::Frame&)> on_send;

  /// The messages of the frames sent, decoded.
  std::vector<snp::Message> SentMessages() const {
    std::vector<snp::Message> out;
    for (const snp::Frame& f : sent) out.push_back(snp::DecodeMessage(f));
    return out;
  }

 private:
  std::vector<snp::Frame> Answer(const snp::Frame& frame) {
    if (on_send) on_send(frame);
    using snp::Address;
    const snp::Message m = snp::DecodeMessage(frame);
    std::vector<snp::Frame> out;
    if (frame.destination.kind == snp::NodeKind::kBridge) {
      auto reply = [&](const snp::Message& r) {
        out.push_back(snp::MakeFrame(Address::Bridge(), Address::Host(), r));
      };
      const snp::MessageType type = frame.type;
      if (!simulation_) {
        reply(snp::SpecialError{.acked = type, .code = StatusCode::kUnimplemented,
                                .text = "manual assembly required"});
      } else if (std::holds_alternative<snp::GetSimInfo>(m)) {
        reply(snp::SimInfo{.time_step = 0.001, .accelerometer_zero = 512.0,
                           .accelerometer_count = 0.0395});
      } else if (std::holds_alternative<snp::GetDivergence>(m)) {
        reply(snp::Divergence{.diverged = false, .time = time});
      } else if (std::holds_alternative<snp::ReadMorphology>(m)) {
        reply(snp::SpecialError{.acked = type, .code = StatusCode::kUnimplemented,
                                .text = "no morphology in this fake"});
      } else if (std::holds_alternative<snp::GetSimTime>(m)) {
        reply(snp::SimTime{.seconds = time});
      } else if (const auto* step = std::get_if<snp::Step>(&m)) {
        time += step->duration;
        reply(snp::StepDone{.time = time});
      } else if (std::holds_alternative<snp::GetRobotPosition>(m)) {
        reply(snp::RobotPosition{.time = time, .position = {0.01 * time, 0.0, 0.05}});
      } else if (std::holds_alternative<snp::ConnectModules>(m) ||
                 std::holds_alternative<snp::DisconnectModule>(m)) {
        reply(snp::SpecialError{.acked = type, .code = StatusCode::kUnimplemented,
                                .text = "not in this fake"});
      } else {
        reply(snp::SpecialAck{.acked = type});
      }
      return out;
    }
    if (frame.destination.IsBroadcast()) return out;
    const int id = frame.destination.id;
    if (silent_modules.count(id)) return out;
    auto from_module = [&](const snp::Message& r) {
      out.push_back(snp::MakeFrame(Address::Module(static_cast<uint8_t>(id)), Address::Host(), r));
    };
    auto refusal = refusals.find({id, frame.type});
    if (refusal != refusals.end()) {
      from_module(snp::Ack{.acked = frame.type, .status = refusal->second});
      return out;
    }
    if (const auto* request = std::get_if<snp::ConnectRequest>(&m)) {
      const std::pair<int, int> link{id, request->child};
      if (silent_links.count(link)) return out;
      if (auto flaky = flaky_links.find(link); flaky != flaky_links.end() && flaky->second > 0) {
        --flaky->second;
        return out;
      }
      from_module(snp::ConnectAck{.child = request->child,
                                  .status = failed_links.count(link) ? snp::LinkStatus::kFailed
                                                                     : snp::LinkStatus::kUp});
    } else if (std::holds_alternative<snp::ReadServoAngle>(m)) {
      from_module(snp::ServoAngle{.angle = 0.25f});
    } else if (const auto* read = std::get_if<snp::ReadAccelerometer>(&m)) {
      snp::Accelerometer a;
      for (int i = 0; i < read->sample_count; ++i) {
        a.samples.push_back({.x = 512, .y = 512, .z = static_cast<int16_t>(760 + i)});
      }
      from_module(a);
    } else {
      from_module(snp::Ack{.acked = frame.type, .status = StatusCode::kOk});
    }
    return out;
  }

  bool simulation_;
  std::deque<snp::Frame> inbox_;
};

}  // namespace yamor::host::testing
