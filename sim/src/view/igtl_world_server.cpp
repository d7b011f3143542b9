/// @file igtl_world_server.cpp
/// The god-object world as OpenIGTLink TRANSFORMs (igtl_world_server.hpp): POSIX sockets,
/// messages packed by the library (hal::pack_igtl_transform()).

#include "numen/sim/view/igtl_world_server.hpp"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <stdexcept>

#include "numen/hal/features.hpp"
#include "numen/platform/state_frame.hpp"
#include "net/tcp_listen.hpp"
#if NUMEN_WITH_OPENIGTLINK
#include "numen/hal/igtl/igtl_message.hpp"
#endif

namespace numen::sim {

IgtlWorldServer::IgtlWorldServer(std::vector<std::string> body_names, IgtlWorldSettings settings)
    : names_(std::move(body_names)), settings_(std::move(settings)) {
  if (!hal::kWithOpenIgtLink)
    throw std::runtime_error("--igtl needs OpenIGTLink: this build has NUMEN_WITH_OPENIGTLINK=OFF");
  for (const std::string& n : names_)
    if (n.size() > 13)
      throw std::invalid_argument("--igtl: body name '" + n + "' is longer than 13 characters ('" +
                                  n + "_target' must fit OpenIGTLink's 20)");
  const TcpListener l = tcp_listen(settings_.host, settings_.port, true, 8, "--igtl");
  listen_fd_ = l.fd;
  port_ = l.port;
  clients_.reserve(settings_.max_clients);
}

IgtlWorldServer::~IgtlWorldServer() {
  for (Client& c : clients_) close(c.fd);
  if (listen_fd_ >= 0) close(listen_fd_);
}

std::size_t IgtlWorldServer::accept_clients() noexcept {
  for (;;) {
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) break;
    if (clients_.size() >= settings_.max_clients) {
      close(fd);
      ++counters_.clients_refused;
      continue;
    }
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    clients_.push_back(Client{fd, {}});
    ++counters_.clients_total;
  }
  return clients_.size();
}

void IgtlWorldServer::send_some(Client& c) noexcept {
  while (!c.backlog.empty()) {
    const ssize_t k = send(c.fd, c.backlog.data(), c.backlog.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (k > 0) {
      c.backlog.erase(0, static_cast<std::size_t>(k));
      continue;
    }
    if (k < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return;
    close(c.fd);  // closed by the client, reset
    c.fd = -1;
    return;
  }
}

void IgtlWorldServer::drop_gone() noexcept {
  const auto gone = std::remove_if(clients_.begin(), clients_.end(),
                                   [](const Client& c) { return c.fd < 0; });
  counters_.clients_gone += static_cast<std::uint64_t>(clients_.end() - gone);
  clients_.erase(gone, clients_.end());
}

bool IgtlWorldServer::write_frame(std::span<const std::byte> frame) noexcept {
  ++counters_.frames;
  accept_clients();
  platform::StateFrameView view;
  if (!platform::StateFrameDecoder::decode(frame, view).ok()) {
    ++counters_.frames_bad;
    return false;
  }
  if (clients_.empty()) return true;
#if NUMEN_WITH_OPENIGTLINK
  try {
    batch_.clear();
    const platform::StateFrameHeader& h = view.header();
    const std::size_t n = std::min<std::size_t>(h.num_bodies, names_.size());
    std::size_t messages = 0;
    const auto add = [&](const std::string& name, const float p[7]) {
      const core::Quat q(p[6], p[3], p[4], p[5]);
      batch_ += hal::pack_igtl_transform(name, h.time_ns, q.normalized().toRotationMatrix(),
                                         core::Vec3(p[0], p[1], p[2]) * 1e3);  // mm
      ++messages;
    };
    float pose[7];
    for (std::size_t b = 0; b < n; ++b) {
      view.body_pose(static_cast<std::uint32_t>(b), pose);
      add(names_[b], pose);
      if (view.target_pose(static_cast<std::uint32_t>(b), pose)) add(names_[b] + "_target", pose);
    }
    for (Client& c : clients_) {
      if (c.backlog.size() + batch_.size() > settings_.max_backlog_bytes) {
        ++counters_.frames_skipped;  // a slow client misses this frame
      } else {
        c.backlog += batch_;
        counters_.messages += messages;
      }
      send_some(c);
    }
  } catch (...) {  // out of memory packing a message: the frame is not served
    return false;
  }
#endif
  drop_gone();
  return true;
}

bool IgtlWorldServer::flush() noexcept {
  for (Client& c : clients_) send_some(c);
  drop_gone();
  return true;
}

}  // namespace numen::sim
