// The byte/frame transport between the robot driver and one robot: the
// in-process simulation (SimBackend), a serial link to real hardware (a later
// issue), or a scripted fake in tests. Every backend carries SNP frames, so
// the same bytes drive the simulation and the real robot (DESIGN.md).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "proto/snp/frame.h"

namespace yamor::host {

/// One robot link. The driver sends frames with Send and collects the robot's
/// replies and events with Receive.
///
/// Thread-safety: implementations need not be thread-safe; the RobotDriver
/// serialises every call under its mutex.
class Backend {
 public:
  virtual ~Backend() = default;

  /// Sends one frame to the robot. Throws yamor::Error(UNAVAILABLE) when the
  /// link is gone.
  virtual void Send(const snp::Frame& frame) = 0;

  /// The next frame from the robot, waiting up to `timeout` for one. A
  /// synchronous backend (the simulation) has its replies ready as soon as
  /// Send returns, so it never waits: nullopt means no reply will come.
  virtual std::optional<snp::Frame> Receive(std::chrono::milliseconds timeout) = 0;

  /// True for a simulated robot: bridge commands (time, step, position,
  /// reset, ground, defects, morphology; docs/snp.md) are answered and
  /// virtual time advances only when stepped. There is no other way in.
  virtual bool IsSimulation() const = 0;

  /// Short name for logs and GetInfo ("simulation", "serial", "fake").
  virtual std::string Name() const = 0;

  /// How many times the link was opened. A link that reopens after a loss
  /// (device unplugged, bridge restarted) counts up: the peer may have
  /// restarted at power-on, so the host must link and configure it again.
  /// Links that cannot reopen stay at 1.
  virtual uint64_t Generation() const { return 1; }
};

}  // namespace yamor::host
