// The in-process simulation backend: an emulated robot (bridge::Robot) driven
// through the real SNP byte path — encode, HandleBytes, decode — so the
// simulation sees exactly the bytes a serial robot would.
#pragma once

#include <deque>
#include <vector>

#include "bridge/robot.h"
#include "host/backend.h"
#include "host/sim_factory.h"
#include "proto/snp/decoder.h"

namespace yamor::host {

/// A simulated robot behind the Backend interface. Synchronous: Send handles
/// the frame (stepping the world for a Step command) before it returns, and
/// the replies wait in an inbox for Receive.
///
/// Thread-safety: not thread-safe (one owner; the driver serialises calls).
class SimBackend final : public Backend {
 public:
  /// Builds the emulated robot (world at t = 0, every module at power-on).
  SimBackend(physics::Morphology morphology, bridge::RobotOptions options);

  /// Encodes `frame`, feeds the bytes to the robot and decodes its replies
  /// into the inbox. Throws INVALID_ARGUMENT for a frame that cannot be encoded.
  void Send(const snp::Frame& frame) override;
  /// Pops the oldest reply; never waits (replies are ready after Send).
  std::optional<snp::Frame> Receive(std::chrono::milliseconds timeout) override;
  /// Always true.
  bool IsSimulation() const override { return true; }
  /// "simulation".
  std::string Name() const override { return "simulation"; }
  /// The emulated robot, for tests and the in-process backend's own use
  /// only: the driver and Evaluate know it through bytes alone.
  bridge::Robot& robot() { return robot_; }

  /// Bytes sent to the robot so far (for tests and statistics).
  uint64_t bytes_sent() const { return bytes_sent_; }

 private:
  bridge::Robot robot_;
  snp::FrameDecoder decoder_;
  std::deque<snp::Frame> inbox_;
  std::vector<uint8_t> tx_;
  std::vector<uint8_t> rx_;
  std::vector<snp::DecodeEvent> events_;
  uint64_t bytes_sent_ = 0;
};

}  // namespace yamor::host
