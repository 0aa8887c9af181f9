#include "proto/snp/message_type.h"

namespace yamor::snp {

namespace {

struct TypeInfo {
  std::string_view name;
  MessageClass message_class;
  PayloadSizeRule size;
};

constexpr PayloadSizeRule Fixed(std::size_t size) { return {size, size, 1}; }

// The one table of per-type facts; docs/snp.md lists the same sizes.
const TypeInfo* Find(MessageType type) {
  using C = MessageClass;
  switch (type) {
#define YAMOR_SNP_TYPE(enumerator, cls, rule)       \
  case MessageType::enumerator: {                   \
    static constexpr TypeInfo kInfo{                \
        std::string_view(#enumerator).substr(1), cls, rule}; \
    return &kInfo;                                  \
  }
    YAMOR_SNP_TYPE(kConnectRequest, C::kModule, Fixed(1))
    YAMOR_SNP_TYPE(kConnectAck, C::kModule, Fixed(2))
    YAMOR_SNP_TYPE(kControl, C::kModule, Fixed(1))
    YAMOR_SNP_TYPE(kSetOscillator, C::kModule, Fixed(13))
    YAMOR_SNP_TYPE(kSetLimits, C::kModule, Fixed(8))
    YAMOR_SNP_TYPE(kSetCoupling, C::kModule, Fixed(9))
    YAMOR_SNP_TYPE(kClearCouplings, C::kModule, Fixed(0))
    YAMOR_SNP_TYPE(kReadServoAngle, C::kModule, Fixed(0))
    YAMOR_SNP_TYPE(kServoAngle, C::kModule, Fixed(4))
    YAMOR_SNP_TYPE(kReadAccelerometer, C::kModule, Fixed(1))
    YAMOR_SNP_TYPE(kAccelerometer, C::kModule, (PayloadSizeRule{6, 96, 6}))
    YAMOR_SNP_TYPE(kAck, C::kModule, Fixed(2))
    YAMOR_SNP_TYPE(kGetSimTime, C::kBridgeCommand, Fixed(0))
    YAMOR_SNP_TYPE(kStep, C::kBridgeCommand, Fixed(8))
    YAMOR_SNP_TYPE(kSetTimer, C::kBridgeCommand, Fixed(9))
    YAMOR_SNP_TYPE(kGetRobotPosition, C::kBridgeCommand, Fixed(0))
    YAMOR_SNP_TYPE(kSetMasterNode, C::kBridgeCommand, Fixed(1))
    YAMOR_SNP_TYPE(kConnectModules, C::kBridgeCommand, Fixed(5))
    YAMOR_SNP_TYPE(kDisconnectModule, C::kBridgeCommand, Fixed(1))
    YAMOR_SNP_TYPE(kResetSimulation, C::kBridgeCommand, Fixed(0))
    YAMOR_SNP_TYPE(kSetGround, C::kBridgeCommand, Fixed(25))
    YAMOR_SNP_TYPE(kSetMotorFault, C::kBridgeCommand, Fixed(2))
    YAMOR_SNP_TYPE(kSetModuleDefect, C::kBridgeCommand, Fixed(2))
    YAMOR_SNP_TYPE(kTurnUpsideDown, C::kBridgeCommand, Fixed(0))
    YAMOR_SNP_TYPE(kGetDivergence, C::kBridgeCommand, Fixed(0))
    YAMOR_SNP_TYPE(kReadMorphology, C::kBridgeCommand, Fixed(5))
    YAMOR_SNP_TYPE(kGetSimInfo, C::kBridgeCommand, Fixed(0))
    YAMOR_SNP_TYPE(kReadScene, C::kBridgeCommand, Fixed(5))
    YAMOR_SNP_TYPE(kSimTime, C::kBridgeReply, Fixed(8))
    YAMOR_SNP_TYPE(kStepDone, C::kBridgeReply, Fixed(8))
    YAMOR_SNP_TYPE(kTimerFired, C::kBridgeReply, Fixed(9))
    YAMOR_SNP_TYPE(kRobotPosition, C::kBridgeReply, Fixed(64))
    YAMOR_SNP_TYPE(kSpecialAck, C::kBridgeReply, Fixed(1))
    YAMOR_SNP_TYPE(kSpecialError, C::kBridgeReply, (PayloadSizeRule{2, 240, 1}))
    YAMOR_SNP_TYPE(kGround, C::kBridgeReply, Fixed(24))
    YAMOR_SNP_TYPE(kDivergence, C::kBridgeReply, (PayloadSizeRule{10, 240, 1}))
    YAMOR_SNP_TYPE(kMorphologyChunk, C::kBridgeReply, (PayloadSizeRule{8, 240, 1}))
    YAMOR_SNP_TYPE(kSimInfo, C::kBridgeReply, Fixed(24))
    YAMOR_SNP_TYPE(kSceneChunk, C::kBridgeReply, (PayloadSizeRule{8, 240, 1}))
#undef YAMOR_SNP_TYPE
  }
  return nullptr;
}

}  // namespace

bool IsKnownMessageType(uint8_t code) {
  return Find(static_cast<MessageType>(code)) != nullptr;
}

std::string_view MessageTypeName(MessageType type) {
  const TypeInfo* info = Find(type);
  return info ? info->name : std::string_view("Unknown");
}

MessageClass ClassOf(MessageType type) {
  const TypeInfo* info = Find(type);
  return info ? info->message_class : MessageClass::kModule;
}

PayloadSizeRule PayloadSizeRuleOf(MessageType type) {
  const TypeInfo* info = Find(type);
  return info ? info->size : PayloadSizeRule{0, 0, 1};
}

}  // namespace yamor::snp
