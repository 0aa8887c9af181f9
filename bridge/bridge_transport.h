// The byte transports of `yamor-bridge`: a pseudo-terminal it creates (the
// host opens the slave side as it would a serial port) or a TCP listener
// (one host connection at a time). Optional pacing of outgoing bytes at a
// serial line's rate, and optional free-running simulated time.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "bridge/bridge_server.h"

namespace yamor::bridge {

/// The thesis's bridge port (5.4).
inline constexpr uint16_t kDefaultBridgePort = 2223;

/// How a BridgeTransport serves its BridgeServer.
struct TransportOptions {
  enum class Kind { kPty, kTcp };
  Kind kind = Kind::kPty;
  /// Pty: a symlink made to the slave device (removed on exit), "" = none.
  std::string link;
  /// TCP: address to bind (a numeric IPv4/IPv6 address or "localhost").
  std::string tcp_host = "127.0.0.1";
  /// TCP: port to listen on; 0 = an ephemeral one (see Endpoint()).
  uint16_t tcp_port = kDefaultBridgePort;
  /// Pace outgoing bytes at `baud` as 8N1 (baud / 10 bytes per second,
  /// absolute deadlines from the start of each burst, so no drift).
  bool pace = false;
  /// Line rate in bit/s (used when `pace`).
  int baud = 115200;
  /// 0 = virtual time, advanced only by the host's Step commands; > 0 = the
  /// world also free-runs at this many simulated seconds per wall second.
  double real_time_factor = 0.0;
  /// Outgoing bytes held while the host does not read; more are dropped
  /// (a serial line does not buffer forever either).
  std::size_t max_pending_bytes = 1 << 20;
};

/// Parses `--tcp`'s "[HOST:]PORT" ("" = the default port on 127.0.0.1) into
/// `options`. Throws yamor::Error(INVALID_ARGUMENT) naming the bad part.
void ParseTcpEndpoint(const std::string& text, TransportOptions& options);

/// Counters of the transport.
struct TransportStats {
  uint64_t bytes_in = 0;       ///< Bytes read from the host.
  uint64_t bytes_out = 0;      ///< Bytes written to the host.
  uint64_t dropped_bytes = 0;  ///< Outgoing bytes dropped (pending limit, or no TCP host).
  uint64_t connections = 0;    ///< TCP connections accepted.
};

/// Serves one BridgeServer over a pty or TCP. The constructor opens the pty
/// (raw mode; keeps its own slave descriptor open so a host may close and
/// reopen the device) or binds the listener, so Endpoint() is known before
/// Run(). Asio, single-threaded: every handler runs on the thread in Run().
///
/// Thread-safety: Stop() may be called from any thread (and from a signal
/// handler's context via Run's own signal set); everything else from one
/// thread.
class BridgeTransport {
 public:
  /// Throws yamor::Error (UNAVAILABLE: pty or socket could not be set up,
  /// e.g. port in use; INVALID_ARGUMENT: bad options).
  BridgeTransport(BridgeServer& server, TransportOptions options);
  ~BridgeTransport();
  BridgeTransport(const BridgeTransport&) = delete;
  BridgeTransport& operator=(const BridgeTransport&) = delete;

  /// "pty /dev/pts/N" or "tcp 127.0.0.1:PORT" (the bound port).
  std::string Endpoint() const;
  /// The pty slave path ("" for TCP).
  std::string SlavePath() const;
  /// The bound TCP port (0 for a pty).
  uint16_t Port() const;

  /// Serves until Stop() or, when `stop_on_signals`, SIGTERM / SIGINT.
  /// Returns the signal number that stopped it, or 0.
  int Run(bool stop_on_signals);
  /// Makes Run return soon. Thread-safe.
  void Stop();

  /// A snapshot of the counters (call from Run's thread or after Run).
  TransportStats stats() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace yamor::bridge
