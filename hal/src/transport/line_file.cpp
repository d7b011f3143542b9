/// @file line_file.cpp
/// The files record sinks write: OutputFile (a temporary file renamed over the path on close),
/// LineFile (stdio) and CountedLineFile (write(2), counted lines); line_file.hpp.

#include "numen/hal/transport/line_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>

namespace numen::hal {
namespace {

[[noreturn]] void fail(const std::string& path, int err) {
  throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
}

/// The permission bits a new file gets from open(…, 0666): 0666 less the process's umask.
mode_t default_mode() {
  const mode_t mask = ::umask(0);
  ::umask(mask);
  return static_cast<mode_t>(0666 & ~mask);
}

}  // namespace

// ---------------------------------------------------------------- OutputFile

OutputFile::OutputFile(const std::string& path)
    : target_(path), unwinding_at_open_(std::uncaught_exceptions()) {
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) fail(path, EISDIR);
  auto open_in_place = [&] {
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd_ < 0) fail(path, errno);
  };
  if (exists && !S_ISREG(st.st_mode)) {  // a device, a FIFO, a terminal
    open_in_place();
    return;
  }
  if (exists) {
    if (::access(path.c_str(), W_OK) != 0) fail(path, errno);  // as open(path, O_WRONLY) would
    char resolved[PATH_MAX];
    if (::realpath(path.c_str(), resolved) != nullptr) target_ = resolved;  // a link's target
  }
  const std::size_t slash = target_.rfind('/');
  const std::string dir = slash == std::string::npos ? "" : target_.substr(0, slash + 1);
  const std::string base = slash == std::string::npos ? target_ : target_.substr(slash + 1);
  std::string temp = dir + "." + base + ".XXXXXX";
  fd_ = ::mkostemp(temp.data(), O_CLOEXEC);
  if (fd_ < 0) {
    if (!exists) fail(path, errno);  // no such directory, a directory not writable
    target_ = path;
    open_in_place();  // the file is writable, its directory is not
    return;
  }
  ::fchmod(fd_, exists ? (st.st_mode & 07777) : default_mode());
  temp_ = std::move(temp);
}

OutputFile::~OutputFile() { discard(); }

void OutputFile::discard() noexcept {
  if (!temp_.empty()) ::unlink(temp_.c_str());
  temp_.clear();
}

bool OutputFile::finish() noexcept {
  if (temp_.empty()) return true;
  if (std::uncaught_exceptions() > unwinding_at_open_) {  // the run was refused: keep `path`
    discard();
    return true;
  }
  const bool ok = ::rename(temp_.c_str(), target_.c_str()) == 0;
  if (!ok) ::unlink(temp_.c_str());
  temp_.clear();
  return ok;
}

// ---------------------------------------------------------------- LineFile

LineFile::LineFile(const std::string& path) : path_(path), output_(path) {
  file_ = ::fdopen(output_.fd(), "w");
  if (file_ == nullptr) {
    const int err = errno;
    ::close(output_.fd());
    fail(path, err);  // ~OutputFile deletes the temporary file
  }
}

LineFile::~LineFile() {
  if (file_ != nullptr) std::fclose(file_);  // output_ then deletes the temporary file
}

bool LineFile::write(const char* data, std::size_t size) noexcept {
  return file_ != nullptr && std::fwrite(data, 1, size, file_) == size;
}

bool LineFile::flush() noexcept { return file_ != nullptr && std::fflush(file_) == 0; }

bool LineFile::close() noexcept {
  if (file_ == nullptr) return true;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  const bool finished = output_.finish();
  return closed && finished;
}

// ---------------------------------------------------------------- CountedLineFile

CountedLineFile::CountedLineFile(const std::string& path, std::size_t buffer_bytes)
    : path_(path), output_(path), fd_(output_.fd()), buffer_(std::max<std::size_t>(buffer_bytes, 1)) {}

CountedLineFile::~CountedLineFile() {
  if (fd_ >= 0) ::close(fd_);  // output_ then deletes the temporary file
}

bool CountedLineFile::append(const char* line, std::size_t size) noexcept {
  if (fd_ < 0 || size == 0 || size > buffer_.size() || line[size - 1] != '\n') return false;
  // A failed write-out is counted (no caller sees its result); the line is kept.
  if (buffer_.size() - used_ < size && !flush()) ++counts_.failed_writes;
  std::memcpy(buffer_.data() + used_, line, size);
  used_ += size;
  return true;
}

bool CountedLineFile::flush() noexcept {
  if (fd_ < 0) return false;
  const char* const begin = buffer_.data();
  std::size_t done = 0;
  bool ok = true;
  while (done < used_) {
    const ssize_t n = ::write(fd_, begin + done, used_ - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {  // 0 for a non-empty write: no progress, taken as a failure
      ok = false;
      break;
    }
    done += static_cast<std::size_t>(n);
  }
  // Every line ends in its one '\n': the lines wholly accepted are the '\n's written.
  const auto written = static_cast<std::uint64_t>(std::count(begin, begin + done, '\n'));
  counts_.written += written;
  counts_.lost += static_cast<std::uint64_t>(std::count(begin, begin + used_, '\n')) - written;
  used_ = 0;
  return ok;
}

bool CountedLineFile::close() noexcept {
  if (fd_ < 0) return true;
  const bool flushed = flush();
  const bool closed = ::close(fd_) == 0;
  fd_ = -1;
  const bool finished = output_.finish();
  return flushed && closed && finished;
}

LineCounts CountedLineFile::take_counts() noexcept {
  const LineCounts c = counts_;
  counts_ = LineCounts{};
  return c;
}

}  // namespace numen::hal
