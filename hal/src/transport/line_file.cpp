/// @file line_file.cpp
/// LineFile: stdio file for record sinks, every failure returned; written to a temporary file
/// renamed over the path on close (line_file.hpp).

#include "numen/hal/transport/line_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

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

/// The permission bits a new file gets from fopen(): 0666 less the process's umask.
mode_t default_mode() {
  const mode_t mask = ::umask(0);
  ::umask(mask);
  return static_cast<mode_t>(0666 & ~mask);
}

}  // namespace

LineFile::LineFile(const std::string& path)
    : path_(path), target_(path), unwinding_at_open_(std::uncaught_exceptions()) {
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) fail(path, EISDIR);
  if (exists && !S_ISREG(st.st_mode)) {  // a device, a FIFO, a terminal: written in place
    file_ = std::fopen(path.c_str(), "w");
    if (file_ == nullptr) fail(path, errno);
    return;
  }
  if (exists) {
    if (::access(path.c_str(), W_OK) != 0) fail(path, errno);  // as fopen(path, "w") would
    char resolved[PATH_MAX];
    if (::realpath(path.c_str(), resolved) != nullptr) target_ = resolved;  // a link's target
  }
  const std::size_t slash = target_.rfind('/');
  const std::string dir = slash == std::string::npos ? "" : target_.substr(0, slash + 1);
  const std::string base = slash == std::string::npos ? target_ : target_.substr(slash + 1);
  std::string temp = dir + "." + base + ".XXXXXX";
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) {
    const int err = errno;
    if (!exists) fail(path, err);  // no such directory, a directory not writable
    file_ = std::fopen(path.c_str(), "w");  // the file is writable, its directory is not
    if (file_ == nullptr) fail(path, errno);
    return;
  }
  ::fchmod(fd, exists ? (st.st_mode & 07777) : default_mode());
  file_ = ::fdopen(fd, "w");
  if (file_ == nullptr) {
    const int err = errno;
    ::close(fd);
    ::unlink(temp.c_str());
    fail(path, err);
  }
  temp_ = std::move(temp);
}

LineFile::~LineFile() { discard(); }

bool LineFile::write(const char* data, std::size_t size) noexcept {
  return file_ != nullptr && std::fwrite(data, 1, size, file_) == size;
}

bool LineFile::flush() noexcept { return file_ != nullptr && std::fflush(file_) == 0; }

void LineFile::discard() noexcept {
  if (file_ == nullptr) return;
  std::fclose(file_);
  file_ = nullptr;
  if (!temp_.empty()) ::unlink(temp_.c_str());
  temp_.clear();
}

bool LineFile::close() noexcept {
  if (file_ == nullptr) return true;
  if (std::uncaught_exceptions() > unwinding_at_open_) {  // the run was refused: keep `path`
    discard();
    return true;
  }
  bool ok = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!temp_.empty()) {
    if (::rename(temp_.c_str(), target_.c_str()) != 0) {
      ok = false;
      ::unlink(temp_.c_str());
    }
    temp_.clear();
  }
  return ok;
}

}  // namespace numen::hal
