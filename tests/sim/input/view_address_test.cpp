// Tests of sim/view_address: `numen run --view [HOST:]PORT`, an IPv6 host in brackets ([::1]:0,
// as the server's URL prints it) or without (::1:0), and the refusals with their messages.
#include "numen/sim/input/view_address.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace {

using numen::sim::parse_view_address;
using numen::sim::ViewAddress;

/// The message parse_view_address() throws for `text` ("" if it accepts it).
std::string refusal(const std::string& text) {
  try {
    (void)parse_view_address(text);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ViewAddress, APortAloneIsOnLoopback) {
  const ViewAddress a = parse_view_address("8080");
  EXPECT_EQ(a.host, "127.0.0.1");
  EXPECT_EQ(a.port, 8080);
  EXPECT_EQ(parse_view_address("0").port, 0);
  EXPECT_EQ(parse_view_address("65535").port, 65535);
}

TEST(ViewAddress, AnIPv4HostOrLocalhost) {
  const ViewAddress a = parse_view_address("0.0.0.0:8080");
  EXPECT_EQ(a.host, "0.0.0.0");
  EXPECT_EQ(a.port, 8080);
  EXPECT_EQ(parse_view_address("localhost:0").host, "localhost");
}

TEST(ViewAddress, AnIPv6HostInBracketsOrWithout) {
  for (const char* text : {"[::1]:0", "::1:0"}) {
    const ViewAddress a = parse_view_address(text);
    EXPECT_EQ(a.host, "::1") << text;
    EXPECT_EQ(a.port, 0) << text;
  }
  const ViewAddress any = parse_view_address("[::]:8080");
  EXPECT_EQ(any.host, "::");
  EXPECT_EQ(any.port, 8080);
  EXPECT_EQ(parse_view_address("[::ffff:127.0.0.1]:9").host, "::ffff:127.0.0.1");
}

TEST(ViewAddress, RefusalsSayWhatIsExpected) {
  const std::string shape =
      "expected [HOST:]PORT (HOST an IPv4 address, localhost or an IPv6 address in brackets "
      "such as [::1]; PORT in 0-65535), got ";
  for (const char* text :
       {"", "8080x", "99999", "65536", "-1", "+80", " 80", "host:", ":8080", "[::1]",
        "[::1]:", "[::1]8080", "[::1:8080", "[::1]:99999", "[::1]:http", "http://x"})
    EXPECT_EQ(refusal(text), shape + "'" + text + "'") << text;
  for (const char* text : {"notahost:8080", "::1]:8080", "example.org:80", "127.0.0.1:80:80"})
    EXPECT_EQ(refusal(text), std::string("HOST must be an IP address or localhost (names are not "
                                         "resolved), got '") +
                                 text + "'")
        << text;
  for (const char* text : {"[127.0.0.1]:80", "[localhost]:80", "[]:80", "[notahost]:80"})
    EXPECT_EQ(refusal(text), std::string("the HOST in brackets must be an IPv6 address (names are "
                                         "not resolved), got '") +
                                 text + "'")
        << text;
  // A control byte is shown escaped.
  EXPECT_EQ(refusal("80\x1b"), shape + "'80\\x1B'");
}

}  // namespace
