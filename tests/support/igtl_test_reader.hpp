#pragma once
/// @file igtl_test_reader.hpp
/// A loopback OpenIGTLink client for the tests of numen's servers (tests/sim/view): connects to
/// 127.0.0.1 (or [::1]) at a port, and reads whole messages (58-byte header, then the body of
/// the size it says) into raw byte strings, in order, with bounded waits (poll, never more than
/// the timeout given). Decoding is the caller's (hal::unpack_igtl(), the library's classes).
/// Header-only.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace numen::test {

/// One client (see the file comment).
class IgtlTestReader {
 public:
  /// Connects (blocking; loopback answers at once). connected() says whether it did.
  explicit IgtlTestReader(std::uint16_t port, bool ipv6 = false) {
    fd_ = socket(ipv6 ? AF_INET6 : AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    int r = -1;
    if (ipv6) {
      sockaddr_in6 a{};
      a.sin6_family = AF_INET6;
      a.sin6_addr = in6addr_loopback;
      a.sin6_port = htons(port);
      r = connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    } else {
      sockaddr_in a{};
      a.sin_family = AF_INET;
      a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      a.sin_port = htons(port);
      r = connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    }
    connected_ = r == 0;
  }
  ~IgtlTestReader() { close(fd_); }
  IgtlTestReader(const IgtlTestReader&) = delete;
  IgtlTestReader& operator=(const IgtlTestReader&) = delete;

  bool connected() const noexcept { return connected_; }
  /// Whole messages read so far, in order.
  const std::vector<std::string>& messages() const noexcept { return messages_; }
  /// The type name of message `m` (its header's bytes 2..13, NUL padding removed).
  static std::string type_of(const std::string& m) { return field(m, 2, 12); }
  /// The device name of message `m` (bytes 14..33).
  static std::string name_of(const std::string& m) { return field(m, 14, 20); }

  /// Reads what arrives for at most `wait_ms` (returns earlier once `done()` holds after a read);
  /// `between()` runs before each poll slice (e.g. the server's flush()). Returns done().
  template <typename Done, typename Between>
  bool read_until(Done done, Between between, int wait_ms = 5000) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(wait_ms);
    while (!done()) {
      if (std::chrono::steady_clock::now() > end) return false;
      between();
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 5) <= 0) continue;
      char buf[65536];
      const ssize_t k = recv(fd_, buf, sizeof buf, 0);
      if (k <= 0) return done();  // closed
      pending_.append(buf, static_cast<std::size_t>(k));
      split();
    }
    return true;
  }

 private:
  static std::string field(const std::string& m, std::size_t at, std::size_t n) {
    if (m.size() < at + n) return {};
    std::string s = m.substr(at, n);
    return s.substr(0, s.find('\0'));
  }
  // Whole messages out of pending_.
  void split() {
    for (;;) {
      if (pending_.size() < 58) return;
      std::uint64_t body = 0;
      for (int i = 0; i < 8; ++i) body = (body << 8) | static_cast<std::uint8_t>(pending_[42 + i]);
      if (pending_.size() < 58 + body) return;
      messages_.push_back(pending_.substr(0, 58 + body));
      pending_.erase(0, 58 + body);
    }
  }
  int fd_ = -1;
  bool connected_ = false;
  std::string pending_;
  std::vector<std::string> messages_;
};

}  // namespace numen::test
