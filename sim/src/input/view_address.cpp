/// @file view_address.cpp
/// `numen run --view [HOST:]PORT` (see view_address.hpp).

#include "numen/sim/input/view_address.hpp"

#include <charconv>
#include <stdexcept>
#include <system_error>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/view/view_server.hpp"

namespace numen::sim {

ViewAddress parse_view_address(const std::string& text) {
  const std::string shown = "'" + InputError::visible(text) + "'";
  const std::string expected =
      "expected [HOST:]PORT (HOST an IPv4 address, localhost or an IPv6 address in brackets "
      "such as [::1]; PORT in 0-65535), got " +
      shown;
  ViewAddress out;
  std::string host, port;
  bool bracketed = false;
  if (!text.empty() && text.front() == '[') {
    // [IPV6]:PORT: the brackets end the address, a colon and the port follow.
    const auto close = text.find(']');
    if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':')
      throw std::invalid_argument(expected);
    bracketed = true;
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else if (const auto colon = text.rfind(':'); colon != std::string::npos) {
    // HOST:PORT; an IPv6 address without brackets ends at the last colon.
    if (colon == 0) throw std::invalid_argument(expected);
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
  } else {
    port = text;
  }
  unsigned value = 0;
  const char* end = port.data() + port.size();
  const std::from_chars_result r = std::from_chars(port.data(), end, value);
  // from_chars of an unsigned reads digits only: no sign, no blank.
  if (port.empty() || r.ec != std::errc() || r.ptr != end || value > 65535)
    throw std::invalid_argument(expected);
  out.port = static_cast<std::uint16_t>(value);
  if (bracketed && (host.find(':') == std::string::npos || !ViewServer::is_address(host)))
    throw std::invalid_argument(
        "the HOST in brackets must be an IPv6 address (names are not resolved), got " + shown);
  if (!host.empty() && !ViewServer::is_address(host))
    throw std::invalid_argument(
        "HOST must be an IP address or localhost (names are not resolved), got " + shown);
  if (!host.empty()) out.host = host;  // PORT alone: the default
  return out;
}

}  // namespace numen::sim
