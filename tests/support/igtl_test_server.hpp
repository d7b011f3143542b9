#pragma once
/// @file igtl_test_server.hpp
/// A loopback TCP server for the OpenIGTLink tests (tests/hal/igtl): listens on 127.0.0.1 at an
/// ephemeral port (bind port 0: parallel ctest runs never clash), accepts one client in a thread
/// and sends it the given byte strings in order (OpenIGTLink messages, or garbage), then keeps
/// the connection open until close_client() or destruction (or closes it at once when asked:
/// a server that goes away), optionally pausing before one of them (a tracker that stalls). Never
/// hangs: accept waits at most `accept_timeout_ms`.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

namespace numen::test {

/// One-client loopback server (see the file comment).
class IgtlTestServer {
 public:
  /// Starts listening; the thread accepts and sends `messages`; `close_after`: close the
  /// connection once they are sent; `pause_ms` ms of silence before message `pause_at`.
  explicit IgtlTestServer(std::vector<std::string> messages, bool close_after = false,
                          int accept_timeout_ms = 5000, std::size_t pause_at = SIZE_MAX,
                          int pause_ms = 0)
      : messages_(std::move(messages)), close_after_(close_after), pause_at_(pause_at),
        pause_ms_(pause_ms) {
    fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
    listen(fd_, 1);
    socklen_t len = sizeof a;
    getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this, accept_timeout_ms] { serve(accept_timeout_ms); });
  }
  ~IgtlTestServer() {
    done_ = true;
    thread_.join();
    close(fd_);
  }
  IgtlTestServer(const IgtlTestServer&) = delete;
  IgtlTestServer& operator=(const IgtlTestServer&) = delete;

  std::uint16_t port() const noexcept { return port_; }
  /// Every message was sent.
  bool all_sent() const noexcept { return all_sent_; }
  /// Closes the client's connection (the server goes away mid-run).
  void close_client() noexcept { done_ = true; }

  /// A free loopback port nobody listens on (bound, then closed): a server that never answers.
  static std::uint16_t closed_port() {
    const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    socklen_t len = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    close(fd);
    return ntohs(a.sin_port);
  }

 private:
  void serve(int accept_timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, accept_timeout_ms) <= 0) return;
    const int c = accept(fd_, nullptr, nullptr);
    if (c < 0) return;
    const timeval slice{0, 100'000};  // a blocked send() rechecks done_ every 100 ms
    setsockopt(c, SOL_SOCKET, SO_SNDTIMEO, &slice, sizeof slice);
    for (std::size_t i = 0; i < messages_.size(); ++i) {
      const std::string& m = messages_[i];
      if (i == pause_at_) {  // the silence, to the millisecond (a stop heard within one)
        const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(pause_ms_);
        while (!done_ && std::chrono::steady_clock::now() < until) usleep(1000);
      }
      std::size_t sent = 0;
      while (sent < m.size() && !done_) {
        const ssize_t k = send(c, m.data() + sent, m.size() - sent, MSG_NOSIGNAL);
        if (k < 0 && (errno == EAGAIN || errno == EINTR)) continue;
        if (k <= 0) break;
        sent += static_cast<std::size_t>(k);
      }
    }
    all_sent_ = true;
    while (!close_after_ && !done_) usleep(1000);
    close(c);
  }

  std::vector<std::string> messages_;
  bool close_after_;
  std::size_t pause_at_;
  int pause_ms_;
  int fd_ = -1;
  std::uint16_t port_ = 0;
  std::atomic<bool> done_{false};
  std::atomic<bool> all_sent_{false};
  std::thread thread_;
};

}  // namespace numen::test
