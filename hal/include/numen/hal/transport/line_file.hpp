#pragma once
/// @file line_file.hpp
/// The files record sinks write: LineFile (buffered stdio; trace writer, view recording) and
/// CountedLineFile (write(2) from its own buffer, counting the lines the kernel accepted; bus
/// recorder). Every failure is returned to the caller so that it is counted, never ignored.
/// Opening and closing belong to the setup thread; writing to whichever thread the sink runs
/// on.
///
/// A file is never lost to a refused run (OutputFile). A regular file (or a path that does not
/// exist yet) is written to a temporary file beside it (`.NAME.XXXXXX` in the same directory,
/// made with mkstemp) and renamed over `path` by close(): until then the previous file at
/// `path` is untouched. A file closed during stack unwinding (an exception that refuses the
/// run after its outputs were opened: std::uncaught_exceptions() above its value at
/// construction) or destroyed without close() deletes its temporary file instead, and `path`
/// stays as it was. A path that exists and is not a regular file (a device such as /dev/full or
/// /dev/null, a FIFO, a terminal) is opened directly, as is a regular file whose directory does
/// not let a temporary file be made. A symbolic link is followed: its target is replaced.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace numen::hal {

/// The descriptor behind one output `path` and its replacement on close (the file comment).
/// Not copyable or movable.
class OutputFile {
 public:
  /// Opens `path` for writing: a temporary file beside it, or `path` itself if it is not a
  /// regular file (truncated). Throws std::runtime_error "path: cannot open for writing: <errno
  /// text>" (no such directory, permission denied, a directory, ...).
  explicit OutputFile(const std::string& path);
  /// discard() unless finish() was called.
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;
  OutputFile(OutputFile&&) = delete;
  OutputFile& operator=(OutputFile&&) = delete;

  /// The descriptor to write (its owner closes it before finish()).
  int fd() const noexcept { return fd_; }
  /// After the owner closed fd(): the temporary file renamed over `path` (false if the rename
  /// failed; the temporary file is then deleted), or, during stack unwinding (the file
  /// comment), deleted and `path` left as it was (true). Idempotent.
  bool finish() noexcept;
  /// After the owner closed fd(): the temporary file deleted, `path` left as it was.
  void discard() noexcept;
  /// The file being written until finish(): the temporary file, or `path` itself.
  const std::string& writing_path() const noexcept { return temp_.empty() ? target_ : temp_; }

 private:
  std::string target_;  // where finish() renames the temporary file (symbolic links resolved)
  std::string temp_;    // the temporary file; empty when the path is written directly
  int fd_ = -1;
  int unwinding_at_open_ = 0;  // std::uncaught_exceptions() at construction
};

/// Owner of one FILE* on an OutputFile. Not copyable or movable.
class LineFile {
 public:
  /// Opens `path` (OutputFile). Throws std::runtime_error "path: cannot open for writing:
  /// <errno text>".
  explicit LineFile(const std::string& path);
  /// If close() was not called: closes the stream and deletes the temporary file (`path`
  /// unchanged).
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
  /// fclose(), then OutputFile::finish(); false if either failed (the buffered tail could not
  /// be written, the rename was refused). Idempotent: a second call returns true.
  bool close() noexcept;
  /// True until close().
  bool is_open() const noexcept { return file_ != nullptr; }
  /// The path given at construction.
  const std::string& path() const noexcept { return path_; }
  /// The file being written until close() (OutputFile::writing_path()).
  const std::string& writing_path() const noexcept { return output_.writing_path(); }

 private:
  std::string path_;
  OutputFile output_;
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

/// A text file of '\n'-terminated lines written with write(2) from its own fixed buffer, on an
/// OutputFile, that counts the lines whose bytes the kernel accepted. stdio cannot tell:
/// fwrite() succeeds into its buffer and the failure shows at a later fflush(), for lines
/// already counted as written (`--record /dev/full` read "24 924 of 25 159 frames written" when
/// none was). For sinks whose count of written records must be what reached the file
/// (CandumpWriter). Opening belongs to the setup thread; append(), flush() and take_counts() to
/// the thread the sink runs on.
class CountedLineFile {
 public:
  /// Opens `path` (OutputFile) and allocates a `buffer_bytes` buffer (>= 1). Throws
  /// std::runtime_error "path: cannot open for writing: <errno text>".
  explicit CountedLineFile(const std::string& path, std::size_t buffer_bytes = 1 << 16);
  /// If close() was not called: closes the descriptor and deletes the temporary file (`path`
  /// unchanged; nothing buffered is written).
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
  /// flush(), close(2), then OutputFile::finish(); false if any failed. Idempotent: a second
  /// call returns true.
  bool close() noexcept;
  /// True until close().
  bool is_open() const noexcept { return fd_ >= 0; }
  /// The lines written and lost (and the failed writes) since the last call; resets them.
  LineCounts take_counts() noexcept;
  /// The path given at construction.
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  OutputFile output_;
  int fd_ = -1;
  std::vector<char> buffer_;
  std::size_t used_ = 0;
  LineCounts counts_{};
};

}  // namespace numen::hal
