// Typed SNP messages: one struct per MessageType, the Message variant, and
// conversion between messages, payload bytes and frames. Numbers are
// little-endian; module parameters are IEEE-754 float32 (what the module
// firmware computes with), simulation quantities float64. docs/snp.md has
// every payload layout.
//
// Thread-safety: all functions are pure and safe from any thread; the
// message structs are plain values without internal synchronisation.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "common/status.h"
#include "proto/snp/frame.h"
#include "proto/snp/message_type.h"

namespace yamor::snp {

/// A control flag setting: leave as is, switch on, switch off.
enum class Tristate : uint8_t {
  kUnchanged = 0,  ///< Keep the current state.
  kOn = 1,         ///< Switch on.
  kOff = 2,        ///< Switch off.
};

/// Result of a bluetooth link attempt.
enum class LinkStatus : uint8_t {
  kUp = 0,      ///< The link to the child is established.
  kFailed = 1,  ///< The child could not be reached.
};

/// A module connector (where another module's handle screws in).
enum class Connector : uint8_t {
  kFront = 0,   ///< Front face.
  kRear = 1,    ///< Rear face.
  kLeft = 2,    ///< Left face.
  kRight = 3,   ///< Right face.
  kTop = 4,     ///< Top face.
  kBottom = 5,  ///< Bottom face.
};

/// Largest connection angle index: angles are index * 15 degrees, 0..23.
inline constexpr uint8_t kMaxAngleIndex = 23;
/// Most accelerometer samples per request / reply.
inline constexpr std::size_t kMaxAccelerometerSamples = 16;
/// Largest raw accelerometer count (10-bit ADC).
inline constexpr int16_t kMaxAccelerometerCount = 1023;
/// Longest SpecialError text in bytes (payload minus type and code bytes).
inline constexpr std::size_t kMaxErrorTextSize = kMaxPayloadSize - 2;

/// A motor fault the simulation can inject (thesis C.2.6).
enum class MotorFault : uint8_t {
  kNone = 0,   ///< Repaired: the servo works.
  kLimp = 1,   ///< No torque.
  kStuck = 2,  ///< Locked at its angle.
};

/// Wire value of "no module" in Divergence.module.
inline constexpr uint8_t kNoModule = 255;
/// Longest Divergence reason in bytes.
inline constexpr std::size_t kMaxDivergenceTextSize = kMaxPayloadSize - 10;
/// Most morphology bytes one MorphologyChunk carries.
inline constexpr std::size_t kMaxMorphologyChunkSize = kMaxPayloadSize - 8;
/// Most scene snapshot bytes one SceneChunk carries.
inline constexpr std::size_t kMaxSceneChunkSize = kMaxPayloadSize - 8;

/// "front", "rear", "left", "right", "top", "bottom" ("unknown" otherwise).
std::string_view ConnectorName(Connector connector);

// ---- Module messages --------------------------------------------------------

/// Sent to a parent module: open a bluetooth link to module `child`.
struct ConnectRequest {
  static constexpr MessageType kType = MessageType::kConnectRequest;  ///< Type code.
  uint8_t child = 0;  ///< Module id to link to (0..254).
  friend bool operator==(const ConnectRequest&, const ConnectRequest&) = default;
};

/// From a parent module: the link to `child` is up or failed.
struct ConnectAck {
  static constexpr MessageType kType = MessageType::kConnectAck;  ///< Type code.
  uint8_t child = 0;                     ///< Module id of the child (0..254).
  LinkStatus status = LinkStatus::kUp;   ///< Outcome.
  friend bool operator==(const ConnectAck&, const ConnectAck&) = default;
};

/// Switches the module's UART, CPG and motors on or off (or leaves them).
struct Control {
  static constexpr MessageType kType = MessageType::kControl;  ///< Type code.
  Tristate uart = Tristate::kUnchanged;    ///< Serial line to the sensor board.
  Tristate cpg = Tristate::kUnchanged;     ///< Oscillator integration.
  Tristate motors = Tristate::kUnchanged;  ///< Servo power.
  friend bool operator==(const Control&, const Control&) = default;
};

/// Sets some of the oscillator parameters; absent fields are left as is.
/// At least one field must be present; present values must be finite.
struct SetOscillator {
  static constexpr MessageType kType = MessageType::kSetOscillator;  ///< Type code.
  std::optional<float> amplitude;  ///< Target amplitude [rad].
  std::optional<float> offset;     ///< Target offset [rad].
  std::optional<float> speed;      ///< Frequency [Hz].
  friend bool operator==(const SetOscillator&, const SetOscillator&) = default;
};

/// Sets the servo set-point limits (finite; the module checks min < max).
struct SetLimits {
  static constexpr MessageType kType = MessageType::kSetLimits;  ///< Type code.
  float min_angle = 0.0f;  ///< Lower limit [rad].
  float max_angle = 0.0f;  ///< Upper limit [rad].
  friend bool operator==(const SetLimits&, const SetLimits&) = default;
};

/// Adds or replaces the coupling from the receiving module to `to`.
struct SetCoupling {
  static constexpr MessageType kType = MessageType::kSetCoupling;  ///< Type code.
  uint8_t to = 0;       ///< Module whose oscillator drives this one (0..254).
  float phase = 0.0f;   ///< Phase bias [rad].
  float weight = 0.0f;  ///< Coupling weight.
  friend bool operator==(const SetCoupling&, const SetCoupling&) = default;
};

/// Removes every coupling of the receiving module.
struct ClearCouplings {
  static constexpr MessageType kType = MessageType::kClearCouplings;  ///< Type code.
  friend bool operator==(const ClearCouplings&, const ClearCouplings&) = default;
};

/// Asks the module for its servo angle (answered with ServoAngle).
struct ReadServoAngle {
  static constexpr MessageType kType = MessageType::kReadServoAngle;  ///< Type code.
  friend bool operator==(const ReadServoAngle&, const ReadServoAngle&) = default;
};

/// The servo angle of the sending module.
struct ServoAngle {
  static constexpr MessageType kType = MessageType::kServoAngle;  ///< Type code.
  float angle = 0.0f;  ///< Measured angle [rad].
  friend bool operator==(const ServoAngle&, const ServoAngle&) = default;
};

/// Asks for `sample_count` accelerometer samples (answered with Accelerometer).
struct ReadAccelerometer {
  static constexpr MessageType kType = MessageType::kReadAccelerometer;  ///< Type code.
  uint8_t sample_count = 1;  ///< Samples wanted (1..16).
  friend bool operator==(const ReadAccelerometer&, const ReadAccelerometer&) = default;
};

/// One raw accelerometer sample: 10-bit ADC counts (0..1023, ~512 at 0 g).
struct AccelerometerSample {
  int16_t x = 0;  ///< X axis count.
  int16_t y = 0;  ///< Y axis count.
  int16_t z = 0;  ///< Z axis count.
  friend bool operator==(const AccelerometerSample&, const AccelerometerSample&) = default;
};

/// Raw accelerometer samples, oldest first (1..16 samples).
struct Accelerometer {
  static constexpr MessageType kType = MessageType::kAccelerometer;  ///< Type code.
  std::vector<AccelerometerSample> samples;  ///< The samples.
  friend bool operator==(const Accelerometer&, const Accelerometer&) = default;
};

/// A module's answer to a module message: applied (kOk) or refused with a
/// canonical code (e.g. kOutOfRange for min_angle >= max_angle).
struct Ack {
  static constexpr MessageType kType = MessageType::kAck;  ///< Type code.
  MessageType acked = MessageType::kControl;  ///< The answered module message type.
  StatusCode status = StatusCode::kOk;        ///< Outcome (any canonical code).
  friend bool operator==(const Ack&, const Ack&) = default;
};

// ---- Bridge commands (host -> bridge) ---------------------------------------

/// Asks for the simulated time (answered with SimTime).
struct GetSimTime {
  static constexpr MessageType kType = MessageType::kGetSimTime;  ///< Type code.
  friend bool operator==(const GetSimTime&, const GetSimTime&) = default;
};

/// Advances the simulation by `duration` (answered with StepDone).
struct Step {
  static constexpr MessageType kType = MessageType::kStep;  ///< Type code.
  double duration = 0.0;  ///< Simulated seconds (finite).
  friend bool operator==(const Step&, const Step&) = default;
};

/// Arms timer `timer_id` to fire `delay` simulated seconds from now
/// (answered with SpecialAck, later TimerFired).
struct SetTimer {
  static constexpr MessageType kType = MessageType::kSetTimer;  ///< Type code.
  uint8_t timer_id = 0;  ///< Caller-chosen id echoed in TimerFired.
  double delay = 0.0;    ///< Simulated seconds (finite).
  friend bool operator==(const SetTimer&, const SetTimer&) = default;
};

/// Asks for the central module's pose (answered with RobotPosition).
struct GetRobotPosition {
  static constexpr MessageType kType = MessageType::kGetRobotPosition;  ///< Type code.
  friend bool operator==(const GetRobotPosition&, const GetRobotPosition&) = default;
};

/// Makes `module` the master node (the one linked to the host).
struct SetMasterNode {
  static constexpr MessageType kType = MessageType::kSetMasterNode;  ///< Type code.
  uint8_t module = 0;  ///< Module id (0..254).
  friend bool operator==(const SetMasterNode&, const SetMasterNode&) = default;
};

/// Attaches connector `from_connector` of module `from` to connector
/// `to_connector` of module `to`, rotated by angle_index * 15 degrees about
/// the connection axis.
struct ConnectModules {
  static constexpr MessageType kType = MessageType::kConnectModules;  ///< Type code.
  uint8_t from = 0;                             ///< First module id (0..254).
  Connector from_connector = Connector::kFront; ///< Connector on `from`.
  uint8_t to = 0;                               ///< Second module id (0..254).
  Connector to_connector = Connector::kFront;   ///< Connector on `to`.
  uint8_t angle_index = 0;                      ///< Rotation / 15 degrees (0..23).
  friend bool operator==(const ConnectModules&, const ConnectModules&) = default;
};

/// Detaches `module` from every neighbour.
struct DisconnectModule {
  static constexpr MessageType kType = MessageType::kDisconnectModule;  ///< Type code.
  uint8_t module = 0;  ///< Module id (0..254).
  friend bool operator==(const DisconnectModule&, const DisconnectModule&) = default;
};

/// Restores the world as it was loaded (time 0).
struct ResetSimulation {
  static constexpr MessageType kType = MessageType::kResetSimulation;  ///< Type code.
  friend bool operator==(const ResetSimulation&, const ResetSimulation&) = default;
};

/// Changes the ground; absent fields keep their value (all absent: read
/// only). Answered with Ground.
struct SetGround {
  static constexpr MessageType kType = MessageType::kSetGround;  ///< Type code.
  std::optional<double> friction;         ///< Coulomb coefficient.
  std::optional<double> slope;            ///< Tilt [rad].
  std::optional<double> slope_direction;  ///< Downhill azimuth [rad].
  friend bool operator==(const SetGround&, const SetGround&) = default;
};

/// Sets (or repairs) the motor fault of `module`.
struct SetMotorFault {
  static constexpr MessageType kType = MessageType::kSetMotorFault;  ///< Type code.
  uint8_t module = 0;                  ///< Module id (0..254).
  MotorFault fault = MotorFault::kNone;  ///< The fault.
  friend bool operator==(const SetMotorFault&, const SetMotorFault&) = default;
};

/// Marks `module` defective (oscillator dead, motor limp) or repaired.
struct SetModuleDefect {
  static constexpr MessageType kType = MessageType::kSetModuleDefect;  ///< Type code.
  uint8_t module = 0;      ///< Module id (0..254).
  bool defective = false;  ///< Defective or repaired.
  friend bool operator==(const SetModuleDefect&, const SetModuleDefect&) = default;
};

/// Turns the robot upside down about its central module, at rest.
struct TurnUpsideDown {
  static constexpr MessageType kType = MessageType::kTurnUpsideDown;  ///< Type code.
  friend bool operator==(const TurnUpsideDown&, const TurnUpsideDown&) = default;
};

/// Asks for the divergence state (answered with Divergence).
struct GetDivergence {
  static constexpr MessageType kType = MessageType::kGetDivergence;  ///< Type code.
  friend bool operator==(const GetDivergence&, const GetDivergence&) = default;
};

/// Asks for `length` bytes of the current morphology XML from `offset`
/// (offset 0 takes a new snapshot). Answered with MorphologyChunk.
struct ReadMorphology {
  static constexpr MessageType kType = MessageType::kReadMorphology;  ///< Type code.
  uint32_t offset = 0;  ///< First byte wanted.
  uint8_t length = 0;   ///< Bytes wanted (1..232).
  friend bool operator==(const ReadMorphology&, const ReadMorphology&) = default;
};

/// Asks for the simulation's fixed facts (answered with SimInfo).
struct GetSimInfo {
  static constexpr MessageType kType = MessageType::kGetSimInfo;  ///< Type code.
  friend bool operator==(const GetSimInfo&, const GetSimInfo&) = default;
};

/// Asks for `length` bytes of the scene snapshot (proto/snp/scene.h) from
/// `offset` (offset 0 takes a new snapshot). Answered with SceneChunk.
struct ReadScene {
  static constexpr MessageType kType = MessageType::kReadScene;  ///< Type code.
  uint32_t offset = 0;  ///< First byte wanted.
  uint8_t length = 0;   ///< Bytes wanted (1..232).
  friend bool operator==(const ReadScene&, const ReadScene&) = default;
};

// ---- Bridge replies (bridge -> host) ----------------------------------------

/// The simulated time.
struct SimTime {
  static constexpr MessageType kType = MessageType::kSimTime;  ///< Type code.
  double seconds = 0.0;  ///< Simulated seconds since reset (finite).
  friend bool operator==(const SimTime&, const SimTime&) = default;
};

/// A Step finished.
struct StepDone {
  static constexpr MessageType kType = MessageType::kStepDone;  ///< Type code.
  double time = 0.0;  ///< Simulated time after the step [s] (finite).
  friend bool operator==(const StepDone&, const StepDone&) = default;
};

/// Timer `timer_id` fired.
struct TimerFired {
  static constexpr MessageType kType = MessageType::kTimerFired;  ///< Type code.
  uint8_t timer_id = 0;  ///< Id given to SetTimer.
  double time = 0.0;     ///< Simulated time of firing [s] (finite).
  friend bool operator==(const TimerFired&, const TimerFired&) = default;
};

/// Pose of the central module at simulated `time`.
struct RobotPosition {
  static constexpr MessageType kType = MessageType::kRobotPosition;  ///< Type code.
  double time = 0.0;                           ///< Simulated time [s].
  std::array<double, 3> position{};            ///< x, y, z [m].
  std::array<double, 4> orientation{1, 0, 0, 0};  ///< Quaternion w, x, y, z.
  friend bool operator==(const RobotPosition&, const RobotPosition&) = default;
};

/// A bridge command succeeded (for commands without a specific reply).
struct SpecialAck {
  static constexpr MessageType kType = MessageType::kSpecialAck;  ///< Type code.
  MessageType acked = MessageType::kResetSimulation;  ///< The bridge command.
  friend bool operator==(const SpecialAck&, const SpecialAck&) = default;
};

/// A bridge command failed.
struct SpecialError {
  static constexpr MessageType kType = MessageType::kSpecialError;  ///< Type code.
  MessageType acked = MessageType::kResetSimulation;  ///< The bridge command.
  StatusCode code = StatusCode::kUnknown;  ///< Canonical code (never kOk).
  std::string text;  ///< Printable ASCII, at most kMaxErrorTextSize bytes.
  friend bool operator==(const SpecialError&, const SpecialError&) = default;
};

/// The ground as it is now.
struct Ground {
  static constexpr MessageType kType = MessageType::kGround;  ///< Type code.
  double friction = 0.0;         ///< Coulomb coefficient.
  double slope = 0.0;            ///< Tilt [rad].
  double slope_direction = 0.0;  ///< Downhill azimuth [rad].
  friend bool operator==(const Ground&, const Ground&) = default;
};

/// Whether the world diverged, and why.
struct Divergence {
  static constexpr MessageType kType = MessageType::kDivergence;  ///< Type code.
  bool diverged = false;        ///< The world is diverged now.
  uint8_t module = kNoModule;   ///< A module of the offending body, or kNoModule.
  double time = 0.0;            ///< Simulated time of the divergence [s].
  std::string reason;           ///< Printable ASCII, at most kMaxDivergenceTextSize.
  friend bool operator==(const Divergence&, const Divergence&) = default;
};

/// A chunk of the morphology XML snapshot (docs/module.md format).
struct MorphologyChunk {
  static constexpr MessageType kType = MessageType::kMorphologyChunk;  ///< Type code.
  uint32_t total = 0;          ///< Size of the whole XML text [bytes].
  uint32_t offset = 0;         ///< Position of `data` in it.
  std::vector<uint8_t> data;   ///< The bytes (offset + size <= total).
  friend bool operator==(const MorphologyChunk&, const MorphologyChunk&) = default;
};

/// The simulation's fixed facts.
struct SimInfo {
  static constexpr MessageType kType = MessageType::kSimInfo;  ///< Type code.
  double time_step = 0.0;             ///< Physics step [s].
  double accelerometer_zero = 0.0;    ///< ADC count at 0 m/s².
  double accelerometer_count = 0.0;   ///< m/s² per ADC count.
  friend bool operator==(const SimInfo&, const SimInfo&) = default;
};

/// A chunk of the scene snapshot (the bytes of EncodeSceneSnapshot).
struct SceneChunk {
  static constexpr MessageType kType = MessageType::kSceneChunk;  ///< Type code.
  uint32_t total = 0;          ///< Size of the whole snapshot [bytes].
  uint32_t offset = 0;         ///< Position of `data` in it.
  std::vector<uint8_t> data;   ///< The bytes (offset + size <= total).
  friend bool operator==(const SceneChunk&, const SceneChunk&) = default;
};

/// Any SNP message.
using Message =
    std::variant<ConnectRequest, ConnectAck, Control, SetOscillator, SetLimits,
                 SetCoupling, ClearCouplings, ReadServoAngle, ServoAngle,
                 ReadAccelerometer, Accelerometer, Ack, GetSimTime, Step,
                 SetTimer, GetRobotPosition, SetMasterNode, ConnectModules,
                 DisconnectModule, ResetSimulation, SetGround, SetMotorFault,
                 SetModuleDefect, TurnUpsideDown, GetDivergence,
                 ReadMorphology, GetSimInfo, SimTime, StepDone, TimerFired,
                 RobotPosition, SpecialAck, SpecialError, Ground, Divergence,
                 MorphologyChunk, SimInfo, ReadScene, SceneChunk>;

/// The type code of `message`.
MessageType TypeOf(const Message& message);

/// The payload bytes of `message`; throws yamor::Error(INVALID_ARGUMENT)
/// naming the field ("SetLimits.min_angle is not finite: nan") for values
/// the wire format cannot carry.
Payload EncodePayload(const Message& message);

/// Parses a payload of `type`; throws yamor::Error(INVALID_ARGUMENT) naming
/// the reason (unknown type, wrong size, non-finite float, value out of its
/// range, non-zero reserved bits or absent-field bytes). Accepted payloads
/// re-encode to the same bytes.
Message DecodePayload(MessageType type, std::span<const uint8_t> payload);

/// A frame carrying `message` from `source` to `destination`; throws
/// yamor::Error(INVALID_ARGUMENT) for bad values or endpoints that do not
/// fit the message class (see ValidateFrame).
Frame MakeFrame(Address source, Address destination, const Message& message);

/// The message in `frame`; throws yamor::Error(INVALID_ARGUMENT) with the
/// reason if the frame or its payload is invalid.
Message DecodeMessage(const Frame& frame);

}  // namespace yamor::snp
