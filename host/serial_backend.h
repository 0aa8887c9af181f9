// The serial backend (issue 11 §2): SNP frames over a byte stream to a real
// robot's master node (a serial port or a bluetooth rfcomm device, thesis
// 5.5 and C.1) or to `yamor-bridge` (the slave side of the pty it created,
// or `yamor-bridge --tcp` as tcp://HOST:PORT). At open the backend says hello
// with the bridge special GetSimInfo: a SimInfo reply means a simulation
// (docs/snp.md, "The hello").
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "host/backend.h"
#include "proto/snp/messages.h"

namespace yamor::host {

/// Parity bit of a serial line.
enum class Parity {
  kNone,  ///< No parity bit.
  kOdd,   ///< Odd parity.
  kEven,  ///< Even parity.
};
/// Flow control of a serial line.
enum class FlowControl {
  kNone,      ///< None.
  kSoftware,  ///< XON/XOFF.
  kHardware,  ///< RTS/CTS.
};

/// "none" / "odd" / "even" -> Parity; INVALID_ARGUMENT naming the text otherwise.
Parity ParseParity(std::string_view text);
/// "none" / "software" / "hardware" -> FlowControl; INVALID_ARGUMENT otherwise.
FlowControl ParseFlowControl(std::string_view text);
/// The settings name of `parity` ("none", "odd", "even").
std::string_view ParityName(Parity parity);
/// The settings name of `flow` ("none", "software", "hardware").
std::string_view FlowControlName(FlowControl flow);
/// True when `baud` is a line rate the serial driver can set (50 .. 4000000,
/// the termios rates).
bool IsSupportedBaudRate(int baud);

/// Where and how a SerialBackend connects.
struct SerialOptions {
  /// A device path (/dev/ttyUSB0, /dev/rfcomm0, /dev/pts/N or a symlink to
  /// one) or tcp://HOST:PORT (IPv6 hosts in brackets).
  std::string device;
  int baud = 115200;                           ///< Line rate [bit/s] (ignored for TCP).
  int data_bits = 8;                           ///< 5..8 (ignored for TCP).
  Parity parity = Parity::kNone;               ///< Parity (ignored for TCP).
  int stop_bits = 1;                           ///< 1 or 2 (ignored for TCP).
  FlowControl flow_control = FlowControl::kNone;  ///< Flow control (ignored for TCP).
  /// Wait for the SimInfo answer to the hello [s]; silence = a real robot.
  double hello_timeout = 0.3;
  /// Longest TCP connect [s].
  double connect_timeout = 2.0;
  /// Longest wait for one frame to leave (a peer that never reads) [s].
  double write_timeout = 2.0;
  /// Frames kept for Receive; beyond this the oldest are dropped and counted.
  std::size_t max_inbox_frames = 4096;
};

/// Throws yamor::Error (INVALID_ARGUMENT / OUT_OF_RANGE) naming the field and
/// value when `options` are unusable (empty device, malformed tcp:// address,
/// unsupported baud rate, data bits outside 5..8, stop bits not 1 or 2,
/// non-positive or non-finite timeouts).
void ValidateSerialOptions(const SerialOptions& options);

/// Counters of a SerialBackend over all its connections.
struct SerialStats {
  uint64_t bytes_in = 0;       ///< Bytes read from the peer.
  uint64_t bytes_out = 0;      ///< Bytes written to the peer.
  uint64_t frames_in = 0;      ///< Frames decoded from the peer.
  uint64_t frames_out = 0;     ///< Frames written (the hellos included).
  uint64_t skipped_bytes = 0;  ///< Bytes outside decoded frames (resynchronisation).
  uint64_t decode_errors = 0;  ///< Rejected frame candidates (snp::DecodeError).
  uint64_t dropped_frames = 0; ///< Frames dropped because the inbox was full.
  uint64_t reconnects = 0;     ///< Successful reopens after a lost link.
};

/// A Backend on a serial line or a TCP connection, on Boost.Asio.
///
/// Frames from the peer are decoded with snp::FrameDecoder, which skips and
/// counts garbage; decoded frames wait in an inbox for Receive. When the link
/// goes away (EOF or EIO of a pty whose master closed, an unplugged device,
/// ECONNRESET, a killed bridge) the call in flight and every later Receive
/// throw yamor::Error(UNAVAILABLE) naming the device and the OS error (frames
/// that arrived before the loss are still handed out first); the next Send
/// tries to reopen the link once, hello included, and throws UNAVAILABLE if
/// that fails. No call blocks past its timeout. On a real robot (the hello
/// was not answered) bridge commands are not written: the backend answers
/// them itself with SpecialError UNIMPLEMENTED ("manual assembly required"),
/// as docs/snp.md prescribes.
///
/// Thread-safety: there is no background thread. The Asio io_context runs
/// on the calling thread inside Send, Receive and the constructor (reads
/// stay armed between calls, so bytes wait in the OS buffer until the next
/// call). Send, Receive, Reopen and the destructor must not run
/// concurrently (the RobotDriver serialises them under its mutex);
/// stats(), IsSimulation(), Name(), device() and sim_info() may be called
/// from any thread at any time.
class SerialBackend final : public Backend {
 public:
  /// Opens the link and says hello. Throws INVALID_ARGUMENT / OUT_OF_RANGE
  /// for bad options and UNAVAILABLE (naming the device and the OS error)
  /// when the device cannot be opened or the TCP peer does not accept.
  explicit SerialBackend(SerialOptions options);
  /// Closes the link.
  ~SerialBackend() override;
  SerialBackend(const SerialBackend&) = delete;
  SerialBackend& operator=(const SerialBackend&) = delete;

  /// Writes one frame; reopens a lost link first (once). Throws UNAVAILABLE
  /// when the link is gone or the frame could not leave within write_timeout.
  /// A bridge command to a real robot is answered locally (SpecialError).
  void Send(const snp::Frame& frame) override;
  /// The next frame, waiting up to `timeout`; nullopt when none came.
  /// Throws UNAVAILABLE once the link is lost and no frame is left.
  std::optional<snp::Frame> Receive(std::chrono::milliseconds timeout) override;
  /// True when the last hello was answered with SimInfo (yamor-bridge).
  bool IsSimulation() const override;
  /// "serial" for a device, "tcp" for tcp://.
  std::string Name() const override;
  /// 1 + the successful reopens: counts up each time the link came back.
  uint64_t Generation() const override;

  /// Closes the link (if open) and opens it again with a new hello; throws
  /// UNAVAILABLE on failure (the link then stays lost).
  void Reopen();
  /// True while the link is open and has not failed.
  bool IsOpen() const;
  /// The device path or tcp:// address.
  const std::string& device() const;
  /// The SimInfo of the last hello (nullopt for a real robot).
  std::optional<snp::SimInfo> sim_info() const;
  /// A snapshot of the counters.
  SerialStats stats() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace yamor::host
