#pragma once
/// @file input_error.hpp
/// Load-time error of a user input file (scene, trajectory). Thrown only while
/// loading, never in the real-time path; what() reads
///   "<file>:<line>:<column>: <key>: <message>"
/// with the parts that are unknown left out (and their separators). Control bytes (a NUL, a carriage
/// return, an escape ...) in any part are written as \xNN in what(), so that a
/// stray byte of a user's file can neither cut the message nor garble the terminal.

#include <charconv>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace numen::sim {

/// An error in a user input, with the place it was found.
class InputError : public std::runtime_error {
 public:
  /// file: path as given by the user; line, column: 1-based, 0 = unknown;
  /// key: dotted key path in a scene file (may be empty); message: what is wrong.
  InputError(std::string file, int line, int column, std::string key, std::string message)
      : std::runtime_error(format(file, line, column, key, message)),
        file_(std::move(file)), line_(line), column_(column), key_(std::move(key)),
        message_(std::move(message)) {}

  const std::string& file() const noexcept { return file_; }
  int line() const noexcept { return line_; }
  int column() const noexcept { return column_; }
  const std::string& key() const noexcept { return key_; }
  const std::string& message() const noexcept { return message_; }

  /// `text` with every byte below 0x20 and 0x7F (DEL) — and with `non_ascii`, every byte
  /// above 0x7F too — written as \xNN. what() is built with it; also for quoting user
  /// text in messages (a token that should be a number: `non_ascii` shows a stray BOM).
  static std::string visible(std::string_view text, bool non_ascii = false) {
    static constexpr char kHex[] = "0123456789ABCDEF";
    std::string out;
    out.reserve(text.size());
    for (const char ch : text) {
      const auto b = static_cast<unsigned char>(ch);
      if (b >= 0x20 && b != 0x7F && !(non_ascii && b > 0x7F)) {
        out += ch;
      } else {
        out += "\\x";
        out += kHex[b >> 4];
        out += kHex[b & 0xF];
      }
    }
    return out;
  }

 private:
  static std::string format(const std::string& file, int line, int column,
                            const std::string& key, const std::string& message) {
    std::ostringstream os;
    os << file;
    if (line > 0) os << ':' << line;
    if (line > 0 && column > 0) os << ':' << column;
    if (!file.empty() || line > 0) os << ": ";
    if (!key.empty()) os << key << ": ";
    os << message;
    return visible(os.str());
  }
  std::string file_;
  int line_;
  int column_;
  std::string key_;
  std::string message_;
};

/// Throws an InputError about `key` with no file position: for values checked after their
/// file was read, or handed over in memory (a trajectory, a trocar placement).
[[noreturn]] inline void fail_at_key(const std::string& key, const std::string& message) {
  throw InputError("", 0, 0, key, message);
}

/// `v` as an input message quotes it: 6 significant digits (printf %g), e.g.
/// 1000, 1e+308, 0.0333333, -1, nan — never the 309 digits of std::to_string(DBL_MAX).
inline std::string format_input_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// `v` in the fewest digits that read back as exactly `v` (std::to_chars' shortest round trip),
/// e.g. 0.0010000001, 0.001, 1e+308, nan: for a value whose message is about digits that %g
/// would cut (a scene_dt that is 1e-10 s off a multiple of dt must not read "got 0.001 s").
inline std::string format_exact_number(double v) {
  char buf[32];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace numen::sim
