#include "numen/platform/state_frame.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace numen::platform {
namespace {

// Little-endian stores and loads, whatever the host's byte order (the compiler turns them
// into plain moves on a little-endian host).
template <class U>
void put_le(std::byte* p, U v) noexcept {
  for (std::size_t i = 0; i < sizeof(U); ++i) p[i] = static_cast<std::byte>((v >> (8 * i)) & 0xFF);
}
template <class U>
U get_le(const std::byte* p) noexcept {
  U v = 0;
  for (std::size_t i = 0; i < sizeof(U); ++i) v |= static_cast<U>(std::to_integer<U>(p[i])) << (8 * i);
  return v;
}
void put_f32(std::byte* p, double v) noexcept {
  put_le<std::uint32_t>(p, std::bit_cast<std::uint32_t>(static_cast<float>(v)));
}

// Offsets of the arrays after the header, for counts B, N, C, A.
struct Offsets {
  std::size_t targets, nodes, contacts, wrench, axes, figures, end;
};
Offsets offsets(std::uint64_t b, std::uint64_t n, std::uint64_t c, std::uint64_t a) noexcept {
  Offsets o{};
  o.targets = kStateFrameHeaderBytes + 4 * kFramePoseFloats * b;
  o.nodes = o.targets + 4 * kFrameTargetFloats * b;
  o.contacts = o.nodes + 4 * kFrameNodeFloats * n;
  o.wrench = o.contacts + 4 * kFrameContactFloats * c;
  o.axes = o.wrench + 4 * kFrameWrenchFloats;
  o.figures = o.axes + 4 * a;
  o.end = o.figures + 4 * kFrameFigureFloats;
  return o;
}

std::byte* put_pose(std::byte* p, const core::Pose& pose) noexcept {
  for (int i = 0; i < 3; ++i) put_f32(p + 4 * i, pose.position[i]);
  put_f32(p + 12, pose.orientation.x());
  put_f32(p + 16, pose.orientation.y());
  put_f32(p + 20, pose.orientation.z());
  put_f32(p + 24, pose.orientation.w());
  return p + 28;
}

std::byte* put_vec3(std::byte* p, const core::Vec3& v) noexcept {
  for (int i = 0; i < 3; ++i) put_f32(p + 4 * i, v[i]);
  return p + 12;
}

std::byte* put_contact(std::byte* p, const core::Vec3& point, const core::Vec3& normal,
                       double depth, const core::Vec3& force) noexcept {
  p = put_vec3(p, point);
  p = put_vec3(p, normal);
  put_f32(p, depth);
  return put_vec3(p + 4, force);
}

}  // namespace

std::size_t StateFrameLayout::frame_bytes(std::uint32_t contacts) const noexcept {
  return offsets(num_bodies, num_nodes, contacts, num_axes).end;
}

std::size_t encode_state_frame(const StateFrameLayout& layout, const core::Data& data,
                               const PeriodReport& report, std::span<const double> axis_torques,
                               const StateFrameFigures& figures, std::span<std::byte> out) noexcept {
  if (data.bodies.size() != layout.num_bodies || data.nodes.size() != layout.num_nodes ||
      axis_torques.size() != layout.num_axes || out.size() < layout.max_frame_bytes())
    return 0;
  const auto rigid = static_cast<std::uint32_t>(std::max(data.num_contacts, 0));
  const auto nodal = static_cast<std::uint32_t>(std::max(data.num_node_contacts, 0));
  const std::uint32_t contacts = std::min(rigid + nodal, layout.max_contacts);
  const Offsets o = offsets(layout.num_bodies, layout.num_nodes, contacts, layout.num_axes);

  std::byte* h = out.data();
  std::memcpy(h, kStateFrameMagic, 4);
  put_le<std::uint16_t>(h + 4, kStateFrameVersion);
  put_le<std::uint16_t>(h + 6, static_cast<std::uint16_t>(kStateFrameHeaderBytes));
  put_le<std::uint32_t>(h + 8, static_cast<std::uint32_t>(o.end));
  put_le<std::uint32_t>(h + 12, layout.num_bodies);
  put_le<std::uint32_t>(h + 16, layout.num_nodes);
  put_le<std::uint32_t>(h + 20, contacts);
  put_le<std::uint32_t>(h + 24, layout.num_axes);
  put_le<std::uint32_t>(h + 28, static_cast<std::uint32_t>(data.attached_body));
  put_le<std::uint64_t>(h + 32, figures.period);
  const double t_ns = data.time * 1e9;
  put_le<std::uint64_t>(h + 40, static_cast<std::uint64_t>(
                                    std::isfinite(t_ns) && std::abs(t_ns) < 9e18 ? std::llround(t_ns) : 0));
  put_le<std::uint32_t>(h + 48, data.status);
  std::uint32_t flags = (report.sample_valid ? kFrameSampleValid : 0u) |
                        (report.torque_commanded ? kFrameTorqueCommanded : 0u) |
                        (report.overrun ? kFrameOverrun : 0u) |
                        (report.target_ready ? kFrameTargetReady : 0u) |
                        (rigid + nodal > contacts ? kFrameContactsTruncated : 0u);
  put_le<std::uint32_t>(h + 52, flags);
  const std::int64_t step_ns =
      std::clamp<std::int64_t>(report.step_ns, 0, std::numeric_limits<std::uint32_t>::max());
  put_le<std::uint32_t>(h + 56, static_cast<std::uint32_t>(step_ns));
  h[60] = static_cast<std::byte>(report.lifecycle);
  h[61] = static_cast<std::byte>(report.startup);
  put_le<std::uint16_t>(h + 62, 0);

  std::byte* p = out.data() + kStateFrameHeaderBytes;
  for (const core::BodyState& b : data.bodies) p = put_pose(p, core::Pose{b.position, b.orientation});
  for (std::uint32_t b = 0; b < layout.num_bodies; ++b) {
    const bool attached = static_cast<std::int32_t>(b) == data.attached_body;
    const bool has_own = b < data.body_targets.size() && data.body_targets[b].enabled;
    const core::Pose* target = attached  ? &data.target
                               : has_own ? &data.body_targets[b].pose
                                         : nullptr;
    if (target != nullptr) {
      p = put_pose(p, *target);
    } else {
      p = put_pose(p, core::Pose{data.bodies[b].position, data.bodies[b].orientation});
    }
    put_f32(p, target != nullptr ? 1.0 : 0.0);
    p += 4;
  }
  for (const core::NodeState& n : data.nodes) p = put_vec3(p, n.position);
  std::uint32_t written = 0;
  for (std::uint32_t c = 0; c < rigid && written < contacts; ++c, ++written) {
    const core::Contact& k = data.contacts[c];
    p = put_contact(p, k.position, k.normal, k.depth, k.force);
  }
  for (std::uint32_t c = 0; c < nodal && written < contacts; ++c, ++written) {
    const core::NodeContact& k = data.node_contacts[c];
    p = put_contact(p, k.position, k.normal, k.depth, k.force);
  }
  p = put_vec3(p, report.feedback.force);
  p = put_vec3(p, report.feedback.torque);
  for (double tau : axis_torques) {
    put_f32(p, tau);
    p += 4;
  }
  put_f32(p, figures.tool_penetration);
  put_f32(p + 4, figures.target_penetration);
  return o.end;
}

float StateFrameView::f32(std::size_t offset) const noexcept {
  return std::bit_cast<float>(get_le<std::uint32_t>(bytes_ + offset));
}

void StateFrameView::body_pose(std::uint32_t b, float out[7]) const noexcept {
  for (std::size_t i = 0; i < kFramePoseFloats; ++i)
    out[i] = f32(kStateFrameHeaderBytes + 4 * (kFramePoseFloats * b + i));
}

bool StateFrameView::target_pose(std::uint32_t b, float out[7]) const noexcept {
  for (std::size_t i = 0; i < kFramePoseFloats; ++i) out[i] = f32(targets_ + 4 * (kFrameTargetFloats * b + i));
  return f32(targets_ + 4 * (kFrameTargetFloats * b + 7)) != 0.0F;
}

void StateFrameView::node_position(std::uint32_t n, float out[3]) const noexcept {
  for (std::size_t i = 0; i < 3; ++i) out[i] = f32(nodes_ + 4 * (kFrameNodeFloats * n + i));
}

FrameContact StateFrameView::contact(std::uint32_t c) const noexcept {
  FrameContact k{};
  const std::size_t at = contacts_ + 4 * kFrameContactFloats * c;
  for (std::size_t i = 0; i < 3; ++i) {
    k.point[i] = f32(at + 4 * i);
    k.normal[i] = f32(at + 12 + 4 * i);
    k.force[i] = f32(at + 28 + 4 * i);
  }
  k.depth = f32(at + 24);
  return k;
}

void StateFrameView::feedback(float out[6]) const noexcept {
  for (std::size_t i = 0; i < 6; ++i) out[i] = f32(wrench_ + 4 * i);
}

float StateFrameView::axis_torque(std::uint32_t a) const noexcept { return f32(axes_ + 4 * a); }
float StateFrameView::tool_penetration() const noexcept { return f32(figures_); }
float StateFrameView::target_penetration() const noexcept { return f32(figures_ + 4); }

StateFrameDecodeResult StateFrameDecoder::decode(std::span<const std::byte> bytes,
                                                 StateFrameView& view) {
  auto fail = [](std::size_t offset, const std::string& what) {
    return StateFrameDecodeResult{"byte " + std::to_string(offset) + ": " + what};
  };
  if (bytes.size() < kStateFrameHeaderBytes)
    return fail(0, "frame of " + std::to_string(bytes.size()) + " bytes is shorter than its " +
                       std::to_string(kStateFrameHeaderBytes) + "-byte header");
  const std::byte* h = bytes.data();
  if (std::memcmp(h, kStateFrameMagic, 4) != 0) return fail(0, "not a state frame (magic is not NMVF)");
  const auto version = get_le<std::uint16_t>(h + 4);
  if (version != kStateFrameVersion)
    return fail(4, "frame version " + std::to_string(version) + ", this reader knows " +
                       std::to_string(kStateFrameVersion));
  if (get_le<std::uint16_t>(h + 6) != kStateFrameHeaderBytes)
    return fail(6, "header size " + std::to_string(get_le<std::uint16_t>(h + 6)) + ", expected " +
                       std::to_string(kStateFrameHeaderBytes));
  StateFrameHeader hd;
  hd.frame_bytes = get_le<std::uint32_t>(h + 8);
  hd.num_bodies = get_le<std::uint32_t>(h + 12);
  hd.num_nodes = get_le<std::uint32_t>(h + 16);
  hd.num_contacts = get_le<std::uint32_t>(h + 20);
  hd.num_axes = get_le<std::uint32_t>(h + 24);
  hd.attached_body = static_cast<std::int32_t>(get_le<std::uint32_t>(h + 28));
  hd.period = get_le<std::uint64_t>(h + 32);
  hd.time_ns = static_cast<std::int64_t>(get_le<std::uint64_t>(h + 40));
  hd.step_status = get_le<std::uint32_t>(h + 48);
  hd.flags = get_le<std::uint32_t>(h + 52);
  hd.step_ns = get_le<std::uint32_t>(h + 56);
  hd.lifecycle = std::to_integer<std::uint8_t>(h[60]);
  hd.startup = std::to_integer<std::uint8_t>(h[61]);
  if (hd.frame_bytes != bytes.size())
    return fail(8, "frame size field says " + std::to_string(hd.frame_bytes) + " bytes, the frame has " +
                       std::to_string(bytes.size()));
  // Counts are u32: the offsets below are computed in 64 bits and cannot overflow.
  const Offsets o = offsets(hd.num_bodies, hd.num_nodes, hd.num_contacts, hd.num_axes);
  if (o.end != bytes.size())
    return fail(12, "counts (bodies " + std::to_string(hd.num_bodies) + ", nodes " +
                        std::to_string(hd.num_nodes) + ", contacts " + std::to_string(hd.num_contacts) +
                        ", axes " + std::to_string(hd.num_axes) + ") need " + std::to_string(o.end) +
                        " bytes, the frame has " + std::to_string(bytes.size()));
  if (hd.attached_body < -1 || hd.attached_body >= static_cast<std::int64_t>(hd.num_bodies))
    return fail(28, "attached body " + std::to_string(hd.attached_body) + " is not -1 or a body index below " +
                        std::to_string(hd.num_bodies));
  view.bytes_ = bytes.data();
  view.header_ = hd;
  view.targets_ = o.targets;
  view.nodes_ = o.nodes;
  view.contacts_ = o.contacts;
  view.wrench_ = o.wrench;
  view.axes_ = o.axes;
  view.figures_ = o.figures;
  return {};
}

}  // namespace numen::platform
