/// @file tcp_listen.cpp
/// A listening TCP socket on an IPv4 or IPv6 address (tcp_listen.hpp).

#include "net/tcp_listen.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

namespace numen::sim {

TcpListener tcp_listen(const std::string& host, std::uint16_t port, bool nonblocking, int backlog,
                       const std::string& what) {
  const bool v6_literal = host.find(':') != std::string::npos;
  const std::string where = (v6_literal ? "[" + host + "]" : host) + ":" + std::to_string(port);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (const int r = getaddrinfo(host.c_str(), service.c_str(), &hints, &found); r != 0)
    throw std::runtime_error(what + ": cannot listen on " + where + ": " + gai_strerror(r));
  const std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> owner(found, &freeaddrinfo);
  std::vector<const addrinfo*> order;  // IPv4 first, then IPv6
  for (int family : {AF_INET, AF_INET6})
    for (const addrinfo* a = found; a != nullptr; a = a->ai_next)
      if (a->ai_family == family) order.push_back(a);
  std::string why = "no IPv4 or IPv6 address";
  for (const addrinfo* a : order) {
    const int fd = socket(a->ai_family,
                          SOCK_STREAM | SOCK_CLOEXEC | (nonblocking ? SOCK_NONBLOCK : 0), 0);
    if (fd < 0) {
      why = std::string("socket: ") + std::strerror(errno);
      continue;
    }
    const int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (a->ai_family == AF_INET6) setsockopt(fd, IPPROTO_IPV6, IPV6_V6ONLY, &one, sizeof one);
    if (bind(fd, a->ai_addr, a->ai_addrlen) != 0 || listen(fd, backlog) != 0) {
      why = std::strerror(errno);
      close(fd);
      continue;
    }
    sockaddr_storage bound{};
    socklen_t len = sizeof bound;
    getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len);
    const std::uint16_t got =
        bound.ss_family == AF_INET6
            ? ntohs(reinterpret_cast<const sockaddr_in6*>(&bound)->sin6_port)
            : ntohs(reinterpret_cast<const sockaddr_in*>(&bound)->sin_port);
    return TcpListener{fd, got};
  }
  throw std::runtime_error(what + ": cannot listen on " + where + ": " + why);
}

}  // namespace numen::sim
