/// @file igtl_world_server.cpp
/// The god-object world as OpenIGTLink messages (igtl_world_server.hpp): POSIX sockets,
/// messages packed by the library (hal::pack_igtl_transform(), hal/igtl/igtl_pack.hpp).

#include "numen/sim/view/igtl_world_server.hpp"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

#include "net/tcp_listen.hpp"
#include "view/tissue_dimple.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/hal/device/safety_supervisor.hpp"
#include "numen/hal/device/sample_check.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/features.hpp"
#include "numen/platform/state_frame.hpp"
#if NUMEN_WITH_OPENIGTLINK
#include "numen/hal/igtl/igtl_message.hpp"
#include "numen/hal/igtl/igtl_pack.hpp"
#endif

namespace numen::sim {

namespace {

/// The rejection bits of a sample's FaultMask in words ("stale, jump"); kNoData is not one.
std::string rejection_words(std::uint8_t mask) {
  static constexpr std::pair<hal::FaultMask, const char*> kBits[] = {
      {hal::SampleFault::kMalformed, "malformed"}, {hal::SampleFault::kNonFinite, "non-finite"},
      {hal::SampleFault::kOutOfRange, "out of range"}, {hal::SampleFault::kStale, "stale"},
      {hal::SampleFault::kJump, "jump"}};
  std::string out;
  for (const auto& [bit, word] : kBits)
    if ((mask & bit) != 0) out += (out.empty() ? "" : ", ") + std::string(word);
  return out;
}

/// Bytes of events a client's backlog may hold above its limit (a client that reads nothing
/// for long loses them too: memory stays bounded).
constexpr std::size_t kEventsAllowance = std::size_t{64} << 10;

constexpr std::uint8_t kRejectionBits =
    static_cast<std::uint8_t>(~hal::SampleFault::kNoData & 0xFFu);

std::string at_time(std::int64_t t_ns) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "at t = %.3f s", static_cast<double>(t_ns) * 1e-9);
  return buf;
}

}  // namespace

std::string igtl_world_status_name(std::size_t device) {
  return device == 0 ? std::string(kIgtlStatusDevice)
                     : std::string(kIgtlStatusDevice) + "_" + std::to_string(device);
}

std::string igtl_world_transform_name(const std::string& body, bool target, IgtlNameStyle style) {
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument(std::string("--igtl") +
                                 (style == IgtlNameStyle::kPlus ? "-names plus" : "") +
                                 ": body name '" + body + "' " + why);
  };
  if (style == IgtlNameStyle::kNumen) {
    if (body.empty() || body.size() > 13)
      throw bad("must have 1 to 13 characters ('" + body +
                "_target' must fit OpenIGTLink's 20)");
    return target ? body + "_target" : body;
  }
  if (body.empty() || body.size() > 7)
    throw bad("must have 1 to 7 characters with PLUS's names ('" + body +
              "TargetToScene' must fit OpenIGTLink's 20)");
  const auto c0 = static_cast<unsigned char>(body[0]);
  if (!((c0 >= 'a' && c0 <= 'z') || (c0 >= 'A' && c0 <= 'Z')))
    throw bad("must start with a letter for PLUS's names (a frame name starts upper case)");
  std::string name = body;
  name[0] = static_cast<char>(std::toupper(c0));
  name += target ? "TargetToScene" : "ToScene";
  int to = 0;  // PLUS's rule: a "To" before a character that is not lower case parts two frames
  for (std::size_t i = 0; i + 2 < name.size(); ++i)
    if (name[i] == 'T' && name[i + 1] == 'o' &&
        std::islower(static_cast<unsigned char>(name[i + 2])) == 0)
      ++to;
  if (to != 1)
    throw bad("holds 'To' before a character that is not a lower-case letter: PLUS's parser "
              "needs exactly one such 'To' and finds " + std::to_string(to) + " in '" + name + "'");
  return name;
}

/// One deformable's POLYDATA: its points are the net's nodes, or its fine surface's vertices.
struct IgtlWorldServer::Organ {
  int net = -1;
  bool fine = false;
  std::vector<core::Vec3> points;  // mm, this frame's
  // An organ given by its material: the tools' dimples drawn on it (view/tissue_dimple.hpp), with
  // its triangles, its vertices' normals and the dimples' scratch; empty otherwise.
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<core::Vec3> normals;
  std::vector<double> moves;
#if NUMEN_WITH_OPENIGTLINK
  std::unique_ptr<hal::IgtlPolyDataPacker> packer;
#endif
};

/// One suture thread's POLYDATA: its nodes as points, its polyline (or two, broken) as LINES.
struct IgtlWorldServer::Thread {
  std::size_t node_begin = 0;  // its first node in the frame's thread_node
  int broken = -1;             // the broken segment its lines were made for (−1: whole)
  std::vector<core::Vec3> points;  // mm, this frame's
#if NUMEN_WITH_OPENIGTLINK
  std::unique_ptr<hal::IgtlPolyDataPacker> packer;
#endif
};

#if NUMEN_WITH_OPENIGTLINK
namespace {

/// The polylines of a thread of `count` nodes broken at segment `broken` (−1: whole): nodes
/// 0 … broken and broken + 1 … count − 1, each kept when it has two nodes or more.
std::vector<std::vector<std::uint32_t>> thread_lines(std::size_t count, int broken) {
  std::vector<std::vector<std::uint32_t>> lines;
  const std::size_t cut = broken >= 0 && static_cast<std::size_t>(broken) + 1 < count
                              ? static_cast<std::size_t>(broken) + 1
                              : count;
  for (const auto& [lo, hi] : {std::pair{std::size_t{0}, cut}, std::pair{cut, count}}) {
    if (hi < lo + 2) continue;
    std::vector<std::uint32_t>& l = lines.emplace_back();
    for (std::size_t i = lo; i < hi; ++i) l.push_back(static_cast<std::uint32_t>(i));
  }
  return lines;
}

}  // namespace
#endif

IgtlWorldServer::IgtlWorldServer(const core::Model& model, IgtlWorldSettings settings)
    : model_(model), settings_(std::move(settings)) {
  if (!hal::kWithOpenIgtLink)
    throw std::runtime_error("--igtl needs OpenIGTLink: this build has NUMEN_WITH_OPENIGTLINK=OFF");
  if (!std::isfinite(settings_.organ_rate_hz) || settings_.organ_rate_hz < 0.0)
    throw std::invalid_argument("--igtl-organ-rate: " + std::to_string(settings_.organ_rate_hz) +
                                " is not a finite rate >= 0");
  for (const core::BodyModel& b : model_.bodies) {
    names_.push_back(b.name);
    pose_names_.push_back(igtl_world_transform_name(b.name, false, settings_.names));
    target_names_.push_back(igtl_world_transform_name(b.name, true, settings_.names));
  }
#if NUMEN_WITH_OPENIGTLINK
  for (int n = 0; n < static_cast<int>(model_.nets.size()); ++n) {
    const core::NetModel& net = model_.nets[static_cast<std::size_t>(n)];
    if (net.name.empty() || net.name.size() > 20)
      throw std::invalid_argument("--igtl: deformable name '" + net.name +
                                  "' must have 1 to 20 characters (OpenIGTLink's device name)");
    Organ o;
    o.net = n;
    o.fine = net.surface_point_count > 0;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    if (o.fine) {
      for (int t = net.surface_face_begin; t < net.surface_face_begin + net.surface_face_count; ++t) {
        const std::array<int, 3>& f = model_.net_surface_faces[static_cast<std::size_t>(t)];
        triangles.push_back({static_cast<std::uint32_t>(f[0] - net.surface_point_begin),
                             static_cast<std::uint32_t>(f[1] - net.surface_point_begin),
                             static_cast<std::uint32_t>(f[2] - net.surface_point_begin)});
      }
    } else {
      for (int t = net.face_begin; t < net.face_begin + net.face_count; ++t) {
        const std::array<int, 3>& f = model_.net_faces[static_cast<std::size_t>(t)];
        triangles.push_back({static_cast<std::uint32_t>(f[0] - net.node_begin),
                             static_cast<std::uint32_t>(f[1] - net.node_begin),
                             static_cast<std::uint32_t>(f[2] - net.node_begin)});
      }
    }
    const std::size_t count =
        static_cast<std::size_t>(o.fine ? net.surface_point_count : net.node_count);
    if (count == 0) continue;  // a net without nodes has nothing to draw
    o.points.resize(count);
    o.packer = std::make_unique<hal::IgtlPolyDataPacker>(net.name, count, triangles);
    if (net.contact_modulus > 0.0) {
      o.triangles = triangles;
      o.normals.resize(count);
      o.moves.resize(count);
    }
    organs_.push_back(std::move(o));
  }
  std::size_t thread_node = 0;
  for (const core::ThreadModel& t : model_.threads) {
    if (t.name.empty() || t.name.size() > 20)
      throw std::invalid_argument("--igtl: thread name '" + t.name +
                                  "' must have 1 to 20 characters (OpenIGTLink's device name)");
    const std::size_t count = static_cast<std::size_t>(std::max(t.segments, 0) + 1);
    Thread th;
    th.node_begin = thread_node;
    th.points.resize(count);
    thread_node += count;
    th.packer = std::make_unique<hal::IgtlPolyDataPacker>(
        t.name, count, std::span<const std::array<std::uint32_t, 3>>{}, thread_lines(count, -1));
    threads_.push_back(std::move(th));
  }
#endif
  nodes_.resize(static_cast<std::size_t>(model_.num_nodes()));
  dimple_spheres_.reserve(model_.body_spheres.size());
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
    clients_.push_back(Client{fd, {}, true});
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

void IgtlWorldServer::add_status(std::string& out, std::int64_t t_ns, int code,
                                 std::int64_t subcode, const std::string& name,
                                 const std::string& message, std::size_t device) {
#if NUMEN_WITH_OPENIGTLINK
  out += hal::pack_igtl_status(igtl_world_status_name(device), t_ns,
                               static_cast<hal::IgtlStatusCode>(code), subcode, name, message);
#else
  (void)out, (void)t_ns, (void)code, (void)subcode, (void)name, (void)message, (void)device;
#endif
}

void IgtlWorldServer::add_string(std::string& out, std::int64_t t_ns, const std::string& text) {
#if NUMEN_WITH_OPENIGTLINK
  out += hal::pack_igtl_string(kIgtlEventsDevice, t_ns, text);
#else
  (void)out, (void)t_ns, (void)text;
#endif
}

std::string IgtlWorldServer::device_words(std::size_t device) const {
  if (device == 0) return "the device";  // device 0's words, as before a loop ran several
  std::string out = "device " + std::to_string(device);
  if (device < settings_.device_names.size()) out += " '" + settings_.device_names[device] + "'";
  return out;
}

// One device's changes between two frames, each a STATUS (under the device's name) and a STRING.
void IgtlWorldServer::add_device_events(std::size_t device, const Last& was, const Last& now,
                                        std::int64_t t) {
  const std::string who = device_words(device);
  const std::string whose = device == 0 ? "the device's" : who + ": its";
  const auto event = [&](int code, std::int64_t subcode, const std::string& name,
                         const std::string& text) {
    add_status(events_, t, code, subcode, name, text, device);
    add_string(events_, t, text);
    ++events_statuses_;
    ++events_strings_;
    ++counters_.events;
  };
  if (now.fault_cause != was.fault_cause) {
    const auto cause = static_cast<hal::FaultCause>(now.fault_cause);
    if (now.fault_cause != 0)
      event(3, now.fault_cause, hal::to_string(cause),
            who + " latched its safe state " + at_time(t) + ": " + hal::to_string(cause));
    else
      event(1, 0, "safe state cleared", whose + " safe state was cleared (re-armed) " + at_time(t));
  }
  const std::uint8_t rejected = now.sample_faults & kRejectionBits;
  if (rejected != (was.sample_faults & kRejectionBits)) {
    if (rejected != 0)
      event((rejected & hal::SampleFault::kStale) != 0 ? 7 : 2, rejected, "samples rejected",
            whose + " samples were rejected " + at_time(t) + " (" + rejection_words(rejected) + ")");
    else
      event(1, 0, "samples valid", whose + " samples are accepted again " + at_time(t));
  }
  if (now.bus_down != was.bus_down) {
    if (now.bus_down)
      event(7, 0, "bus down",
            whose + " bus is down " + at_time(t) + " (a tracker's connection lost, a CAN bus off)");
    else
      event(1, 0, "bus up", whose + " bus is back " + at_time(t));
  }
}

void IgtlWorldServer::add_device_intro(std::size_t device, const Last& now, std::int64_t t) {
  const auto cause = static_cast<hal::FaultCause>(now.fault_cause);
  if (now.fault_cause != 0)
    add_status(intro_, t, 3, now.fault_cause, hal::to_string(cause),
               (device == 0 ? std::string("the device") : device_words(device)) +
                   " is in its safe state: " + hal::to_string(cause),
               device);
  else if (device == 0)
    add_status(intro_, t, 1, 0, "ok", "numen world " + at_time(t));
  else
    add_status(intro_, t, 1, 0, "ok", device_words(device) + " " + at_time(t), device);
}

// The changes this frame shows against the previous one, as STATUS and STRING into events_.
void IgtlWorldServer::add_events(const platform::StateFrameView& view) {
  events_.clear();
  events_statuses_ = events_strings_ = 0;
  const platform::StateFrameHeader& h = view.header();
  const std::int64_t t = h.time_ns;
  const bool bus_down = (h.flags & platform::kFrameBusDown) != 0;
  // The first frame is compared with a fresh device (no fault, no rejection, bus up), holding
  // what it holds.
  const Last was = last_.seen ? last_ : Last{true, 0, 0, false, h.held_body};
  add_device_events(0, was, Last{true, h.fault_cause, h.sample_faults, bus_down, h.held_body}, t);
  // The loop's other devices, each against its own previous frame.
  if (extra_last_.size() != h.num_extra_devices) extra_last_.assign(h.num_extra_devices, Last{});
  for (std::uint32_t d = 0; d < h.num_extra_devices; ++d) {
    const platform::FrameDevice f = view.extra_device(d);
    const Last now{true, f.fault_cause, f.sample_faults, (f.flags & platform::kFrameBusDown) != 0, -1};
    add_device_events(d + 1, extra_last_[d].seen ? extra_last_[d] : Last{true, 0, 0, false, -1},
                      now, t);
    extra_last_[d] = now;
  }
  if (h.held_body != was.held_body) {
    const auto name = [&](std::int32_t b) {
      return b >= 0 && static_cast<std::size_t>(b) < names_.size() ? "'" + names_[static_cast<std::size_t>(b)] + "'"
                                                                   : "body " + std::to_string(b);
    };
    add_string(events_, t,
               h.held_body >= 0
                   ? "the device holds " + name(h.held_body) + " " + at_time(t)
                   : "the device released " + name(was.held_body) + " " + at_time(t));
    ++events_strings_;
    ++counters_.events;
  }
  last_ = Last{true, h.fault_cause, h.sample_faults, bus_down, h.held_body};
}

// Every deformable's POLYDATA at this frame's node positions into `out`.
void IgtlWorldServer::add_organs(std::string& out, const platform::StateFrameView& view) {
#if NUMEN_WITH_OPENIGTLINK
  const platform::StateFrameHeader& h = view.header();
  const std::size_t n = std::min<std::size_t>(h.num_nodes, nodes_.size());
  float x[3];
  for (std::size_t i = 0; i < n; ++i) {
    view.node_position(static_cast<std::uint32_t>(i), x);
    nodes_[i].position = core::Vec3(x[0], x[1], x[2]);
  }
  for (Organ& o : organs_) {
    const core::NetModel& net = model_.nets[static_cast<std::size_t>(o.net)];
    for (std::size_t i = 0; i < o.points.size(); ++i) {
      const int k = static_cast<int>(i);
      const core::Vec3& node = nodes_[static_cast<std::size_t>(net.node_begin + k)].position;
      // A fine surface needs the nets' code (a build without it has no net to draw).
      if constexpr (core::kWithDeformable)
        o.points[i] =
            1e3 * (o.fine ? core::net_surface_position(model_, nodes_, net.surface_point_begin + k)
                          : node);
      else
        o.points[i] = 1e3 * node;
    }
    if (!o.moves.empty()) {  // the tools' dimples: every other body's spheres, in mm
      dimple_spheres_.clear();
      float p[7];
      for (std::uint32_t b = 0; b < h.num_bodies && b < model_.bodies.size(); ++b) {
        if (static_cast<int>(b) == net.body) continue;
        view.body_pose(b, p);
        const core::Quat q(p[6], p[3], p[4], p[5]);
        const core::Vec3 at(p[0], p[1], p[2]);
        const core::BodyModel& bm = model_.bodies[b];
        for (int k = bm.sphere_begin; k < bm.sphere_begin + bm.sphere_count; ++k) {
          const core::Sphere& sp = model_.body_spheres[static_cast<std::size_t>(k)];
          dimple_spheres_.push_back({1e3 * (at + q * sp.center), 1e3 * sp.radius});
        }
      }
      vertex_normals(o.points, o.triangles, o.normals);
      press_tissue_dimples(o.points, o.normals, dimple_spheres_, o.moves);
    }
    o.packer->pack(h.time_ns, o.points, out);
  }
#else
  (void)out, (void)view;
#endif
}

std::uint64_t IgtlWorldServer::add_threads(std::string& out, const platform::StateFrameView& view) {
  std::uint64_t messages = 0;
#if NUMEN_WITH_OPENIGTLINK
  const platform::StateFrameHeader& h = view.header();
  // The frame's threads are the model's (the stream was laid out from it): a frame that does not
  // carry them all has none drawn.
  if (h.num_threads != model_.threads.size()) return 0;
  for (std::size_t t = 0; t < threads_.size(); ++t) {
    Thread& th = threads_[t];
    if (th.node_begin + th.points.size() > h.num_thread_nodes) break;
    const int broken = view.thread(static_cast<std::uint32_t>(t)).broken_segment;
    if (broken != th.broken) {
      th.packer->set_lines(thread_lines(th.points.size(), broken));
      th.broken = broken;
    }
    float x[3];
    for (std::size_t i = 0; i < th.points.size(); ++i) {
      view.thread_node(static_cast<std::uint32_t>(th.node_begin + i), x);
      th.points[i] = 1e3 * core::Vec3(x[0], x[1], x[2]);  // mm
    }
    th.packer->pack(h.time_ns, th.points, out);
    ++messages;
  }
#else
  (void)out, (void)view;
#endif
  return messages;
}

bool IgtlWorldServer::write_frame(std::span<const std::byte> frame) noexcept {
  ++counters_.frames;
  accept_clients();
  platform::StateFrameView view;
  if (!platform::StateFrameDecoder::decode(frame, view).ok()) {
    ++counters_.frames_bad;
    return false;
  }
#if NUMEN_WITH_OPENIGTLINK
  try {
    const platform::StateFrameHeader& h = view.header();
    add_events(view);  // the changes are tracked with or without clients
    if (clients_.empty()) return true;
    batch_.clear();
    batch_transforms_ = 0;
    const std::size_t n = std::min<std::size_t>(h.num_bodies, names_.size());
    const auto add = [&](const std::string& name, const float p[7]) {
      const core::Quat q(p[6], p[3], p[4], p[5]);
      batch_ += hal::pack_igtl_transform(name, h.time_ns, q.normalized().toRotationMatrix(),
                                         core::Vec3(p[0], p[1], p[2]) * 1e3);  // mm
      ++batch_transforms_;
    };
    float pose[7];
    for (std::size_t b = 0; b < n; ++b) {
      view.body_pose(static_cast<std::uint32_t>(b), pose);
      add(pose_names_[b], pose);
      if (view.target_pose(static_cast<std::uint32_t>(b), pose)) add(target_names_[b], pose);
    }
    batch_polydata_ = add_threads(batch_, view);  // the threads, every frame after the poses
    // The organs: due on the grid of organ_rate_hz in simulated time (no burst after a gap).
    const bool any_fresh =
        std::any_of(clients_.begin(), clients_.end(), [](const Client& c) { return c.fresh; });
    bool organ_due = false;
    if (settings_.organ_rate_hz > 0.0 && !organs_.empty()) {
      const auto interval = static_cast<std::int64_t>(std::llround(1e9 / settings_.organ_rate_hz));
      if (!organ_sent_ || h.time_ns >= organ_due_ns_) {
        organ_due = true;
        organ_due_ns_ = organ_sent_ ? organ_due_ns_ + interval : h.time_ns + interval;
        if (organ_due_ns_ <= h.time_ns) organ_due_ns_ = h.time_ns + interval;
        organ_sent_ = true;
      }
    }
    std::string organs;  // every deformable's POLYDATA at this frame
    if (organ_due || any_fresh) add_organs(organs, view);
    intro_.clear();  // a new client's state, after its shapes: every device's
    std::uint64_t intro_statuses = 0;
    if (any_fresh) {
      add_device_intro(0, last_, h.time_ns);
      for (std::size_t d = 0; d < extra_last_.size(); ++d) add_device_intro(d + 1, extra_last_[d], h.time_ns);
      intro_statuses = 1 + extra_last_.size();
    }
    const std::size_t limit =
        std::max(settings_.max_backlog_bytes, 2 * (organs.size() + intro_.size() + batch_.size()));
    // In each client's stream: the shapes (at its first frame, then when due), its state when it
    // is new, the frame's TRANSFORMs, the frame's events.
    for (Client& c : clients_) {
      if (c.fresh) {
        c.backlog += organs;
        c.backlog += intro_;
        c.backlog += batch_;
        counters_.polydata += organs_.size() + batch_polydata_;
        counters_.statuses += intro_statuses;
        counters_.messages += batch_transforms_;
        c.fresh = false;
      } else if (c.backlog.size() + (organ_due ? organs.size() : 0) + batch_.size() > limit) {
        ++counters_.frames_skipped;  // a slow client misses this frame's poses and shapes
      } else {
        if (organ_due) {
          c.backlog += organs;
          counters_.polydata += organs_.size();
        }
        c.backlog += batch_;
        counters_.messages += batch_transforms_;
        counters_.polydata += batch_polydata_;
      }
      if (c.backlog.size() + events_.size() <= limit + kEventsAllowance) {
        c.backlog += events_;  // small and rare: kept when the frame is not
        counters_.statuses += events_statuses_;
        counters_.strings += events_strings_;
      } else if (!events_.empty()) {
        ++counters_.events_skipped;
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
