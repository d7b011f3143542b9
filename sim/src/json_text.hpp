#pragma once
/// @file json_text.hpp
/// JSON string literal for the CLI's hand-written `--json` outputs (run.cpp, scene_info.cpp).
/// Internal to numen::sim. Not real-time: allocates.

#include <cstdio>
#include <string>

namespace numen::sim::detail {

/// `in` as a JSON string literal, quotes included: '"' and '\' escaped, control characters
/// (< 0x20) as \u00XX (RFC 8259 §7); other bytes (UTF-8) as they are.
inline std::string json_string(const std::string& in) {
  std::string out = "\"";
  for (unsigned char c : in) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

}  // namespace numen::sim::detail
