// Test helpers: sample and random SNP messages with fitting endpoints.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "proto/snp/snp.h"

namespace yamor::snp::testing {

/// A message with endpoints allowed for its class.
struct AddressedMessage {
  Address source;       ///< Sender.
  Address destination;  ///< Receiver.
  Message message;      ///< The message.
};

/// Hand-written messages covering every type (several for some types:
/// edge values, broadcast, partial SetOscillator, max-size payloads).
std::vector<AddressedMessage> SampleMessages();

/// A random valid message of a random type with fitting random endpoints.
AddressedMessage RandomMessage(std::mt19937_64& rng);

/// Wire bytes of an addressed message.
std::vector<uint8_t> EncodeMessage(const AddressedMessage& message);

}  // namespace yamor::snp::testing
