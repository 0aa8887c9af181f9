// BridgeServer: one emulated robot (bridge::Robot) behind a byte stream, the
// heart of the `yamor-bridge` program. Bytes in -> snp::FrameDecoder
// (resynchronises on garbage) -> Robot::HandleFrame -> encoded reply bytes
// out. Transport-agnostic: the pty and TCP transports (bridge_transport.h)
// and the tests feed it bytes and ship what it returns.
#pragma once

#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "bridge/robot.h"
#include "physics/morphology.h"
#include "proto/snp/decoder.h"

namespace yamor::bridge {

/// What a BridgeServer did with its byte stream.
struct BridgeStats {
  snp::DecoderStats decoder;      ///< Bytes fed, frames, skipped bytes, rejections per kind.
  RobotStats robot;               ///< The emulated robot's counters.
  uint64_t bytes_out = 0;         ///< Reply and event bytes produced.
  uint64_t handler_failures = 0;  ///< Frames whose handling threw (logged, no reply).
  uint64_t streams = 0;           ///< Streams ended with EndStream (host connections closed).
};

/// Serves one emulated robot over a byte stream.
///
/// Robustness: garbage, corrupted, oversized or malformed frames are skipped
/// by the decoder and counted (stats().decoder); a frame whose contents the
/// robot refuses is answered by the robot (Ack / SpecialError); an exception
/// while handling a frame (e.g. a diverged world) is logged and counted, never
/// propagated. Nothing a peer sends makes a method throw.
///
/// Thread-safety: thread-safe. Every public method takes one internal mutex,
/// so a transport thread feeding bytes, a free-run timer and a stats reader
/// may call concurrently; calls are serialised (the robot sees one caller at
/// a time, as Robot requires).
class BridgeServer {
 public:
  /// Builds the robot for `morphology` (world at t = 0, modules at power-on).
  BridgeServer(physics::Morphology morphology, RobotOptions options = {});

  BridgeServer(const BridgeServer&) = delete;
  BridgeServer& operator=(const BridgeServer&) = delete;

  /// Feeds `bytes` from the host (any chunking) and appends the encoded
  /// replies and events of every complete frame to `out`.
  void HandleBytes(std::span<const uint8_t> bytes, std::vector<uint8_t>& out);

  /// The host's stream ended (connection closed): a partial frame is
  /// dropped (counted as truncated) so the next stream starts clean. The
  /// robot keeps its state.
  void EndStream();

  /// Free-running time: advances the world by `seconds` (whole steps, none
  /// if less than one step) and appends the encoded events (TimerFired) to
  /// `out`. Returns the simulated seconds actually advanced (0 once the world
  /// diverged; the failure is logged once).
  double Advance(double seconds, std::vector<uint8_t>& out);

  /// Simulated time [s].
  double Time() const;
  /// The world's fixed step [s].
  double TimeStep() const;
  /// A snapshot of the counters.
  BridgeStats stats() const;

  /// Runs `f(const Robot&)` under the lock (tests, diagnostics).
  template <typename F>
  auto WithRobot(F&& f) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(static_cast<const Robot&>(robot_));
  }

 private:
  void HandleEventsLocked(std::vector<uint8_t>& out);

  mutable std::mutex mutex_;
  Robot robot_;
  snp::FrameDecoder decoder_;
  std::vector<snp::DecodeEvent> events_;
  std::vector<snp::Frame> replies_;
  uint64_t bytes_out_ = 0;
  uint64_t handler_failures_ = 0;
  uint64_t streams_ = 0;
  bool divergence_logged_ = false;
};

}  // namespace yamor::bridge
