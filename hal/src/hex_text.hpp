#pragma once
/// @file hex_text.hpp
/// Hexadecimal text of identifiers and values in hal's error messages (private header). One
/// definition for every file: in a unity batch, file-local overloads of one name resolve
/// across files.

#include <cstdint>
#include <cstdio>
#include <string>

namespace numen::hal::detail {

/// "0x" and `v` in upper-case hexadecimal, zero-padded to `digits` digits (more if `v` needs
/// them): hex_digits(0x6041, 4) = "0x6041".
inline std::string hex_digits(std::uint64_t v, int digits) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%0*llX", digits, static_cast<unsigned long long>(v));
  return buf;
}

/// A CAN identifier or COB-ID as written in the docs: "0x" and at least three upper-case hex
/// digits (hex_cob_id(0x181) = "0x181", hex_cob_id(0x80) = "0x080").
inline std::string hex_cob_id(std::uint32_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%03X", static_cast<unsigned>(id));
  return buf;
}

}  // namespace numen::hal::detail
