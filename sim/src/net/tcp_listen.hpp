#pragma once
/// @file tcp_listen.hpp
/// A listening IPv4 TCP socket for numen's OpenIGTLink servers (the replay, igtl_replay.cpp; the
/// world out, igtl_world_server.cpp). Private to sim.

#include <cstdint>
#include <string>

namespace numen::sim {

/// A bound, listening socket and the port it got.
struct TcpListener {
  int fd = -1;
  std::uint16_t port = 0;  ///< The port bound (the ephemeral one when 0 was asked).
};

/// Binds `host` (an IPv4 address literal) : `port` (0: an ephemeral port) with SO_REUSEADDR,
/// close-on-exec, non-blocking when `nonblocking`, and listens (`backlog`). Throws
/// std::runtime_error "`what`: cannot listen on HOST:PORT: <errno text>" (or "… is not an IPv4
/// address"). The caller closes the fd.
TcpListener tcp_listen(const std::string& host, std::uint16_t port, bool nonblocking, int backlog,
                       const std::string& what);

}  // namespace numen::sim
