/// @file standard_streams.cpp

#include "standard_streams.hpp"

#include <fcntl.h>
#include <stdio_ext.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <streambuf>

namespace numen::app {
namespace {

/// std::cout's buffer once guard_standard_streams() has run: bytes go to descriptor 1 by
/// write(2), and the errno of the first write that fails is kept until stdout_failure() takes
/// it (C's stdio keeps only a flag, and drops the reason with the bytes). What a failed write
/// did not write is dropped, never tried again.
class StdoutBuffer final : public std::streambuf {
 public:
  StdoutBuffer() { setp(bytes_, bytes_ + sizeof bytes_); }

  /// The errno of the first failed write since the last call (0: none), cleared.
  int take_error() noexcept {
    const int e = error_;
    error_ = 0;
    return e;
  }

 protected:
  int_type overflow(int_type c) override {
    if (!write_out()) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override { return write_out() ? 0 : -1; }

 private:
  /// Writes the buffered bytes; false (and the errno kept) if write(2) fails.
  bool write_out() noexcept {
    const char* at = pbase();
    auto left = static_cast<std::size_t>(pptr() - pbase());
    setp(bytes_, bytes_ + sizeof bytes_);  // written or dropped
    while (left > 0) {
      const ssize_t n = ::write(STDOUT_FILENO, at, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        if (error_ == 0) error_ = n < 0 ? errno : EIO;
        return false;
      }
      at += n;
      left -= static_cast<std::size_t>(n);
    }
    return true;
  }

  char bytes_[8192];
  int error_ = 0;
};

/// The buffer installed on std::cout (null before guard_standard_streams()). Never destroyed:
/// std::cout is flushed once more at exit, after the statics of this file are gone.
StdoutBuffer* g_stdout = nullptr;

}  // namespace

void guard_standard_streams() noexcept {
  std::signal(SIGPIPE, SIG_IGN);
  for (const int fd : {STDIN_FILENO, STDOUT_FILENO, STDERR_FILENO}) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    // open() takes the lowest free descriptor: `fd`, the lower ones being open already.
    const int held = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (held >= 0 && held != fd) ::close(held);
  }
  if (g_stdout == nullptr) {
    std::cout.flush();
    g_stdout = new StdoutBuffer;  // NOLINT(cppcoreguidelines-owning-memory): see g_stdout
    std::cout.rdbuf(g_stdout);
  }
}

std::string stdout_failure() {
  std::cout.flush();
  int reason = g_stdout != nullptr ? g_stdout->take_error() : 0;
  if (reason == 0 && !std::cout) reason = EIO;
  std::cout.clear();
  // Anything written through C's stdio (printf) instead: its buffer is written now, so that a
  // failure of these last bytes leaves its reason in errno.
  errno = 0;
  const bool flush_failed = std::fflush(stdout) != 0;
  if (flush_failed || std::ferror(stdout) != 0) {
    if (reason == 0) reason = flush_failed && errno != 0 ? errno : EIO;
    __fpurge(stdout);
    std::clearerr(stdout);
  }
  return reason == 0 ? "" : std::strerror(reason);
}

int with_stdout_checked(int status) {
  const std::string lost = stdout_failure();
  if (lost.empty()) return status;
  std::cerr << "numen: stdout: cannot write the output (" << lost << ")\n";
  return status == 0 ? 1 : status;  // 1: ExitStatus::kError (docs/outputs.md)
}

}  // namespace numen::app
