// The one SNP conversation of the host (DESIGN.md, "One SNP path"): send a
// frame, await its acknowledgement or reply with a timeout, map real <-> wire
// module ids, hand unsolicited frames to a callback. RobotDriver and the
// stateless Evaluate workers both talk to their robot only through it.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "cpg/robot_config.h"
#include "host/backend.h"
#include "host/id_map.h"
#include "proto/snp/messages.h"
#include "proto/snp/scene.h"

namespace yamor::host {

/// Timeouts of one link.
struct SnpLinkOptions {
  /// Wait for a module's or the bridge's reply on a real link [s] (a
  /// simulation answers synchronously and never waits).
  double reply_timeout = 1.0;
};

/// One SNP conversation over a Backend. Module ids in the API are real ids;
/// on a simulation they are mapped to simulation ids on the wire (IdMap,
/// thesis C.1), on hardware they go as they are. Replies that are not the
/// one awaited (late answers, events such as TimerFired) go to the
/// unsolicited handler.
///
/// Thread-safety: not thread-safe: one owner at a time (the RobotDriver
/// serialises every call under its mutex; an Evaluate worker owns its link).
class SnpLink {
 public:
  /// Talks over `backend` (not owned; must outlive the link).
  SnpLink(Backend& backend, IdMap id_map, SnpLinkOptions options = {});

  /// The backend.
  Backend& backend() const { return *backend_; }
  /// Real id -> id on the wire.
  int Wire(int real) const;
  /// Id on the wire -> real id.
  int Real(int wire) const;
  /// `message` with every module id field mapped to wire ids.
  snp::Message ToWire(const snp::Message& message) const;

  /// Called with every frame that is not the awaited reply.
  void SetUnsolicitedHandler(std::function<void(const snp::Frame&)> handler);
  /// Called (before the call fails) when a send went out on a link that had
  /// been lost and reopened (Backend::Generation changed): the peer may be
  /// at power-on, unlinked and unconfigured.
  void SetReopenedHandler(std::function<void()> handler);

  /// Sends a module message to real module `id` and waits up to `timeout`
  /// seconds for `reply` (kAck: the Ack of this type); nullopt when nothing
  /// came; throws yamor::Error with the module's code when it refused.
  /// A ConnectAck reply comes back with its child as a real id.
  std::optional<snp::Message> ModuleRequest(int id, const snp::Message& message,
                                            snp::MessageType reply, double timeout);
  /// As ModuleRequest with the reply timeout; UNAVAILABLE when no reply came.
  snp::Message ModuleCall(int id, const snp::Message& message, snp::MessageType reply);
  /// Sends a bridge command and waits for `reply` (kSpecialAck: the
  /// SpecialAck of this command); throws the SpecialError's code with its
  /// text, UNAVAILABLE when nothing came. Module ids in the reply stay wire ids.
  snp::Message BridgeRequest(const snp::Message& message, snp::MessageType reply);
  /// Sends ConfigurationFrames(config) (real ids) and checks every answer:
  /// a refusal throws the module's code, a failed link INVALID_ARGUMENT, a
  /// missing answer UNAVAILABLE.
  void Configure(const cpg::RobotConfig& config);
  /// The current morphology XML, read with chunked ReadMorphology specials
  /// (pipelined: up to 4 requests in flight).
  std::string ReadMorphologyXml();
  /// The scene snapshot (proto/snp/scene.h), read with chunked ReadScene
  /// specials like ReadMorphologyXml; module ids in it stay wire ids.
  /// FAILED_PRECONDITION (the bridge's) when the world is diverged.
  snp::SceneSnapshot ReadScene();

 private:
  void Unsolicited(const snp::Frame& frame);
  // The frame's message; nullopt (logged, naming `from`) when undecodable.
  static std::optional<snp::Message> Decode(const snp::Frame& frame, const std::string& from);
  // BridgeRequest in two halves, for pipelined reads.
  void SendBridgeCommand(const snp::Message& message);
  snp::Message AwaitBridgeReply(snp::MessageType command, snp::MessageType reply);
  // A chunked snapshot read (ReadMorphology or ReadScene): the whole text.
  template <class Request, class Chunk>
  std::vector<uint8_t> ReadChunked();
  // Sends one frame; throws UNAVAILABLE when it went out on a reopened link.
  void SendFrame(const snp::Frame& frame);

  Backend* backend_;
  IdMap id_map_;
  SnpLinkOptions options_;
  bool map_ids_;
  std::function<void(const snp::Frame&)> unsolicited_;
  std::function<void()> reopened_;
  uint64_t generation_;  // Backend::Generation() when the link last saw it
};

}  // namespace yamor::host
