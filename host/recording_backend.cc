#include "host/recording_backend.h"

#include <utility>

#include "common/log.h"
#include "common/status.h"

namespace yamor::host {

RecordingBackend::RecordingBackend(std::unique_ptr<Backend> inner,
                                   std::shared_ptr<snp::RecordingWriter> writer,
                                   snp::RecordAttributes attributes)
    : inner_(std::move(inner)), writer_(std::move(writer)) {
  YAMOR_CHECK(inner_ != nullptr, "RecordingBackend needs a backend");
  YAMOR_CHECK(writer_ != nullptr, "RecordingBackend needs a writer");
  if (!snp::FindAttribute(attributes, "backend")) {
    attributes.insert(attributes.begin(), {"backend", inner_->Name()});
  }
  try {
    writer_->WriteOpen(attributes);
  } catch (const Error& e) {
    ++write_failures_;
    Log().error("recording: {}", e.what());
  }
}

void RecordingBackend::Send(const snp::Frame& frame) {
  inner_->Send(frame);
  Record(snp::Direction::kHostToRobot, frame);
}

std::optional<snp::Frame> RecordingBackend::Receive(std::chrono::milliseconds timeout) {
  std::optional<snp::Frame> frame = inner_->Receive(timeout);
  if (frame) Record(snp::Direction::kRobotToHost, *frame);
  return frame;
}

void RecordingBackend::Record(snp::Direction direction, const snp::Frame& frame) {
  try {
    writer_->WriteFrame(direction, frame);
    ++frames_recorded_;
  } catch (const Error& e) {
    // Logged once: a full disk would otherwise log every frame.
    if (write_failures_++ == 0) Log().error("recording stops working: {}", e.what());
  }
}

}  // namespace yamor::host
