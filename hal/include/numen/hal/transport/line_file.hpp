#pragma once
/// @file line_file.hpp
/// LineFile: a text file opened for writing by a RecordSink (trace writer, view recording):
/// buffered stdio, and every failure returned to the caller so that it is counted, never
/// ignored. Opening and closing belong to the setup thread; write() and flush() to whichever
/// thread the sink runs on.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

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

/// Lines a CountedLineFile settled since the last take_counts().
struct LineCounts {
  std::uint64_t written = 0;        ///< Lines whose every byte write(2) accepted.
  std::uint64_t lost = 0;           ///< Lines not (wholly) accepted: a write(2) failed.
  /// Write-outs append() made to make room that failed (ENOSPC, EIO, ...); a failed flush() or
  /// close() is returned to its caller instead.
  std::uint64_t failed_writes = 0;
};

/// A text file of '\n'-terminated lines written with write(2) from its own fixed buffer, that
/// counts the lines whose bytes the kernel accepted. stdio cannot tell: fwrite() succeeds into
/// its buffer and the failure shows at a later fflush(), for lines already counted as written
/// (`--record /dev/full` read "24 924 of 25 159 frames written" when none was). For sinks whose
/// count of written records must be what reached the file (CandumpWriter). Opening belongs to
/// the setup thread; append(), flush() and take_counts() to the thread the sink runs on.
class CountedLineFile {
 public:
  /// Opens (creates, truncates) `path` for writing and allocates a `buffer_bytes` buffer
  /// (>= 1). Throws std::runtime_error "path: cannot open for writing: <errno text>".
  explicit CountedLineFile(const std::string& path, std::size_t buffer_bytes = 1 << 16);
  /// close() (a failure is then not reported).
  ~CountedLineFile();
  CountedLineFile(const CountedLineFile&) = delete;
  CountedLineFile& operator=(const CountedLineFile&) = delete;
  CountedLineFile(CountedLineFile&&) = delete;
  CountedLineFile& operator=(CountedLineFile&&) = delete;

  /// Buffers one line: `size` bytes ending in '\n' (the only '\n' among them), first writing
  /// the buffer out (flush()) if the line does not fit. False if the file is closed or the
  /// line is empty, does not end in '\n' or is longer than the buffer (not buffered, not
  /// counted). A failed write-out is counted in take_counts(), not returned here. noexcept,
  /// no allocation.
  bool append(const char* line, std::size_t size) noexcept;
  /// Writes the buffer out with write(2), retrying EINTR and short writes. False if a write
  /// failed (or the file is closed): the lines it did not wholly accept are counted lost and
  /// dropped from the buffer, so that later lines are tried afresh (a disk that frees space).
  bool flush() noexcept;
  /// flush(), then close(2); false if either failed. Idempotent: a second call returns true.
  bool close() noexcept;
  /// True until close().
  bool is_open() const noexcept { return fd_ >= 0; }
  /// The lines written and lost (and the failed writes) since the last call; resets them.
  LineCounts take_counts() noexcept;
  /// The path given at construction.
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  std::vector<char> buffer_;
  std::size_t used_ = 0;
  LineCounts counts_{};
};

}  // namespace numen::hal
