#pragma once
/// @file tcp_listen.hpp
/// A listening TCP socket for numen's OpenIGTLink servers (the replay, igtl_replay.cpp; the
/// world out, igtl_world_server.cpp). Private to sim.

#include <cstdint>
#include <string>

namespace numen::sim {

/// A bound, listening socket and the port it got.
struct TcpListener {
  int fd = -1;
  std::uint16_t port = 0;  ///< The port bound (the ephemeral one when 0 was asked).
};

/// Binds `host` : `port` (0: an ephemeral port) with SO_REUSEADDR, close-on-exec, non-blocking
/// when `nonblocking`, and listens (`backlog`). `host` is an IPv4 or IPv6 literal (without
/// brackets) or a name, resolved by getaddrinfo(); of its addresses the IPv4 ones are tried
/// first (so "localhost" is 127.0.0.1 where it has both, as the viewer's), then the IPv6 ones
/// (an IPv6 socket is IPv6 only). Throws std::runtime_error "`what`: cannot listen on
/// HOST:PORT: <reason>" (the resolver's or the last bind's). The caller closes the fd.
TcpListener tcp_listen(const std::string& host, std::uint16_t port, bool nonblocking, int backlog,
                       const std::string& what);

}  // namespace numen::sim
