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

namespace yamor::host {

double DefaultSimulationTimeStep() { return physics::WorldOptions().time_step; }

std::unique_ptr<Backend> MakeSimBackend(physics::Morphology morphology,
                                        const SimulationOptions& options) {
  bridge::RobotOptions robot_options;
  robot_options.world.time_step =
      options.time_step == 0.0 ? DefaultSimulationTimeStep() : options.time_step;
  robot_options.world.seed = options.seed;
  robot_options.phase_seed = options.seed;
  if (options.master >= 0) robot_options.master = options.master;
  return std::make_unique<SimBackend>(std::move(morphology), robot_options);
}

}  // namespace yamor::host
