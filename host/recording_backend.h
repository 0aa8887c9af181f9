// A Backend decorator that records every SNP frame in both directions to a
// recorded-session file (docs/snp.md, "Recorded sessions"): `yamord
// --record FILE`. `yamor-bridge --replay FILE` re-drives a simulation from it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "host/backend.h"
#include "proto/snp/recording.h"

namespace yamor::host {

/// Wraps any Backend: forwards Send and Receive unchanged and writes each
/// frame sent (after the inner Send accepted it) and each frame received to
/// a shared RecordingWriter. Construction writes an `open` line with the
/// given attributes, so frames after it belong to this backend. A recording
/// write that fails is logged (once per backend) and counted; the robot
/// keeps being served.
///
/// Thread-safety: as thread-safe as the wrapped backend (the driver
/// serialises calls under its mutex); the writer is thread-safe, so several
/// RecordingBackends (one per opened simulation) may share one file.
class RecordingBackend final : public Backend {
 public:
  /// Wraps `inner`, recording to `writer`; writes the `open` line with
  /// `attributes` (backend=<inner's Name()> is added first unless given).
  RecordingBackend(std::unique_ptr<Backend> inner,
                   std::shared_ptr<snp::RecordingWriter> writer,
                   snp::RecordAttributes attributes);

  /// Forwards to the inner backend, then records the frame as host→robot.
  void Send(const snp::Frame& frame) override;
  /// Forwards to the inner backend and records a frame it returns as robot→host.
  std::optional<snp::Frame> Receive(std::chrono::milliseconds timeout) override;
  /// The inner backend's answer.
  bool IsSimulation() const override { return inner_->IsSimulation(); }
  /// The inner backend's name.
  std::string Name() const override { return inner_->Name(); }
  /// The inner backend's link generation (a reopened link counts up).
  uint64_t Generation() const override { return inner_->Generation(); }

  /// Frames recorded by this backend (both directions).
  uint64_t frames_recorded() const { return frames_recorded_; }
  /// Recording writes that failed.
  uint64_t write_failures() const { return write_failures_; }

 private:
  void Record(snp::Direction direction, const snp::Frame& frame);

  std::unique_ptr<Backend> inner_;
  std::shared_ptr<snp::RecordingWriter> writer_;
  uint64_t frames_recorded_ = 0;
  uint64_t write_failures_ = 0;
};

}  // namespace yamor::host
