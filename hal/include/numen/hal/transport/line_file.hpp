#pragma once
/// @file line_file.hpp
/// LineFile: a text file opened for writing by a RecordSink (bus recorder, trace writer):
/// buffered stdio, and every failure returned to the caller so that it is counted, never
/// ignored. Opening and closing belong to the setup thread; write() and flush() to whichever
/// thread the sink runs on.

#include <cstddef>
#include <cstdio>
#include <string>

namespace numen::hal {

/// Owner of one FILE* opened with mode "w" (truncated). Not copyable or movable.
class LineFile {
 public:
  /// Opens (truncates) `path`. Throws std::runtime_error "path: cannot open for writing:
  /// <errno text>".
  explicit LineFile(const std::string& path);
  /// Closes the file if close() was not called (a failure is then not reported).
  ~LineFile();
  LineFile(const LineFile&) = delete;
  LineFile& operator=(const LineFile&) = delete;
  LineFile(LineFile&&) = delete;
  LineFile& operator=(LineFile&&) = delete;

  /// Writes `size` bytes (buffered). False if fwrite wrote fewer (disk full, I/O error) or the
  /// file is closed. noexcept, no allocation.
  bool write(const char* data, std::size_t size) noexcept;
  /// fflush(); false on failure or if the file is closed.
  bool flush() noexcept;
  /// fclose(); false if it failed (the buffered tail could not be written). Idempotent: a
  /// second call returns true.
  bool close() noexcept;
  /// True until close().
  bool is_open() const noexcept { return file_ != nullptr; }
  /// The path given at construction.
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
};

}  // namespace numen::hal
