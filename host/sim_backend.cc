#include "host/sim_backend.h"

#include <utility>

#include "common/log.h"

namespace yamor::host {

SimBackend::SimBackend(physics::Morphology morphology, bridge::RobotOptions options)
    : robot_(std::move(morphology), std::move(options)) {}

void SimBackend::Send(const snp::Frame& frame) {
  tx_.clear();
  snp::AppendEncodedFrame(frame, tx_);
  bytes_sent_ += tx_.size();
  rx_.clear();
  robot_.HandleBytes(tx_, rx_);
  events_.clear();
  decoder_.Feed(rx_, events_);
  for (snp::DecodeEvent& event : events_) {
    if (auto* decoded = std::get_if<snp::DecodedFrame>(&event)) {
      inbox_.push_back(std::move(decoded->frame));
    } else {
      // The robot encodes with the same codec: a bad reply is a bug there.
      Log().error("sim backend: undecodable reply bytes: {}",
                  std::get<snp::DecodeError>(event).reason());
    }
  }
}

std::optional<snp::Frame> SimBackend::Receive(std::chrono::milliseconds /*timeout*/) {
  if (inbox_.empty()) return std::nullopt;
  snp::Frame frame = std::move(inbox_.front());
  inbox_.pop_front();
  return frame;
}

}  // namespace yamor::host
