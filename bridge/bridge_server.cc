#include "bridge/bridge_server.h"

#include <cmath>
#include <exception>
#include <utility>

#include "common/log.h"
#include "proto/snp/frame.h"
#include "proto/snp/message_type.h"

namespace yamor::bridge {

BridgeServer::BridgeServer(physics::Morphology morphology, RobotOptions options)
    : robot_(std::move(morphology), std::move(options)) {}

void BridgeServer::HandleBytes(std::span<const uint8_t> bytes, std::vector<uint8_t>& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  events_.clear();
  decoder_.Feed(bytes, events_);
  HandleEventsLocked(out);
}

void BridgeServer::EndStream() {
  std::lock_guard<std::mutex> lock(mutex_);
  events_.clear();
  decoder_.Flush(events_);
  ++streams_;
  // Bytes after a truncated candidate's start byte are searched again, so a
  // flush can still yield frames; they belong to the stream that ended and
  // their replies have nowhere to go.
  std::vector<uint8_t> discarded;
  HandleEventsLocked(discarded);
  bytes_out_ -= discarded.size();
}

void BridgeServer::HandleEventsLocked(std::vector<uint8_t>& out) {
  const std::size_t before = out.size();
  for (const snp::DecodeEvent& event : events_) {
    if (const auto* decoded = std::get_if<snp::DecodedFrame>(&event)) {
      replies_.clear();
      try {
        robot_.HandleFrame(decoded->frame, replies_);
      } catch (const std::exception& e) {
        // Robot answers bad contents itself; anything else is logged, and the
        // stream goes on (the host times out on the missing reply).
        ++handler_failures_;
        Log().error("yamor-bridge: handling {} at stream offset {} failed: {}",
                    snp::MessageTypeName(decoded->frame.type), decoded->offset, e.what());
      }
      for (const snp::Frame& reply : replies_) snp::AppendEncodedFrame(reply, out);
    } else {
      const auto& error = std::get<snp::DecodeError>(event);
      Log().debug("yamor-bridge: skipped candidate at stream offset {}: {}", error.offset(),
                  error.reason());
    }
  }
  bytes_out_ += out.size() - before;
}

double BridgeServer::Advance(double seconds, std::vector<uint8_t>& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double dt = robot_.world().options().time_step;
  if (!(seconds >= dt)) return 0.0;
  // Whole steps only: Robot::Advance rounds to the nearest step count.
  const double steps = std::floor(seconds / dt);
  const double start = robot_.Time();
  replies_.clear();
  try {
    robot_.Advance(steps * dt, replies_);
    divergence_logged_ = false;
  } catch (const std::exception& e) {
    if (!divergence_logged_) {
      Log().warn("yamor-bridge: free-running world stopped: {}", e.what());
      divergence_logged_ = true;
    }
  }
  const std::size_t before = out.size();
  for (const snp::Frame& event : replies_) snp::AppendEncodedFrame(event, out);
  bytes_out_ += out.size() - before;
  return robot_.Time() - start;
}

double BridgeServer::Time() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_.Time();
}

double BridgeServer::TimeStep() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return robot_.world().options().time_step;
}

BridgeStats BridgeServer::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return BridgeStats{.decoder = decoder_.stats(),
                     .robot = robot_.stats(),
                     .bytes_out = bytes_out_,
                     .handler_failures = handler_failures_,
                     .streams = streams_};
}

}  // namespace yamor::bridge
