// UnusedPort: a loopback TCP port nobody listens on now, for tests that need
// a daemon that is not there (or a port to start one on later).
//
// Thread safety: a function of the system's ports; another process may take
// the port afterwards.
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace yamor::testing {

/// A 127.0.0.1 port bound and closed again at once.
inline int UnusedPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  socklen_t length = sizeof address;
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

}  // namespace yamor::testing
