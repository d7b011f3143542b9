#pragma once
/// @file pseudo_terminal.hpp
/// A pseudo-terminal pair for the tests that put numen's serial line (SerialBus,
/// `--bus serial:PATH`) on a real tty: the code under test opens `path` (the slave), the test
/// plays the far end on `master` (non-blocking). Header-only; POSIX.

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>

namespace numen::test {

/// openpty() pair. The slave stays open (`slave`) until destruction: a pty with no slave open
/// hangs up, and the test may poll(2) it to see what reached the code under test's side
/// (the line discipline's input is one buffer, whichever descriptor reads it). Throws
/// std::runtime_error when openpty fails.
struct Pty {
  int master = -1;
  int slave = -1;
  std::string path;  ///< The slave's path, e.g. /dev/pts/3.
  Pty() {
    if (::openpty(&master, &slave, nullptr, nullptr, nullptr) != 0)
      throw std::runtime_error(std::string("openpty: ") + std::strerror(errno));
    char name[256];
    ::ttyname_r(slave, name, sizeof(name));
    path = name;
    ::fcntl(master, F_SETFL, ::fcntl(master, F_GETFL) | O_NONBLOCK);
  }
  ~Pty() {
    ::close(master);
    ::close(slave);
  }
  Pty(const Pty&) = delete;
  Pty& operator=(const Pty&) = delete;
};

/// Writes all of `bytes` to the non-blocking descriptor `fd`, waiting for room (poll POLLOUT)
/// while it is full. False, errno set, on an error other than EAGAIN.
inline bool write_all(int fd, std::span<const std::uint8_t> bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else {
      if (n < 0 && errno != EAGAIN) return false;
      pollfd p{fd, POLLOUT, 0};
      ::poll(&p, 1, 100);
    }
  }
  return true;
}

}  // namespace numen::test
