/// @file line_file.cpp
/// LineFile: stdio file for record sinks, every failure returned.

#include "numen/hal/transport/line_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace numen::hal {

LineFile::LineFile(const std::string& path) : path_(path) {
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
  }
}

LineFile::~LineFile() { close(); }

bool LineFile::write(const char* data, std::size_t size) noexcept {
  return file_ != nullptr && std::fwrite(data, 1, size, file_) == size;
}

bool LineFile::flush() noexcept { return file_ != nullptr && std::fflush(file_) == 0; }

bool LineFile::close() noexcept {
  if (file_ == nullptr) return true;
  const bool ok = std::fclose(file_) == 0;
  file_ = nullptr;
  return ok;
}

CountedLineFile::CountedLineFile(const std::string& path, std::size_t buffer_bytes)
    : path_(path), buffer_(std::max<std::size_t>(buffer_bytes, 1)) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd_ < 0) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open for writing: " + std::strerror(err));
  }
}

CountedLineFile::~CountedLineFile() { close(); }

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
  return flushed && closed;
}

LineCounts CountedLineFile::take_counts() noexcept {
  const LineCounts c = counts_;
  counts_ = LineCounts{};
  return c;
}

}  // namespace numen::hal
