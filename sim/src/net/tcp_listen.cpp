/// @file tcp_listen.cpp
/// A listening IPv4 TCP socket (tcp_listen.hpp).

#include "net/tcp_listen.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace numen::sim {

TcpListener tcp_listen(const std::string& host, std::uint16_t port, bool nonblocking, int backlog,
                       const std::string& what) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1)
    throw std::runtime_error(what + ": '" + host + "' is not an IPv4 address");
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | (nonblocking ? SOCK_NONBLOCK : 0), 0);
  if (fd < 0) throw std::runtime_error(what + ": socket: " + std::strerror(errno));
  const int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 ||
      listen(fd, backlog) != 0) {
    const std::string why = std::strerror(errno);
    close(fd);
    throw std::runtime_error(what + ": cannot listen on " + host + ":" + std::to_string(port) +
                             ": " + why);
  }
  socklen_t len = sizeof addr;
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  return TcpListener{fd, ntohs(addr.sin_port)};
}

}  // namespace numen::sim
