#pragma once
/// @file line_file.hpp
/// LineFile: a text file opened for writing by a RecordSink (bus recorder, trace writer, view
/// recording): buffered stdio, and every failure returned to the caller so that it is counted,
/// never ignored. Opening and closing belong to the setup thread; write() and flush() to
/// whichever thread the sink runs on.
///
/// A file is never lost to a refused run. A regular file (or a path that does not exist yet)
/// is written to a temporary file beside it (`.NAME.XXXXXX` in the same directory, made with
/// mkstemp) and renamed over `path` by close(): until then the previous file at `path` is
/// untouched. A LineFile closed during stack unwinding (an exception that refuses the run
/// after its outputs were opened: std::uncaught_exceptions() above its value at construction)
/// or destroyed without close() deletes its temporary file instead, and `path` stays as it was.
/// A path that exists and is not a regular file (a device such as /dev/full or /dev/null, a
/// FIFO, a terminal) is opened directly with mode "w", as is a regular file whose directory
/// does not let a temporary file be made. A symbolic link is followed: its target is replaced.

#include <cstddef>
#include <cstdio>
#include <string>

namespace numen::hal {

/// Owner of one FILE* written to a temporary file renamed over `path` on close() (see the
/// file comment). Not copyable or movable.
class LineFile {
 public:
  /// Opens `path` for writing: a temporary file beside it, or `path` itself if it is not a
  /// regular file. Throws std::runtime_error "path: cannot open for writing: <errno text>"
  /// (e.g. no such directory, permission denied, a directory).
  explicit LineFile(const std::string& path);
  /// If close() was not called: closes and deletes the temporary file (`path` unchanged).
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
  /// fclose(), then the temporary file renamed over `path`; false if either failed (the
  /// buffered tail could not be written, the rename was refused). During stack unwinding (see
  /// the file comment) the temporary file is deleted instead and the result is true.
  /// Idempotent: a second call returns true.
  bool close() noexcept;
  /// True until close().
  bool is_open() const noexcept { return file_ != nullptr; }
  /// The path given at construction.
  const std::string& path() const noexcept { return path_; }
  /// The file being written until close(): the temporary file, or `path` itself (not a regular
  /// file); after close(), `path`.
  const std::string& writing_path() const noexcept { return temp_.empty() ? path_ : temp_; }

 private:
  /// Closes the stream and deletes the temporary file (if any): `path` unchanged.
  void discard() noexcept;

  std::string path_;
  std::string target_;  // where close() renames the temporary file (symbolic links resolved)
  std::string temp_;    // the temporary file; empty when `path` is written directly
  std::FILE* file_ = nullptr;
  int unwinding_at_open_ = 0;  // std::uncaught_exceptions() at construction
};

}  // namespace numen::hal
