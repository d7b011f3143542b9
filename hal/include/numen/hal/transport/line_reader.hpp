#pragma once
/// @file line_reader.hpp
/// LineReader: a text file read one line at a time in a fixed buffer, so that memory does not
/// depend on the file's size or on its longest line. Users: the candump log reader
/// (candump_log.hpp) and the JIGSAWS kinematics loader (sim/input/jigsaws.hpp). Setup code or a
/// reader thread: opening allocates the buffer once, reading never allocates.

#include <cstddef>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

namespace numen::hal {

/// Owner of one file opened for reading (mode "rb") and its line buffer of 2 × max_line
/// bytes. Lines end at '\n' (a '\r' before it stays in the line); the last line may lack
/// one. Not copyable or movable.
class LineReader {
 public:
  /// Opens `path`; lines longer than `max_line` (>= 1) bytes are cut (next()). Throws
  /// std::runtime_error "path: cannot open: <errno text>", std::invalid_argument if
  /// max_line is 0.
  LineReader(std::string path, std::size_t max_line);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;
  LineReader(LineReader&&) = delete;
  LineReader& operator=(LineReader&&) = delete;

  /// The next line, without its '\n', in `line` (a view into the buffer, valid until the next
  /// call); false at the end of the file. A line longer than max_line comes back as its first
  /// max_line bytes with `cut` set; the rest of it is skipped. Throws std::runtime_error
  /// "path:N: read error: <errno text>" (N: the line being read) if reading fails.
  bool next(std::string_view& line, bool& cut);
  /// Lines returned so far (the 1-based number of the last one).
  std::size_t line_number() const noexcept { return lines_; }
  /// The path as given.
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  std::size_t max_line_;
  std::FILE* file_ = nullptr;
  std::unique_ptr<char[]> buffer_;  // 2 * max_line_ bytes
  std::size_t begin_ = 0;           // unread bytes are buffer_[begin_, end_)
  std::size_t end_ = 0;
  std::size_t lines_ = 0;
  bool eof_ = false;
  bool skip_rest_ = false;  // skipping the tail of a cut line
};

}  // namespace numen::hal
