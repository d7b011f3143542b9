#pragma once
/// @file input_error.hpp
/// Load-time error of a user input file (scene, trajectory). Thrown only while
/// loading, never in the real-time path; what() reads
///   "<file>:<line>:<column>: <key>: <message>"
/// with the parts that are unknown left out (and their separators).

#include <sstream>
#include <stdexcept>
#include <string>

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
    return os.str();
  }
  std::string file_;
  int line_;
  int column_;
  std::string key_;
  std::string message_;
};

}  // namespace numen::sim
