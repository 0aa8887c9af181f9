// The server side of the CamApp protocol (docs/camapp.md) for yamor-camapp:
// a TCP listener that greets every client with the hello and then sends it
// every sample line published from the moment it connected, each at its
// scheduled time (the camera's latency). Boost.Asio, one I/O thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

namespace yamor::camapp {

/// Where and what the server serves.
struct CamAppServerOptions {
  std::string address = "127.0.0.1";  ///< Listening address.
  int port = 2225;                    ///< Listening port (0: an ephemeral one).
  int width = 640;                    ///< Image width in the hello [px].
  int height = 480;                   ///< Image height in the hello [px].
  /// Lines queued for a client that does not read; beyond, it is dropped.
  std::size_t max_queued_lines = 4096;
};

/// The CamApp TCP server.
/// Thread-safety: Publish, port and clients may be called from any thread;
/// the I/O thread owns the sockets.
class CamAppServer {
 public:
  /// Binds and starts listening; UNAVAILABLE naming the address when it cannot.
  explicit CamAppServer(CamAppServerOptions options);
  /// Closes every connection and stops the I/O thread.
  ~CamAppServer();
  CamAppServer(const CamAppServer&) = delete;
  CamAppServer& operator=(const CamAppServer&) = delete;

  /// The port it listens on.
  int port() const noexcept;

  /// Sends `line` (without '\n') to every client connected at `send_at` or
  /// earlier, at `send_at`. Lines go out in the order published; a time
  /// earlier than a previous line's is sent with it.
  void Publish(std::string line, std::chrono::steady_clock::time_point send_at);

  /// Clients connected now.
  int clients() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace yamor::camapp
