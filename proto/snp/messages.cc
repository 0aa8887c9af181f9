#include "proto/snp/messages.h"

#include <bit>
#include <cmath>
#include <concepts>
#include <string>
#include <type_traits>
#include <utility>

#include <fmt/format.h>

#include "proto/snp/frame_check.h"

namespace yamor::snp {

namespace {

constexpr uint8_t kTristateBits = 2;
constexpr uint8_t kTristateMask = 0x03;
constexpr uint8_t kControlReservedBits = 0xC0;
constexpr uint8_t kOscillatorAmplitudeBit = 0x01;
constexpr uint8_t kOscillatorOffsetBit = 0x02;
constexpr uint8_t kOscillatorSpeedBit = 0x04;
constexpr uint8_t kOscillatorReservedBits = 0xF8;
constexpr uint8_t kGroundReservedBits = 0xF8;
constexpr uint8_t kMaxStatusCode =
    static_cast<uint8_t>(StatusCode::kUnauthenticated);

template <class M, class T>
concept Is = std::same_as<std::remove_const_t<M>, T>;

// Raises the INVALID_ARGUMENT error of a message field.
template <class... Args>
[[noreturn]] void FailField(MessageType type, std::string_view field,
                            fmt::format_string<Args...> format,
                            Args&&... args) {
  throw Error(StatusCode::kInvalidArgument,
              fmt::format("{}.{} {}", MessageTypeName(type), field,
                          fmt::format(format, std::forward<Args>(args)...)));
}

// Encoding side of the symmetric field serialisers below: validates each
// value and appends its little-endian bytes.
class Writer {
 public:
  static constexpr bool kDecoding = false;

  explicit Writer(MessageType type) : type_(type) {}

  void U8(uint8_t value, std::string_view) { out_.PushBack(value); }

  void U8InRange(uint8_t value, std::string_view field, uint8_t min,
                 uint8_t max) {
    if (value < min || value > max) {
      FailField(type_, field, "{} out of range {}..{}", value, min, max);
    }
    U8(value, field);
  }

  void ModuleId(uint8_t value, std::string_view field) {
    U8InRange(value, field, 0, kMaxModuleId);
  }

  template <class E>
  void Enum(E value, std::string_view field, E max) {
    U8InRange(static_cast<uint8_t>(value), field, 0,
              static_cast<uint8_t>(max));
  }

  void AccelerometerCount(int16_t value, std::size_t index, char axis) {
    CheckAccelerometerCount(type_, value, index, axis);
    PutLittleEndian(static_cast<uint16_t>(value), 2);
  }

  void Float32(float value, std::string_view field) {
    if (!std::isfinite(value)) FailField(type_, field, "is not finite: {}", value);
    PutLittleEndian(std::bit_cast<uint32_t>(value), 4);
  }

  void Float64(double value, std::string_view field) {
    if (!std::isfinite(value)) FailField(type_, field, "is not finite: {}", value);
    PutLittleEndian(std::bit_cast<uint64_t>(value), 8);
  }

  // A message type answered by an Ack / SpecialAck / SpecialError.
  void AckedType(MessageType value, std::string_view field,
                 MessageClass required) {
    CheckAckedType(type_, static_cast<uint8_t>(value), field, required);
    U8(static_cast<uint8_t>(value), field);
  }

  void Status(StatusCode value, std::string_view field, bool allow_ok) {
    U8InRange(static_cast<uint8_t>(value), field, allow_ok ? 0 : 1,
              kMaxStatusCode);
  }

  void U32(uint32_t value, std::string_view) { PutLittleEndian(value, 4); }

  void Bool(bool value, std::string_view field) { U8(value ? 1 : 0, field); }

  void Bytes(const std::vector<uint8_t>& value, std::string_view field,
             std::size_t max) {
    if (value.size() > max) {
      FailField(type_, field, "is {} bytes long, at most {} fit", value.size(), max);
    }
    out_.Append(value);
  }

  void Text(const std::string& value, std::string_view field,
            std::size_t max = kMaxErrorTextSize) {
    if (value.size() > max) {
      FailField(type_, field, "is {} bytes long, at most {} fit", value.size(),
                max);
    }
    CheckPrintable(type_, field,
                   {reinterpret_cast<const uint8_t*>(value.data()),
                    value.size()});
    out_.Append({reinterpret_cast<const uint8_t*>(value.data()), value.size()});
  }

  MessageType type() const { return type_; }
  const Payload& payload() const { return out_; }

  static void CheckAckedType(MessageType type, uint8_t code,
                             std::string_view field, MessageClass required) {
    if (!IsKnownMessageType(code)) {
      FailField(type, field, "is not a known message type: 0x{:02x}", code);
    }
    if (ClassOf(static_cast<MessageType>(code)) != required) {
      FailField(type, field, "names {}, which is not a {}",
                MessageTypeName(static_cast<MessageType>(code)),
                required == MessageClass::kModule ? "module message"
                                                  : "bridge command");
    }
  }

  static void CheckAccelerometerCount(MessageType type, int16_t value,
                                     std::size_t index, char axis) {
    if (value < 0 || value > kMaxAccelerometerCount) {
      FailField(type, fmt::format("samples[{}].{}", index, axis),
                "{} out of range 0..{}", value, kMaxAccelerometerCount);
    }
  }

  static void CheckPrintable(MessageType type, std::string_view field,
                             std::span<const uint8_t> text) {
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] < 0x20 || text[i] > 0x7E) {
        FailField(type, field, "has non-printable byte 0x{:02x} at {}",
                  text[i], i);
      }
    }
  }

 private:
  void PutLittleEndian(uint64_t bits, int size) {
    for (int i = 0; i < size; ++i) {
      out_.PushBack(static_cast<uint8_t>(bits >> (8 * i)));
    }
  }

  MessageType type_;
  Payload out_;
};

// Decoding side: reads and validates the same fields in the same order.
class Reader {
 public:
  static constexpr bool kDecoding = true;

  Reader(MessageType type, std::span<const uint8_t> in)
      : type_(type), in_(in) {}

  void U8(uint8_t& value, std::string_view) {
    value = static_cast<uint8_t>(GetLittleEndian(1));
  }

  void U8InRange(uint8_t& value, std::string_view field, uint8_t min,
                 uint8_t max) {
    U8(value, field);
    if (value < min || value > max) {
      FailField(type_, field, "{} out of range {}..{}", value, min, max);
    }
  }

  void ModuleId(uint8_t& value, std::string_view field) {
    U8InRange(value, field, 0, kMaxModuleId);
  }

  template <class E>
  void Enum(E& value, std::string_view field, E max) {
    uint8_t raw = 0;
    U8InRange(raw, field, 0, static_cast<uint8_t>(max));
    value = static_cast<E>(raw);
  }

  void AccelerometerCount(int16_t& value, std::size_t index, char axis) {
    value = static_cast<int16_t>(GetLittleEndian(2));
    Writer::CheckAccelerometerCount(type_, value, index, axis);
  }

  void Float32(float& value, std::string_view field) {
    value = std::bit_cast<float>(static_cast<uint32_t>(GetLittleEndian(4)));
    if (!std::isfinite(value)) FailField(type_, field, "is not finite: {}", value);
  }

  void Float64(double& value, std::string_view field) {
    value = std::bit_cast<double>(GetLittleEndian(8));
    if (!std::isfinite(value)) FailField(type_, field, "is not finite: {}", value);
  }

  void AckedType(MessageType& value, std::string_view field,
                 MessageClass required) {
    uint8_t code = 0;
    U8(code, field);
    Writer::CheckAckedType(type_, code, field, required);
    value = static_cast<MessageType>(code);
  }

  void Status(StatusCode& value, std::string_view field, bool allow_ok) {
    uint8_t raw = 0;
    U8InRange(raw, field, allow_ok ? 0 : 1, kMaxStatusCode);
    value = static_cast<StatusCode>(raw);
  }

  void U32(uint32_t& value, std::string_view) {
    value = static_cast<uint32_t>(GetLittleEndian(4));
  }

  void Bool(bool& value, std::string_view field) {
    uint8_t raw = 0;
    U8InRange(raw, field, 0, 1);
    value = raw != 0;
  }

  // The rest of the payload (the size rule bounds it).
  void Bytes(std::vector<uint8_t>& value, std::string_view, std::size_t) {
    const std::span<const uint8_t> rest = in_.subspan(pos_);
    value.assign(rest.begin(), rest.end());
    pos_ = in_.size();
  }

  void Text(std::string& value, std::string_view field,
            std::size_t = kMaxErrorTextSize) {
    const std::span<const uint8_t> rest = in_.subspan(pos_);
    Writer::CheckPrintable(type_, field, rest);
    value.assign(rest.begin(), rest.end());
    pos_ = in_.size();
  }

  uint32_t RawU32() { return static_cast<uint32_t>(GetLittleEndian(4)); }
  uint64_t RawU64() { return GetLittleEndian(8); }
  std::size_t remaining() const { return in_.size() - pos_; }
  MessageType type() const { return type_; }

 private:
  uint64_t GetLittleEndian(int size) {
    // The payload size rule was checked first, so a short read is a codec bug.
    YAMOR_CHECK(remaining() >= static_cast<std::size_t>(size),
                "SNP field read past the payload end");
    uint64_t bits = 0;
    for (int i = 0; i < size; ++i) {
      bits |= static_cast<uint64_t>(in_[pos_ + i]) << (8 * i);
    }
    pos_ += static_cast<std::size_t>(size);
    return bits;
  }

  MessageType type_;
  std::span<const uint8_t> in_;
  std::size_t pos_ = 0;
};

// ---- Field lists: one function per message, shared by Writer and Reader ----

template <class Io, Is<ConnectRequest> M>
void Serialize(Io& io, M& m) { io.ModuleId(m.child, "child"); }

template <class Io, Is<ConnectAck> M>
void Serialize(Io& io, M& m) {
  io.ModuleId(m.child, "child");
  io.Enum(m.status, "status", LinkStatus::kFailed);
}

template <class Io, Is<Control> M>
void Serialize(Io& io, M& m) {
  // Three 2-bit tristates in one byte: UART bits 0-1, CPG 2-3, motors 4-5.
  if constexpr (Io::kDecoding) {
    uint8_t packed = 0;
    io.U8(packed, "flags");
    if ((packed & kControlReservedBits) != 0) {
      FailField(io.type(), "flags", "has reserved bits set: 0x{:02x}", packed);
    }
    Tristate* fields[] = {&m.uart, &m.cpg, &m.motors};
    const char* names[] = {"uart", "cpg", "motors"};
    for (int i = 0; i < 3; ++i) {
      const uint8_t value = (packed >> (kTristateBits * i)) & kTristateMask;
      if (value > static_cast<uint8_t>(Tristate::kOff)) {
        FailField(io.type(), names[i], "has invalid tristate value {}", value);
      }
      *fields[i] = static_cast<Tristate>(value);
    }
  } else {
    const Tristate fields[] = {m.uart, m.cpg, m.motors};
    const char* names[] = {"uart", "cpg", "motors"};
    uint8_t packed = 0;
    for (int i = 0; i < 3; ++i) {
      const auto value = static_cast<uint8_t>(fields[i]);
      if (value > static_cast<uint8_t>(Tristate::kOff)) {
        FailField(io.type(), names[i], "has invalid tristate value {}", value);
      }
      packed = static_cast<uint8_t>(packed | (value << (kTristateBits * i)));
    }
    io.U8(packed, "flags");
  }
}

template <class Io, Is<SetOscillator> M>
void Serialize(Io& io, M& m) {
  // A field mask, then all three floats; absent ones are sent as 0 bytes so
  // every message has one canonical encoding.
  using Field = std::conditional_t<Io::kDecoding, std::optional<float>,
                                   const std::optional<float>>;
  Field* values[] = {&m.amplitude, &m.offset, &m.speed};
  const char* names[] = {"amplitude", "offset", "speed"};
  const uint8_t bits[] = {kOscillatorAmplitudeBit, kOscillatorOffsetBit,
                          kOscillatorSpeedBit};
  if constexpr (Io::kDecoding) {
    uint8_t mask = 0;
    io.U8(mask, "mask");
    if ((mask & kOscillatorReservedBits) != 0) {
      FailField(io.type(), "mask", "has reserved bits set: 0x{:02x}", mask);
    }
    if (mask == 0) FailField(io.type(), "mask", "sets no field");
    for (int i = 0; i < 3; ++i) {
      if ((mask & bits[i]) != 0) {
        float value = 0.0f;
        io.Float32(value, names[i]);
        *values[i] = value;
      } else {
        if (io.RawU32() != 0) {
          FailField(io.type(), names[i], "is absent but its bytes are not zero");
        }
        values[i]->reset();
      }
    }
  } else {
    uint8_t mask = 0;
    for (int i = 0; i < 3; ++i) {
      if (values[i]->has_value()) mask = static_cast<uint8_t>(mask | bits[i]);
    }
    if (mask == 0) FailField(io.type(), "mask", "sets no field");
    io.U8(mask, "mask");
    for (int i = 0; i < 3; ++i) {
      io.Float32(values[i]->value_or(0.0f), names[i]);
    }
  }
}

template <class Io, Is<SetLimits> M>
void Serialize(Io& io, M& m) {
  io.Float32(m.min_angle, "min_angle");
  io.Float32(m.max_angle, "max_angle");
}

template <class Io, Is<SetCoupling> M>
void Serialize(Io& io, M& m) {
  io.ModuleId(m.to, "to");
  io.Float32(m.phase, "phase");
  io.Float32(m.weight, "weight");
}

template <class Io, Is<ServoAngle> M>
void Serialize(Io& io, M& m) { io.Float32(m.angle, "angle"); }

template <class Io, Is<ReadAccelerometer> M>
void Serialize(Io& io, M& m) {
  io.U8InRange(m.sample_count, "sample_count", 1,
               static_cast<uint8_t>(kMaxAccelerometerSamples));
}

template <class Io, Is<Accelerometer> M>
void Serialize(Io& io, M& m) {
  // No count byte: the frame length gives the number of 6-byte samples.
  std::size_t count = m.samples.size();
  if constexpr (Io::kDecoding) {
    count = io.remaining() / 6;
    m.samples.resize(count);
  } else if (count < 1 || count > kMaxAccelerometerSamples) {
    FailField(io.type(), "samples", "has {} samples, expects 1..{}", count,
              kMaxAccelerometerSamples);
  }
  for (std::size_t i = 0; i < count; ++i) {
    auto& sample = m.samples[i];
    io.AccelerometerCount(sample.x, i, 'x');
    io.AccelerometerCount(sample.y, i, 'y');
    io.AccelerometerCount(sample.z, i, 'z');
  }
}

template <class Io, Is<Ack> M>
void Serialize(Io& io, M& m) {
  io.AckedType(m.acked, "acked", MessageClass::kModule);
  io.Status(m.status, "status", /*allow_ok=*/true);
}

template <class Io, Is<Step> M>
void Serialize(Io& io, M& m) { io.Float64(m.duration, "duration"); }

template <class Io, Is<SetTimer> M>
void Serialize(Io& io, M& m) {
  io.U8(m.timer_id, "timer_id");
  io.Float64(m.delay, "delay");
}

template <class Io, Is<SetMasterNode> M>
void Serialize(Io& io, M& m) { io.ModuleId(m.module, "module"); }

template <class Io, Is<ConnectModules> M>
void Serialize(Io& io, M& m) {
  io.ModuleId(m.from, "from");
  io.Enum(m.from_connector, "from_connector", Connector::kBottom);
  io.ModuleId(m.to, "to");
  io.Enum(m.to_connector, "to_connector", Connector::kBottom);
  io.U8InRange(m.angle_index, "angle_index", 0, kMaxAngleIndex);
}

template <class Io, Is<DisconnectModule> M>
void Serialize(Io& io, M& m) { io.ModuleId(m.module, "module"); }

template <class Io, Is<SimTime> M>
void Serialize(Io& io, M& m) { io.Float64(m.seconds, "seconds"); }

template <class Io, Is<StepDone> M>
void Serialize(Io& io, M& m) { io.Float64(m.time, "time"); }

template <class Io, Is<TimerFired> M>
void Serialize(Io& io, M& m) {
  io.U8(m.timer_id, "timer_id");
  io.Float64(m.time, "time");
}

template <class Io, Is<RobotPosition> M>
void Serialize(Io& io, M& m) {
  io.Float64(m.time, "time");
  io.Float64(m.position[0], "position.x");
  io.Float64(m.position[1], "position.y");
  io.Float64(m.position[2], "position.z");
  io.Float64(m.orientation[0], "orientation.w");
  io.Float64(m.orientation[1], "orientation.x");
  io.Float64(m.orientation[2], "orientation.y");
  io.Float64(m.orientation[3], "orientation.z");
}

template <class Io, Is<SpecialAck> M>
void Serialize(Io& io, M& m) {
  io.AckedType(m.acked, "acked", MessageClass::kBridgeCommand);
}

template <class Io, Is<SpecialError> M>
void Serialize(Io& io, M& m) {
  io.AckedType(m.acked, "acked", MessageClass::kBridgeCommand);
  io.Status(m.code, "code", /*allow_ok=*/false);
  io.Text(m.text, "text");
}

template <class Io, Is<SetGround> M>
void Serialize(Io& io, M& m) {
  // A field mask, then all three float64s; absent ones are 0 bytes. A zero
  // mask is a read-only request.
  using Field = std::conditional_t<Io::kDecoding, std::optional<double>,
                                   const std::optional<double>>;
  Field* values[] = {&m.friction, &m.slope, &m.slope_direction};
  const char* names[] = {"friction", "slope", "slope_direction"};
  if constexpr (Io::kDecoding) {
    uint8_t mask = 0;
    io.U8(mask, "mask");
    if ((mask & kGroundReservedBits) != 0) {
      FailField(io.type(), "mask", "has reserved bits set: 0x{:02x}", mask);
    }
    for (int i = 0; i < 3; ++i) {
      if ((mask & (1u << i)) != 0) {
        double value = 0.0;
        io.Float64(value, names[i]);
        *values[i] = value;
      } else {
        if (io.RawU64() != 0) {
          FailField(io.type(), names[i], "is absent but its bytes are not zero");
        }
        values[i]->reset();
      }
    }
  } else {
    uint8_t mask = 0;
    for (int i = 0; i < 3; ++i) {
      if (values[i]->has_value()) mask = static_cast<uint8_t>(mask | (1u << i));
    }
    io.U8(mask, "mask");
    for (int i = 0; i < 3; ++i) io.Float64(values[i]->value_or(0.0), names[i]);
  }
}

template <class Io, Is<SetMotorFault> M>
void Serialize(Io& io, M& m) {
  io.ModuleId(m.module, "module");
  io.Enum(m.fault, "fault", MotorFault::kStuck);
}

template <class Io, Is<SetModuleDefect> M>
void Serialize(Io& io, M& m) {
  io.ModuleId(m.module, "module");
  io.Bool(m.defective, "defective");
}

template <class Io, Is<ReadMorphology> M>
void Serialize(Io& io, M& m) {
  io.U32(m.offset, "offset");
  io.U8InRange(m.length, "length", 1, static_cast<uint8_t>(kMaxMorphologyChunkSize));
}

template <class Io, Is<ReadScene> M>
void Serialize(Io& io, M& m) {
  io.U32(m.offset, "offset");
  io.U8InRange(m.length, "length", 1, static_cast<uint8_t>(kMaxSceneChunkSize));
}

template <class Io, Is<Ground> M>
void Serialize(Io& io, M& m) {
  io.Float64(m.friction, "friction");
  io.Float64(m.slope, "slope");
  io.Float64(m.slope_direction, "slope_direction");
}

template <class Io, Is<Divergence> M>
void Serialize(Io& io, M& m) {
  io.Bool(m.diverged, "diverged");
  io.U8(m.module, "module");  // 0..254, or kNoModule
  io.Float64(m.time, "time");
  io.Text(m.reason, "reason", kMaxDivergenceTextSize);
}

template <class Io, Is<MorphologyChunk> M>
void Serialize(Io& io, M& m) {
  io.U32(m.total, "total");
  io.U32(m.offset, "offset");
  io.Bytes(m.data, "data", kMaxMorphologyChunkSize);
  if (static_cast<uint64_t>(m.offset) + m.data.size() > m.total) {
    FailField(io.type(), "data", "ends at {}, past the total of {} bytes",
              static_cast<uint64_t>(m.offset) + m.data.size(), m.total);
  }
}

template <class Io, Is<SceneChunk> M>
void Serialize(Io& io, M& m) {
  io.U32(m.total, "total");
  io.U32(m.offset, "offset");
  io.Bytes(m.data, "data", kMaxSceneChunkSize);
  if (static_cast<uint64_t>(m.offset) + m.data.size() > m.total) {
    FailField(io.type(), "data", "ends at {}, past the total of {} bytes",
              static_cast<uint64_t>(m.offset) + m.data.size(), m.total);
  }
}

template <class Io, Is<SimInfo> M>
void Serialize(Io& io, M& m) {
  io.Float64(m.time_step, "time_step");
  io.Float64(m.accelerometer_zero, "accelerometer_zero");
  io.Float64(m.accelerometer_count, "accelerometer_count");
}

// Messages without fields.
template <class Io, class M>
  requires(Is<M, ClearCouplings> || Is<M, ReadServoAngle> ||
           Is<M, GetSimTime> || Is<M, GetRobotPosition> ||
           Is<M, ResetSimulation> || Is<M, TurnUpsideDown> ||
           Is<M, GetDivergence> || Is<M, GetSimInfo>)
void Serialize(Io&, M&) {}

template <std::size_t I = 0>
Message DecodeAlternative(Reader& reader) {
  if constexpr (I == std::variant_size_v<Message>) {
    throw Error(StatusCode::kInternal,
                fmt::format("no message struct for type 0x{:02x}",
                            static_cast<uint8_t>(reader.type())));
  } else {
    using T = std::variant_alternative_t<I, Message>;
    if (T::kType != reader.type()) return DecodeAlternative<I + 1>(reader);
    T message;
    Serialize(reader, message);
    YAMOR_CHECK(reader.remaining() == 0,
                "SNP payload bytes left after the last field");
    return Message(std::in_place_index<I>, std::move(message));
  }
}

}  // namespace

std::string_view ConnectorName(Connector connector) {
  switch (connector) {
    case Connector::kFront: return "front";
    case Connector::kRear: return "rear";
    case Connector::kLeft: return "left";
    case Connector::kRight: return "right";
    case Connector::kTop: return "top";
    case Connector::kBottom: return "bottom";
  }
  return "unknown";
}

MessageType TypeOf(const Message& message) {
  return std::visit([](const auto& m) { return m.kType; }, message);
}

Payload EncodePayload(const Message& message) {
  Writer writer(TypeOf(message));
  std::visit([&writer](const auto& m) { Serialize(writer, m); }, message);
  return writer.payload();
}

Message DecodePayload(MessageType type, std::span<const uint8_t> payload) {
  const auto code = static_cast<uint8_t>(type);
  if (!IsKnownMessageType(code)) {
    throw Error(StatusCode::kInvalidArgument,
                fmt::format("unknown message type 0x{:02x}", code));
  }
  const PayloadSizeRule rule = PayloadSizeRuleOf(type);
  if (!rule.Allows(payload.size())) {
    internal::ReasonText reason;
    internal::FormatSizeRule(rule, payload.size(), MessageTypeName(type), reason);
    throw Error(StatusCode::kInvalidArgument, std::string(reason.view()));
  }
  Reader reader(type, payload);
  return DecodeAlternative(reader);
}

Frame MakeFrame(Address source, Address destination, const Message& message) {
  Frame frame{source, destination, TypeOf(message), EncodePayload(message)};
  ValidateFrame(frame);
  return frame;
}

Message DecodeMessage(const Frame& frame) {
  ValidateFrame(frame);
  return DecodePayload(frame.type, frame.payload.bytes());
}

}  // namespace yamor::snp
