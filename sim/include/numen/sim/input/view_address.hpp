#pragma once
/// @file view_address.hpp
/// The address of `numen run --view [HOST:]PORT` (docs/viewer.md, "Server"): where the live
/// viewer's server listens.

#include <cstdint>
#include <string>

namespace numen::sim {

/// A parsed `--view` value.
struct ViewAddress {
  /// An IPv4 or IPv6 address literal, or "localhost" (ViewServer::is_address()); an IPv6
  /// address without its brackets. Default: loopback only.
  std::string host = "127.0.0.1";
  /// TCP port, 0-65535 (0: any free port).
  std::uint16_t port = 0;
};

/// Parses `numen run --view`'s value:
/// - `PORT`: on 127.0.0.1;
/// - `HOST:PORT`: HOST an IPv4 address or `localhost`;
/// - `[IPV6]:PORT`: an IPv6 address in brackets (RFC 3986's IP-literal, as the server's URL
///   prints it: `[::1]:8080`);
/// - `IPV6:PORT`: an IPv6 address without brackets, the last colon ending it (`::1:8080`).
/// PORT is decimal digits only, at most 65535. Host names are not resolved. Throws
/// std::invalid_argument quoting the value (control bytes escaped, InputError::visible()) and
/// saying what is wrong: "expected [HOST:]PORT ..." for the shape or the port, "HOST must be
/// an IP address or localhost ..." for the host, "... in brackets must be an IPv6 address ..."
/// for a bracketed one that is not.
ViewAddress parse_view_address(const std::string& text);

}  // namespace numen::sim
