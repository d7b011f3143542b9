#pragma once
/// @file text_chars.hpp
/// Character classes of the text logs hal parses (candump and evemu lines; private header). One
/// definition for every file: in a unity batch, file-local functions of one name collide.

namespace numen::hal::detail {

/// A space or a tab: the separators of a log line's fields.
constexpr bool is_blank(char c) noexcept { return c == ' ' || c == '\t'; }

/// A decimal digit '0'–'9'.
constexpr bool is_digit(char c) noexcept { return c >= '0' && c <= '9'; }

/// The value 0–15 of a hexadecimal digit (either case); -1 for any other character.
constexpr int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace numen::hal::detail
