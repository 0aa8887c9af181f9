// SNP message types: the one-byte type codes, their classes (module message,
// bridge command, bridge reply) and the payload size rule of each type.
// The wire format is specified in docs/snp.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace yamor::snp {

/// The message type byte of a frame. Values not listed are unknown and are
/// rejected by every decoder.
enum class MessageType : uint8_t {
  // Module messages (0x01-0x3F): exchanged between the host and modules.
  kConnectRequest = 0x01,     ///< Host -> parent module: open a link to a child.
  kConnectAck = 0x02,         ///< Parent module -> host: child link up or failed.
  kControl = 0x03,            ///< UART / CPG / motor switches (tristate each).
  kSetOscillator = 0x04,      ///< Amplitude / offset / speed (masked).
  kSetLimits = 0x05,          ///< Servo set-point limit angles.
  kSetCoupling = 0x06,        ///< Add or replace one CPG coupling.
  kClearCouplings = 0x07,     ///< Remove every coupling of the module.
  kReadServoAngle = 0x08,     ///< Ask for the servo angle.
  kServoAngle = 0x09,         ///< Reply: the servo angle.
  kReadAccelerometer = 0x0A,  ///< Ask for N accelerometer samples.
  kAccelerometer = 0x0B,      ///< Reply: N raw accelerometer samples.
  kAck = 0x0C,                ///< Reply: a module message was applied or refused.
  // Bridge commands (0x40-0x5F): host -> simulation bridge only.
  kGetSimTime = 0x40,         ///< Ask for the simulated time.
  kStep = 0x41,               ///< Advance the simulation by a duration.
  kSetTimer = 0x42,           ///< Fire TimerFired after a delay.
  kGetRobotPosition = 0x43,   ///< Ask for the central module's pose.
  kSetMasterNode = 0x44,      ///< Choose the module linked to the host.
  kConnectModules = 0x45,     ///< Attach two modules at given connectors.
  kDisconnectModule = 0x46,   ///< Detach a module from all its neighbours.
  kResetSimulation = 0x47,    ///< Restore the initial world.
  kSetGround = 0x48,          ///< Change friction / slope (masked); answered by Ground.
  kSetMotorFault = 0x49,      ///< Make a motor limp, stuck or repaired.
  kSetModuleDefect = 0x4A,    ///< Mark a whole module defective or repaired.
  kTurnUpsideDown = 0x4B,     ///< Turn the robot upside down about its centre.
  kGetDivergence = 0x4C,      ///< Ask whether the world diverged (and why).
  kReadMorphology = 0x4D,     ///< Read a chunk of the current morphology XML.
  kGetSimInfo = 0x4E,         ///< Ask for the simulation's fixed facts.
  kReadScene = 0x4F,          ///< Read a chunk of the scene snapshot (for rendering).
  // Bridge replies (0x60-0x7F): simulation bridge -> host only.
  kSimTime = 0x60,            ///< Reply: simulated time.
  kStepDone = 0x61,           ///< Reply: a Step finished.
  kTimerFired = 0x62,         ///< Event: a SetTimer delay elapsed.
  kRobotPosition = 0x63,      ///< Reply: central module pose.
  kSpecialAck = 0x64,         ///< Reply: a bridge command succeeded.
  kSpecialError = 0x65,       ///< Reply: a bridge command failed (code + text).
  kGround = 0x66,             ///< Reply: ground friction and slope now.
  kDivergence = 0x67,         ///< Reply: divergence state.
  kMorphologyChunk = 0x68,    ///< Reply: a chunk of the morphology XML.
  kSimInfo = 0x69,            ///< Reply: time step and accelerometer scale.
  kSceneChunk = 0x6A,         ///< Reply: a chunk of the scene snapshot.
};

/// Who may send a message type to whom (enforced on encode and decode).
enum class MessageClass : uint8_t {
  kModule,         ///< Host/module <-> module/host/broadcast; never the bridge.
  kBridgeCommand,  ///< From the host to the bridge.
  kBridgeReply,    ///< From the bridge to the host.
};

/// Every known message type, in code order (for tests and tables).
inline constexpr MessageType kAllMessageTypes[] = {
    MessageType::kConnectRequest,   MessageType::kConnectAck,
    MessageType::kControl,          MessageType::kSetOscillator,
    MessageType::kSetLimits,        MessageType::kSetCoupling,
    MessageType::kClearCouplings,   MessageType::kReadServoAngle,
    MessageType::kServoAngle,       MessageType::kReadAccelerometer,
    MessageType::kAccelerometer,    MessageType::kAck,
    MessageType::kGetSimTime,       MessageType::kStep,
    MessageType::kSetTimer,         MessageType::kGetRobotPosition,
    MessageType::kSetMasterNode,    MessageType::kConnectModules,
    MessageType::kDisconnectModule, MessageType::kResetSimulation,
    MessageType::kSetGround,        MessageType::kSetMotorFault,
    MessageType::kSetModuleDefect,  MessageType::kTurnUpsideDown,
    MessageType::kGetDivergence,    MessageType::kReadMorphology,
    MessageType::kGetSimInfo,       MessageType::kReadScene,
    MessageType::kSimTime,          MessageType::kStepDone,
    MessageType::kTimerFired,       MessageType::kRobotPosition,
    MessageType::kSpecialAck,       MessageType::kSpecialError,
    MessageType::kGround,           MessageType::kDivergence,
    MessageType::kMorphologyChunk,  MessageType::kSimInfo,
    MessageType::kSceneChunk,
};

/// Allowed payload sizes of a type: min..max in steps of `step` bytes.
struct PayloadSizeRule {
  std::size_t min = 0;   ///< Smallest payload size.
  std::size_t max = 0;   ///< Largest payload size.
  std::size_t step = 1;  ///< Sizes are min + k*step.

  /// True when `size` is allowed by this rule.
  constexpr bool Allows(std::size_t size) const {
    return size >= min && size <= max && (size - min) % step == 0;
  }
};

/// True when `code` is a known message type.
bool IsKnownMessageType(uint8_t code);

/// The name of a type as used in docs and errors ("SetLimits"), or
/// "Unknown" for a value that is not a known type.
std::string_view MessageTypeName(MessageType type);

/// The class of a known type (undefined result for unknown types: check
/// IsKnownMessageType first).
MessageClass ClassOf(MessageType type);

/// The payload size rule of a known type ({0,0,1} for unknown types).
PayloadSizeRule PayloadSizeRuleOf(MessageType type);

}  // namespace yamor::snp
