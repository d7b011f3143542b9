/// @file igtl_tracker_client.cpp
/// The OpenIGTLink receiver thread (igtl_tracker_client.hpp): TCP through POSIX sockets and
/// poll(2) with short timeouts (so that stop() is heard within ~50 ms), messages through the
/// library (igtl_message.hpp).

#include "numen/hal/igtl/igtl_tracker_client.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <stdexcept>

namespace numen::hal {

namespace {

constexpr int kIgtlPollSliceMs = 50;

std::int64_t igtl_mono_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

std::string describe(const IgtlFaultRecord& r) {
  return std::string(to_string(r.fault)) + ": " + (r.type.empty() ? "?" : r.type) + " '" +
         r.device_name + "', message " + std::to_string(r.message) + " at stream byte " +
         std::to_string(r.stream_offset) + ", field at byte " + std::to_string(r.byte_offset);
}

IgtlTrackerClient::IgtlTrackerClient(IgtlTrackerClientSettings settings)
    : settings_(std::move(settings)) {
  const auto bad = [](const std::string& what) {
    return std::invalid_argument("OpenIGTLink tracker client: " + what);
  };
  std::vector<std::string> tools = {settings_.device_name};
  tools.insert(tools.end(), settings_.more_device_names.begin(), settings_.more_device_names.end());
  if (tools.size() > kIgtlMaxTools)
    throw bad(std::to_string(tools.size()) + " tools: at most " + std::to_string(kIgtlMaxTools));
  for (std::size_t k = 0; k < tools.size(); ++k) {
    if (tools[k].empty() || tools[k].size() > 20)
      throw bad("device_name '" + tools[k] + "' must have 1 to 20 characters");
    if (std::find(tools.begin(), tools.begin() + static_cast<std::ptrdiff_t>(k), tools[k]) !=
        tools.begin() + static_cast<std::ptrdiff_t>(k))
      throw bad("device_name '" + tools[k] + "' names two tools");
  }
  if (settings_.registration_name.size() > 20 ||
      std::find(tools.begin(), tools.end(), settings_.registration_name) != tools.end())
    throw bad("registration_name '" + settings_.registration_name +
              "' must have at most 20 characters and not be a tool's device name");
  if (settings_.port == 0) throw bad("port must be 1..65535");
  if (settings_.host.empty()) throw bad("host is empty");
  if (settings_.queue_poses == 0) throw bad("queue_poses must be >= 1");
  if (settings_.connect_timeout_ns <= 0 || settings_.reconnect_interval_ns <= 0)
    throw bad("connect_timeout_ns and reconnect_interval_ns must be > 0");
  for (std::size_t k = 0; k < tools.size(); ++k)
    queues_.push_back(
        std::make_unique<boost::lockfree::spsc_queue<IgtlPose>>(settings_.queue_poses));
  records_.reserve(kIgtlFaultCount);
  names_.reserve(kIgtlMaxNamesSeen);
  thread_ = std::thread([this] { run(); });
}

IgtlTrackerClient::~IgtlTrackerClient() { stop(); }

void IgtlTrackerClient::stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

const IgtlPose* IgtlTrackerClient::front(std::size_t tool) noexcept {
  if (tool >= queues_.size() || queues_[tool]->read_available() == 0) return nullptr;
  return &queues_[tool]->front();
}

void IgtlTrackerClient::pop(std::size_t tool) noexcept {
  if (tool < queues_.size()) queues_[tool]->pop();
}

IgtlClientCounters IgtlTrackerClient::counters() const noexcept {
  IgtlClientCounters c;
  const auto get = [](const std::atomic<std::uint64_t>& a) {
    return a.load(std::memory_order_relaxed);
  };
  c.messages = get(messages_);
  c.bytes = get(bytes_);
  c.poses = get(poses_);
  for (std::size_t i = 0; i < tool_poses_.size(); ++i) c.tool_poses[i] = get(tool_poses_[i]);
  c.other_devices = get(other_devices_);
  c.ignored = get(ignored_);
  for (std::size_t i = 0; i < faults_.size(); ++i) c.faults[i] = get(faults_[i]);
  c.dropped_full = get(dropped_full_);
  c.connects = get(connects_);
  c.connect_failures = get(connect_failures_);
  c.disconnects = get(disconnects_);
  return c;
}

std::vector<IgtlFaultRecord> IgtlTrackerClient::fault_records() const {
  std::lock_guard<std::mutex> lock(records_mutex_);
  return records_;
}

std::optional<IgtlTransform> IgtlTrackerClient::registration() const {
  std::lock_guard<std::mutex> lock(records_mutex_);
  return registration_;
}

std::optional<IgtlFaultRecord> IgtlTrackerClient::registration_refused() const {
  std::lock_guard<std::mutex> lock(records_mutex_);
  return registration_refused_;
}

std::vector<std::string> IgtlTrackerClient::names_seen() const {
  std::lock_guard<std::mutex> lock(records_mutex_);
  return names_;
}

void IgtlTrackerClient::fault(IgtlFault f, const IgtlHeader& h, std::uint64_t message,
                              std::uint64_t at, std::size_t offset) {
  count(faults_[static_cast<std::size_t>(f)]);
  std::lock_guard<std::mutex> lock(records_mutex_);
  for (const IgtlFaultRecord& r : records_)
    if (r.fault == f) return;  // the first of each kind: bounded
  records_.push_back(IgtlFaultRecord{f, h.type, h.device_name, message, at, offset});
}

std::size_t IgtlTrackerClient::tool_of(const std::string& name) const noexcept {
  if (name == settings_.device_name) return 0;
  for (std::size_t k = 0; k < settings_.more_device_names.size(); ++k)
    if (name == settings_.more_device_names[k]) return k + 1;
  return queues_.size();
}

void IgtlTrackerClient::push(const IgtlPose& pose, std::size_t tool) {
  count(poses_);
  count(tool_poses_[tool]);
  // The time origin is the first stamped pose: an unstamped one (0) has no place on the clock.
  if (!has_first_stamp_.load(std::memory_order_relaxed) && pose.stamp_ns != 0) {  // one writer
    first_stamp_ns_ = pose.stamp_ns;
    has_first_stamp_.store(true, std::memory_order_release);
  }
  while (!queues_[tool]->push(pose)) {
    if (!settings_.wait_when_full) {
      count(dropped_full_);
      return;
    }
    if (stop_.load(std::memory_order_acquire)) return;
    const timespec ts{0, 100'000};
    nanosleep(&ts, nullptr);
  }
}

int IgtlTrackerClient::connect_once() {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const std::string port = std::to_string(settings_.port);
  if (getaddrinfo(settings_.host.c_str(), port.c_str(), &hints, &list) != 0) return -1;
  int fd = -1;
  for (addrinfo* a = list; a != nullptr && fd < 0; a = a->ai_next) {
    fd = socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    if (connect(fd, a->ai_addr, a->ai_addrlen) == 0) break;
    bool ok = false;
    if (errno == EINPROGRESS) {
      const std::int64_t deadline = igtl_mono_now_ns() + settings_.connect_timeout_ns;
      while (!stop_.load(std::memory_order_acquire) && igtl_mono_now_ns() < deadline) {
        pollfd p{fd, POLLOUT, 0};
        const int r = poll(&p, 1, kIgtlPollSliceMs);
        if (r > 0) {
          int err = 0;
          socklen_t len = sizeof err;
          getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
          ok = err == 0;
          break;
        }
        if (r < 0 && errno != EINTR) break;
      }
    }
    if (!ok) {
      close(fd);
      fd = -1;
    }
  }
  freeaddrinfo(list);
  if (fd >= 0) {
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  return fd;
}

IgtlTrackerClient::ReadResult IgtlTrackerClient::read_fully(int fd, std::uint8_t* out,
                                                            std::size_t n) {
  std::size_t got = 0;
  while (got < n) {
    if (stop_.load(std::memory_order_acquire)) return ReadResult::kStopped;
    pollfd p{fd, POLLIN, 0};
    const int r = poll(&p, 1, kIgtlPollSliceMs);
    if (r == 0 || (r < 0 && errno == EINTR)) continue;
    if (r < 0) return ReadResult::kClosed;
    const ssize_t k = recv(fd, out + got, n - got, 0);
    if (k == 0) return ReadResult::kClosed;
    if (k < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      return ReadResult::kClosed;
    }
    got += static_cast<std::size_t>(k);
    count(bytes_, static_cast<std::uint64_t>(k));
  }
  return ReadResult::kOk;
}

void IgtlTrackerClient::session(int fd) {
  IgtlDecoder decoder;
  std::array<std::uint8_t, kIgtlHeaderBytes> head{};
  std::array<std::uint8_t, 4096> scratch{};  // bodies read and discarded: memory never grows
  IgtlHeader h;
  IgtlTransform tf;
  std::uint64_t at = 0;  // stream offset of the message
  for (std::uint64_t message = 0;; ++message) {
    if (read_fully(fd, head.data(), head.size()) != ReadResult::kOk) return;
    count(messages_);
    const IgtlDecodeResult hr = decoder.decode_header(head, settings_.max_body_bytes, h);
    if (!hr.ok()) {  // the framing is lost: the caller drops the connection
      fault(hr.fault, h, message, at, hr.byte_offset);
      return;
    }
    if (h.version == 1 && igtl_pose_body_size_ok(h.type, h.body_size)) {  // a pose message
      const auto n = static_cast<std::size_t>(h.body_size);
      if (read_fully(fd, scratch.data(), n) != ReadResult::kOk) return;
      const IgtlDecodeResult br = decoder.decode_pose(
          h, std::span<const std::uint8_t>(scratch.data(), n), tf, settings_.rigid_tolerance);
      if (!br.ok()) {
        fault(br.fault, h, message, at, br.byte_offset);
        if (!settings_.registration_name.empty() && h.device_name == settings_.registration_name) {
          std::lock_guard<std::mutex> lock(records_mutex_);
          registration_refused_ =
              IgtlFaultRecord{br.fault, h.type, h.device_name, message, at, br.byte_offset};
        }
      } else if (const std::size_t tool = tool_of(h.device_name); tool < queues_.size()) {
        IgtlPose pose;
        pose.stamp_ns = igtl_stamp_ns(h.timestamp_raw);
        pose.received_mono_ns = igtl_mono_now_ns();
        pose.rotation = tf.rotation;
        pose.translation = tf.translation;
        push(pose, tool);
      } else if (!settings_.registration_name.empty() &&
                 h.device_name == settings_.registration_name) {
        std::lock_guard<std::mutex> lock(records_mutex_);
        registration_ = tf;
      } else {
        count(other_devices_);
        std::lock_guard<std::mutex> lock(records_mutex_);
        if (names_.size() < kIgtlMaxNamesSeen &&
            std::find(names_.begin(), names_.end(), h.device_name) == names_.end())
          names_.push_back(h.device_name);
      }
    } else {
      if (igtl_pose_type(h.type) && h.version != 1)
        fault(IgtlFault::kUnsupportedVersion, h, message, at, kIgtlVersionOffset);
      else if (igtl_pose_type(h.type))
        fault(IgtlFault::kBodySizeMismatch, h, message, at, kIgtlBodySizeOffset);
      else if (!igtl_known_type(h.type))
        fault(IgtlFault::kUnknownType, h, message, at, kIgtlTypeOffset);
      else
        count(ignored_);
      for (std::uint64_t left = h.body_size; left > 0;) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, scratch.size()));
        if (read_fully(fd, scratch.data(), n) != ReadResult::kOk) return;
        left -= n;
      }
    }
    at += kIgtlHeaderBytes + h.body_size;
  }
}

void IgtlTrackerClient::run() {
  while (!stop_.load(std::memory_order_acquire)) {
    const int fd = connect_once();
    if (fd < 0) {
      if (stop_.load(std::memory_order_acquire)) break;
      count(connect_failures_);
    } else {
      count(connects_);
      connected_.store(true, std::memory_order_release);
      session(fd);
      connected_.store(false, std::memory_order_release);
      close(fd);
      if (stop_.load(std::memory_order_acquire)) break;
      count(disconnects_);
    }
    if (!settings_.reconnect) break;
    const std::int64_t until = igtl_mono_now_ns() + settings_.reconnect_interval_ns;
    while (!stop_.load(std::memory_order_acquire) && igtl_mono_now_ns() < until) {
      const timespec ts{0, 10'000'000};
      nanosleep(&ts, nullptr);
    }
  }
  ended_.store(true, std::memory_order_release);
}

}  // namespace numen::hal
