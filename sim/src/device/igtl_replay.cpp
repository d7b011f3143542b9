/// @file igtl_replay.cpp
/// The OpenIGTLink replay server (igtl_replay.hpp): POSIX sockets, messages packed by the
/// OpenIGTLink library (hal::pack_igtl_transform(), pack_igtl_position(), pack_igtl_qtrans()).

#include "numen/sim/device/igtl_replay.hpp"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <stdexcept>

#include "numen/hal/features.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"
#include "net/tcp_listen.hpp"
#if NUMEN_WITH_OPENIGTLINK
#include "numen/hal/igtl/igtl_message.hpp"
#include "numen/hal/igtl/igtl_pack.hpp"
#endif

namespace numen::sim {

#if NUMEN_WITH_OPENIGTLINK
namespace {

std::int64_t igtl_replay_clock_ns(clockid_t clock) noexcept {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Sends all of `data`; false when the client has gone (or `stop`).
bool igtl_replay_send_all(int fd, const std::string& data, const std::atomic<bool>* stop) {
  std::size_t sent = 0;
  while (sent < data.size()) {
    if (stop != nullptr && stop->load(std::memory_order_relaxed)) return false;
    pollfd p{fd, POLLOUT, 0};
    const int r = poll(&p, 1, 50);
    if (r == 0 || (r < 0 && errno == EINTR)) continue;
    if (r < 0 || (p.revents & (POLLERR | POLLHUP)) != 0) return false;
    const ssize_t k = send(fd, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
    if (k < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      return false;
    }
    sent += static_cast<std::size_t>(k);
  }
  return true;
}

}  // namespace
#endif

IgtlReplayServer::IgtlReplayServer(const Scene& scene, IgtlReplaySettings settings)
    : scene_(&scene), settings_(std::move(settings)) {
  if (!scene.igtl)
    throw InputError(scene.file, 0, 0, "igtl",
                     "the scene has no [device.igtl]: nothing names the tool to replay");
  if (const IgtlTrackerScene& t = *scene.igtl; !t.registration_name.empty())
    throw InputError(t.registration_file, t.registration_line, t.registration_column,
                     "device.igtl.registration",
                     "igtl-replay places the tool in the tracker's frame with the scene's "
                     "registration; this one is read from the TRANSFORM '" + t.registration_name +
                         "' at start, which the replay does not have: give a fixed registration "
                         "= { position, orientation } to replay");
  if (!std::isfinite(settings_.rate_hz) || settings_.rate_hz < 0.0)
    throw std::invalid_argument("igtl-replay: rate must be finite and >= 0");
  if (!std::isfinite(settings_.stall_at_s) || settings_.stall_at_s < 0.0 ||
      !std::isfinite(settings_.stall_s) || settings_.stall_s < 0.0)
    throw std::invalid_argument("igtl-replay: a stall's time and length must be finite and >= 0");
  if (!(settings_.accept_timeout_s > 0.0))
    throw std::invalid_argument("igtl-replay: accept timeout must be > 0");
  if (!hal::kWithOpenIgtLink)
    throw std::runtime_error("igtl-replay needs OpenIGTLink: this build has NUMEN_WITH_OPENIGTLINK=OFF");
  const TcpListener l = tcp_listen(settings_.host, settings_.port, false, 1, "igtl-replay");
  listen_fd_ = l.fd;
  port_ = l.port;
}

IgtlReplayServer::~IgtlReplayServer() {
  if (listen_fd_ >= 0) close(listen_fd_);
}

IgtlReplayResult IgtlReplayServer::serve(const std::atomic<bool>* stop) {
  IgtlReplayResult result;
#if NUMEN_WITH_OPENIGTLINK
  const Scene& scene = *scene_;
  const IgtlTrackerScene& t = *scene.igtl;
  const auto stopped = [stop] { return stop != nullptr && stop->load(std::memory_order_relaxed); };
  int fd = -1;
  const std::int64_t give_up =
      igtl_replay_clock_ns(CLOCK_MONOTONIC) + std::llround(settings_.accept_timeout_s * 1e9);
  while (fd < 0 && !stopped() && igtl_replay_clock_ns(CLOCK_MONOTONIC) < give_up) {
    pollfd p{listen_fd_, POLLIN, 0};
    if (poll(&p, 1, 50) > 0) fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
  }
  if (fd < 0) return result;
  result.client_connected = true;
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  const SimulatedInstrument instrument(scene.device, scene.trajectory);
  const double period = settings_.rate_hz > 0.0 ? 1.0 / settings_.rate_hz : scene.model.dt;
  const double duration = settings_.duration_s >= 0.0 ? settings_.duration_s : scene.duration_s;
  const std::int64_t count = std::llround(std::floor(duration / period + 1e-6)) + 1;
  const std::int64_t t0_real = igtl_replay_clock_ns(CLOCK_REALTIME);
  const std::int64_t t0_mono = igtl_replay_clock_ns(CLOCK_MONOTONIC);
  const core::Quat reg_inv = t.registration.orientation.conjugate();
  const core::Quat cal_inv = t.calibration.orientation.conjugate();
  // The stall: the poses of [stall_from, stall_to) are not sent; the first one after it waits
  // for the stall's wall time (paced: its own time, which is as long).
  const std::int64_t stall_from = std::llround(settings_.stall_at_s * 1e9);
  const std::int64_t stall_to = stall_from + std::llround(settings_.stall_s * 1e9);
  bool stalled = false;
  for (std::int64_t k = 0; k < count && !stopped(); ++k) {
    if (settings_.disconnect_after >= 0 && k >= settings_.disconnect_after) break;
    const auto tk_ns = static_cast<std::int64_t>(std::llround(static_cast<double>(k) * period * 1e9));
    if (settings_.stall_s > 0.0 && tk_ns >= stall_from && tk_ns < stall_to) continue;
    if (settings_.stall_s > 0.0 && tk_ns >= stall_to && !stalled) {
      stalled = true;
      if (!settings_.paced) {  // a silence of stall_s in wall time, a stop heard within 10 ms
        const std::int64_t until = igtl_replay_clock_ns(CLOCK_MONOTONIC) + (stall_to - stall_from);
        while (!stopped() && igtl_replay_clock_ns(CLOCK_MONOTONIC) < until) {
          const timespec slice{0, 10'000'000};
          nanosleep(&slice, nullptr);
        }
      }
    }
    if (settings_.paced) {
      const std::int64_t due = t0_mono + tk_ns;
      const timespec ts{static_cast<time_t>(due / 1'000'000'000), static_cast<long>(due % 1'000'000'000)};
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
    }
    // The tip (tracked frame) the simulated encoders would give: controlled · tool_offset⁻¹.
    const core::Pose c = instrument.controlled_pose_at(tk_ns + scene.bus.latency_ns);
    const core::Pose& off = scene.device.tool_offset;
    core::Pose p;
    p.orientation = (c.orientation * off.orientation.conjugate()).normalized();
    p.position = c.position - p.orientation * off.position;
    // M = registration⁻¹ · tip · calibration⁻¹
    const core::Quat mq = (reg_inv * p.orientation * cal_inv).normalized();
    const core::Vec3 mp = reg_inv * (p.position - t.registration.position) - mq * t.calibration.position;
    const std::int64_t stamp = t0_real + tk_ns;
    const core::Vec3 sent_p = mp / t.metres_per_unit;
    const std::string msg =
        settings_.message == IgtlReplayMessage::kPosition
            ? hal::pack_igtl_position(t.device_name, stamp, mq, sent_p)
        : settings_.message == IgtlReplayMessage::kQtrans
            ? hal::pack_igtl_qtrans(t.device_name, stamp, mq, sent_p)
            : hal::pack_igtl_transform(t.device_name, stamp, mq.toRotationMatrix(), sent_p);
    if (!igtl_replay_send_all(fd, msg, stop)) {
      result.client_gone = !stopped();
      break;
    }
    ++result.messages_sent;
  }
  close(fd);
#else
  (void)stop;
#endif
  return result;
}

}  // namespace numen::sim
