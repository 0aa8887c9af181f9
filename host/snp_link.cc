#include "host/snp_link.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <utility>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"
#include "host/config_frames.h"

namespace yamor::host {
namespace {

using snp::Address;
using Clock = std::chrono::steady_clock;

std::chrono::milliseconds ToMillis(double seconds) {
  return std::chrono::milliseconds(static_cast<int64_t>(std::ceil(std::max(0.0, seconds) * 1e3)));
}

std::chrono::milliseconds Remaining(Clock::time_point deadline) {
  return std::max(std::chrono::milliseconds(0),
                  std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
}

}  // namespace

SnpLink::SnpLink(Backend& backend, IdMap id_map, SnpLinkOptions options)
    : backend_(&backend),
      id_map_(std::move(id_map)),
      options_(options),
      map_ids_(backend.IsSimulation()),
      generation_(backend.Generation()) {}

int SnpLink::Wire(int real) const { return map_ids_ ? id_map_.ToSim(real) : real; }

int SnpLink::Real(int wire) const { return map_ids_ ? id_map_.ToReal(wire) : wire; }

snp::Message SnpLink::ToWire(const snp::Message& message) const {
  auto wire8 = [this](int real) { return static_cast<uint8_t>(Wire(real)); };
  snp::Message out = message;
  if (auto* m = std::get_if<snp::ConnectRequest>(&out)) m->child = wire8(m->child);
  if (auto* m = std::get_if<snp::SetCoupling>(&out)) m->to = wire8(m->to);
  if (auto* m = std::get_if<snp::SetMasterNode>(&out)) m->module = wire8(m->module);
  if (auto* m = std::get_if<snp::DisconnectModule>(&out)) m->module = wire8(m->module);
  if (auto* m = std::get_if<snp::SetMotorFault>(&out)) m->module = wire8(m->module);
  if (auto* m = std::get_if<snp::SetModuleDefect>(&out)) m->module = wire8(m->module);
  if (auto* m = std::get_if<snp::ConnectModules>(&out)) {
    m->from = wire8(m->from);
    m->to = wire8(m->to);
  }
  return out;
}

void SnpLink::SetUnsolicitedHandler(std::function<void(const snp::Frame&)> handler) {
  unsolicited_ = std::move(handler);
}

void SnpLink::SetReopenedHandler(std::function<void()> handler) {
  reopened_ = std::move(handler);
}

void SnpLink::SendFrame(const snp::Frame& frame) {
  backend_->Send(frame);
  const uint64_t generation = backend_->Generation();
  if (generation == generation_) return;
  generation_ = generation;
  if (reopened_) reopened_();
  throw Error(StatusCode::kUnavailable,
              "the " + backend_->Name() + " link was lost and reopened before " +
                  std::string(snp::MessageTypeName(frame.type)) +
                  ": the robot may have restarted at power-on; Refresh (or ConnectRobot) "
                  "links and configures it again");
}

std::optional<snp::Message> SnpLink::Decode(const snp::Frame& frame, const std::string& from) {
  try {
    return snp::DecodeMessage(frame);
  } catch (const Error& e) {
    Log().warn("snp link: undecodable reply from {}: {}", from, e.what());
    return std::nullopt;
  }
}

void SnpLink::Unsolicited(const snp::Frame& frame) {
  if (unsolicited_) {
    unsolicited_(frame);
    return;
  }
  Log().debug("snp link: ignoring {} from {}", snp::MessageTypeName(frame.type),
              snp::ToString(frame.source));
}

std::optional<snp::Message> SnpLink::ModuleRequest(int id, const snp::Message& message,
                                                   snp::MessageType reply, double timeout) {
  const int wire = Wire(id);
  const Address module = Address::Module(static_cast<uint8_t>(wire));
  const snp::Message wire_message = ToWire(message);
  const snp::MessageType type = snp::TypeOf(message);
  SendFrame(snp::MakeFrame(Address::Host(), module, wire_message));
  const Clock::time_point deadline = Clock::now() + ToMillis(timeout);
  while (true) {
    std::optional<snp::Frame> frame = backend_->Receive(Remaining(deadline));
    if (!frame) return std::nullopt;  // the backend waited the rest for nothing
    if (frame->source != module || frame->destination.kind != snp::NodeKind::kHost) {
      Unsolicited(*frame);
      continue;
    }
    std::optional<snp::Message> decoded = Decode(*frame, "module " + std::to_string(id));
    if (!decoded) continue;
    const snp::Message& m = *decoded;
    if (const auto* ack = std::get_if<snp::Ack>(&m); ack && ack->acked == type) {
      if (ack->status != StatusCode::kOk) {
        throw Error(ack->status, "module " + std::to_string(id) + " refused " +
                                     std::string(snp::MessageTypeName(type)) + " (" +
                                     std::string(StatusCodeName(ack->status)) + ")");
      }
      if (reply == snp::MessageType::kAck) return m;
    }
    if (snp::TypeOf(m) == reply && reply != snp::MessageType::kAck) {
      if (const auto* ack = std::get_if<snp::ConnectAck>(&m)) {
        // A late answer to an earlier link attempt is not ours.
        if (ack->child != std::get<snp::ConnectRequest>(wire_message).child) continue;
        snp::ConnectAck real = *ack;
        real.child = static_cast<uint8_t>(Real(ack->child));
        return real;
      }
      return m;
    }
    Unsolicited(*frame);
  }
}

snp::Message SnpLink::ModuleCall(int id, const snp::Message& message, snp::MessageType reply) {
  std::optional<snp::Message> m = ModuleRequest(id, message, reply, options_.reply_timeout);
  if (!m) {
    throw Error(StatusCode::kUnavailable,
                "module " + std::to_string(id) + " did not answer " +
                    std::string(snp::MessageTypeName(snp::TypeOf(message))) +
                    (backend_->IsSimulation() ? ""
                                              : " within " + FormatRounded(options_.reply_timeout) + " s") +
                    " (is it linked? the robot may be half-configured)");
  }
  return *m;
}

snp::Message SnpLink::BridgeRequest(const snp::Message& message, snp::MessageType reply) {
  SendBridgeCommand(message);
  return AwaitBridgeReply(snp::TypeOf(message), reply);
}

void SnpLink::SendBridgeCommand(const snp::Message& message) {
  SendFrame(snp::MakeFrame(Address::Host(), Address::Bridge(), ToWire(message)));
}

snp::Message SnpLink::AwaitBridgeReply(snp::MessageType type, snp::MessageType reply) {
  const Clock::time_point deadline = Clock::now() + ToMillis(options_.reply_timeout);
  while (true) {
    std::optional<snp::Frame> frame = backend_->Receive(Remaining(deadline));
    if (!frame) {
      throw Error(StatusCode::kUnavailable, "the " + backend_->Name() +
                                                " backend did not answer " +
                                                std::string(snp::MessageTypeName(type)));
    }
    if (frame->source.kind != snp::NodeKind::kBridge) {
      Unsolicited(*frame);
      continue;
    }
    std::optional<snp::Message> decoded = Decode(*frame, "the bridge");
    if (!decoded) continue;
    const snp::Message& m = *decoded;
    if (const auto* error = std::get_if<snp::SpecialError>(&m); error && error->acked == type) {
      throw Error(error->code, std::string(snp::MessageTypeName(type)) + " failed: " + error->text);
    }
    if (const auto* ack = std::get_if<snp::SpecialAck>(&m);
        ack && ack->acked == type && reply == snp::MessageType::kSpecialAck) {
      return m;
    }
    if (snp::TypeOf(m) == reply && reply != snp::MessageType::kSpecialAck) return m;
    Unsolicited(*frame);
  }
}

void SnpLink::Configure(const cpg::RobotConfig& config) {
  for (const snp::Frame& frame : ConfigurationFrames(config)) {
    const snp::Message message = snp::DecodeMessage(frame);
    const int id = frame.destination.id;
    const snp::MessageType reply = std::holds_alternative<snp::ConnectRequest>(message)
                                       ? snp::MessageType::kConnectAck
                                       : snp::MessageType::kAck;
    std::optional<snp::Message> answer =
        ModuleRequest(id, message, reply, options_.reply_timeout);
    if (!answer) {
      throw Error(StatusCode::kUnavailable, "module " + std::to_string(id) + " did not answer " +
                                                std::string(snp::MessageTypeName(frame.type)));
    }
    if (const auto* ack = std::get_if<snp::ConnectAck>(&*answer);
        ack && ack->status != snp::LinkStatus::kUp) {
      throw Error(StatusCode::kInvalidArgument, "bluetooth link " + std::to_string(id) + " -> " +
                                                    std::to_string(ack->child) + " failed");
    }
  }
}

namespace {

// The command and reply of one chunked snapshot read (ReadMorphology /
// MorphologyChunk, ReadScene / SceneChunk: the same layout).
template <class Request, class Chunk>
struct ChunkedRead {
  static constexpr uint32_t kChunk = static_cast<uint32_t>(snp::kMaxPayloadSize - 8);
  static Request At(uint32_t offset) {
    return Request{.offset = offset, .length = static_cast<uint8_t>(kChunk)};
  }
};

}  // namespace

template <class Request, class Chunk>
std::vector<uint8_t> SnpLink::ReadChunked() {
  // The first read takes the snapshot and tells its size; the rest are
  // pipelined, kWindow requests ahead, so a slow line never idles between
  // chunks (the bridge answers in order).
  constexpr uint32_t kWindow = 4;
  using Read = ChunkedRead<Request, Chunk>;
  const std::string name(snp::MessageTypeName(Request::kType));
  std::vector<uint8_t> bytes;
  uint32_t total = 0;
  uint32_t next_offset = 0;  // of the next request to send
  uint32_t in_flight = 0;
  do {
    if (next_offset == 0) {
      SendBridgeCommand(Read::At(0));
      next_offset = Read::kChunk;
      in_flight = 1;
    } else {
      while (in_flight < kWindow && next_offset < total) {
        SendBridgeCommand(Read::At(next_offset));
        next_offset += Read::kChunk;
        ++in_flight;
      }
    }
    const snp::Message m = AwaitBridgeReply(Request::kType, Chunk::kType);
    --in_flight;
    const auto& chunk = std::get<Chunk>(m);
    if (!bytes.empty() && chunk.total != total) {
      throw Error(StatusCode::kInternal, name + ": the snapshot size changed");
    }
    total = chunk.total;
    if (chunk.offset != bytes.size() || (chunk.data.empty() && bytes.size() < total)) {
      throw Error(StatusCode::kInternal, name + ": chunk at offset " +
                                             std::to_string(chunk.offset) + ", expected " +
                                             std::to_string(bytes.size()));
    }
    bytes.insert(bytes.end(), chunk.data.begin(), chunk.data.end());
  } while (bytes.size() < total);
  return bytes;
}

std::string SnpLink::ReadMorphologyXml() {
  const std::vector<uint8_t> bytes = ReadChunked<snp::ReadMorphology, snp::MorphologyChunk>();
  return std::string(bytes.begin(), bytes.end());
}

snp::SceneSnapshot SnpLink::ReadScene() {
  const std::vector<uint8_t> bytes = ReadChunked<snp::ReadScene, snp::SceneChunk>();
  try {
    return snp::DecodeSceneSnapshot(bytes);
  } catch (const Error& e) {
    // The peer sent a snapshot its own codec should have refused.
    throw Error(StatusCode::kInternal, std::string("ReadScene: ") + e.what());
  }
}

}  // namespace yamor::host
