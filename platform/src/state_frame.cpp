#include "numen/platform/state_frame.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <iterator>
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

// The C++ type a field of wire type T is read as and the unsigned type of its bytes.
template <FrameFieldType T>
struct Wire;
template <>
struct Wire<FrameFieldType::kU8> { using type = std::uint8_t; using bits = std::uint8_t; };
template <>
struct Wire<FrameFieldType::kU16> { using type = std::uint16_t; using bits = std::uint16_t; };
template <>
struct Wire<FrameFieldType::kU32> { using type = std::uint32_t; using bits = std::uint32_t; };
template <>
struct Wire<FrameFieldType::kI32> { using type = std::int32_t; using bits = std::uint32_t; };
template <>
struct Wire<FrameFieldType::kU64> { using type = std::uint64_t; using bits = std::uint64_t; };
template <>
struct Wire<FrameFieldType::kI64> { using type = std::int64_t; using bits = std::uint64_t; };

template <FrameField F>
using field_t = typename Wire<frame_field(F).type>::type;

// Header field F at its declared offset, as its declared type.
template <FrameField F>
void put_field(std::byte* frame, field_t<F> v) noexcept {
  using Bits = typename Wire<frame_field(F).type>::bits;
  static_assert(sizeof(Bits) == frame_field_bytes(frame_field(F).type));
  put_le<Bits>(frame + frame_field(F).offset, static_cast<Bits>(v));
}
template <FrameField F>
field_t<F> get_field(const std::byte* frame) noexcept {
  using Bits = typename Wire<frame_field(F).type>::bits;
  return static_cast<field_t<F>>(get_le<Bits>(frame + frame_field(F).offset));
}
constexpr std::size_t offset_of(FrameField f) noexcept { return frame_field(f).offset; }

// Byte offsets of the arrays after the header (kStateFrameArrays, in order) and of the end,
// for counts B, N, C, A, G, D, E, H, T.
struct Offsets {
  std::array<std::size_t, kStateFrameArrays.size()> at;
  std::size_t end;
};
Offsets offsets(std::uint64_t b, std::uint64_t n, std::uint64_t c, std::uint64_t a,
                std::uint64_t g, std::uint64_t d, std::uint64_t e, std::uint64_t threads,
                std::uint64_t thread_nodes) noexcept {
  Offsets o{};
  std::size_t at = kStateFrameHeaderBytes;
  for (std::size_t i = 0; i < kStateFrameArrays.size(); ++i) {
    const StateFrameArray& array = kStateFrameArrays[i];
    std::uint64_t items = 1;
    if (array.count) {
      switch (*array.count) {
        case FrameField::kNumBodies: items = b; break;
        case FrameField::kNumNodes: items = n; break;
        case FrameField::kNumContacts: items = c; break;
        case FrameField::kNumGrasps: items = g; break;
        case FrameField::kNumExtraDevices: items = d; break;
        case FrameField::kNumExtraAxes: items = e; break;
        case FrameField::kNumThreads: items = threads; break;
        case FrameField::kNumThreadNodes: items = thread_nodes; break;
        default: items = a; break;  // kNumAxes (frame_arrays_are_well_formed())
      }
    }
    o.at[i] = at;
    at += kFrameFloatBytes * array.floats * items;
  }
  o.end = at;
  return o;
}
constexpr std::size_t array_index(FrameArray a) noexcept { return static_cast<std::size_t>(a); }

// Writes the scalars in order as floats; returns the byte after them.
template <class... Values>
std::byte* put_floats(std::byte* p, Values... values) noexcept {
  ((put_f32(p, static_cast<double>(values)), p += kFrameFloatBytes), ...);
  return p;
}

// Writes a fixed-size Eigen vector's coefficients in order as floats; returns the byte after
// them. Indexed stores, not put_floats(): the node loop of a large net is then vectorised
// (2562 nodes: 6.6 µs per frame against 10 µs).
template <class Vector>
std::byte* put_coeffs(std::byte* p, const Vector& v) noexcept {
  const auto n = static_cast<std::size_t>(v.size());
  for (std::size_t i = 0; i < n; ++i)
    put_f32(p + kFrameFloatBytes * i, v[static_cast<Eigen::Index>(i)]);
  return p + kFrameFloatBytes * n;
}

std::byte* put_pose(std::byte* p, const core::Pose& pose) noexcept {
  return put_coeffs(put_coeffs(p, pose.position), pose.orientation.coeffs());  // x y z w
}

std::byte* put_vec3(std::byte* p, const core::Vec3& v) noexcept { return put_coeffs(p, v); }

std::byte* put_contact(std::byte* p, const core::Vec3& point, const core::Vec3& normal,
                       double depth, const core::Vec3& force) noexcept {
  p = put_vec3(p, point);
  p = put_vec3(p, normal);
  p = put_floats(p, depth);
  return put_vec3(p, force);
}

}  // namespace

std::size_t StateFrameLayout::frame_bytes(std::uint32_t contacts) const noexcept {
  return offsets(num_bodies, num_nodes, contacts, num_axes, num_grasps, num_extra_devices,
                 num_extra_axes, num_threads, num_thread_nodes).end;
}

std::size_t encode_state_frame(const StateFrameLayout& layout, const core::Data& data,
                               const PeriodReport& report, std::span<const double> axis_torques,
                               const StateFrameFigures& figures, std::span<std::byte> out,
                               std::span<const FrameDeviceInput> extra_devices) noexcept {
  if (data.bodies.size() != layout.num_bodies || data.nodes.size() != layout.num_nodes ||
      data.grasps.size() != layout.num_grasps || axis_torques.size() != layout.num_axes ||
      extra_devices.size() != layout.num_extra_devices || out.size() < layout.max_frame_bytes())
    return 0;
  std::size_t extra_axes = 0;
  for (const FrameDeviceInput& d : extra_devices) {
    if (d.report == nullptr) return 0;
    extra_axes += d.axis_torques.size();
  }
  if (extra_axes != layout.num_extra_axes) return 0;
  if (data.threads.size() != layout.num_threads) return 0;
  std::size_t thread_nodes = 0;
  for (const core::ThreadState& th : data.threads) thread_nodes += th.position.size();
  if (thread_nodes != layout.num_thread_nodes) return 0;
  const auto rigid = static_cast<std::uint32_t>(std::max(data.num_contacts, 0));
  const auto nodal = static_cast<std::uint32_t>(std::max(data.num_node_contacts, 0));
  const std::uint32_t contacts = std::min(rigid + nodal, layout.max_contacts);
  const Offsets o = offsets(layout.num_bodies, layout.num_nodes, contacts, layout.num_axes,
                            layout.num_grasps, layout.num_extra_devices, layout.num_extra_axes,
                            layout.num_threads, layout.num_thread_nodes);

  std::byte* h = out.data();
  std::memcpy(h + offset_of(FrameField::kMagic), kStateFrameMagic, sizeof kStateFrameMagic);
  put_field<FrameField::kVersion>(h, kStateFrameVersion);
  put_field<FrameField::kHeaderBytes>(h, static_cast<std::uint16_t>(kStateFrameHeaderBytes));
  put_field<FrameField::kFrameBytes>(h, static_cast<std::uint32_t>(o.end));
  put_field<FrameField::kNumBodies>(h, layout.num_bodies);
  put_field<FrameField::kNumNodes>(h, layout.num_nodes);
  put_field<FrameField::kNumContacts>(h, contacts);
  put_field<FrameField::kNumAxes>(h, layout.num_axes);
  put_field<FrameField::kHeldBody>(h, data.held_body);
  put_field<FrameField::kPeriod>(h, figures.period);
  const double t_ns = data.time * 1e9;
  const bool t_fits = std::isfinite(t_ns) && std::abs(t_ns) < 9e18;
  put_field<FrameField::kTimeNs>(h, t_fits ? std::llround(t_ns) : 0);
  put_field<FrameField::kStepStatus>(h, data.status);
  const std::uint32_t flags = (report.sample_valid ? kFrameSampleValid : 0u) |
                              (report.torque_commanded ? kFrameTorqueCommanded : 0u) |
                              (report.overrun ? kFrameOverrun : 0u) |
                              (report.target_ready ? kFrameTargetReady : 0u) |
                              (rigid + nodal > contacts ? kFrameContactsTruncated : 0u) |
                              (figures.bus_down ? kFrameBusDown : 0u);
  put_field<FrameField::kFlags>(h, flags);
  const std::int64_t step_ns =
      std::clamp<std::int64_t>(report.step_ns, 0, std::numeric_limits<std::uint32_t>::max());
  put_field<FrameField::kStepNs>(h, static_cast<std::uint32_t>(step_ns));
  put_field<FrameField::kLifecycle>(h, static_cast<std::uint8_t>(report.lifecycle));
  put_field<FrameField::kStartup>(h, static_cast<std::uint8_t>(report.startup));
  put_field<FrameField::kFaultCause>(h, static_cast<std::uint8_t>(report.fault_cause));
  put_field<FrameField::kSampleFaults>(h, report.sample_faults);
  put_field<FrameField::kNumGrasps>(h, layout.num_grasps);
  put_field<FrameField::kNumExtraDevices>(h, layout.num_extra_devices);
  put_field<FrameField::kNumExtraAxes>(h, layout.num_extra_axes);
  put_field<FrameField::kNumThreads>(h, layout.num_threads);
  put_field<FrameField::kNumThreadNodes>(h, layout.num_thread_nodes);

  // Each array from its declared offset (kStateFrameArrays), items in order.
  auto array = [&](FrameArray a) { return out.data() + o.at[array_index(a)]; };
  std::byte* p = array(FrameArray::kBodyPose);
  for (const core::BodyState& b : data.bodies) p = put_pose(p, core::Pose{b.position, b.orientation});
  p = array(FrameArray::kTargetPose);
  for (std::uint32_t b = 0; b < layout.num_bodies; ++b) {
    const bool held = static_cast<std::int32_t>(b) == data.held_body;
    const bool has_own = b < data.body_targets.size() && data.body_targets[b].enabled;
    const core::Pose* target = held      ? &data.target
                               : has_own ? &data.body_targets[b].pose
                                         : nullptr;
    if (target != nullptr) {
      p = put_pose(p, *target);
    } else {
      p = put_pose(p, core::Pose{data.bodies[b].position, data.bodies[b].orientation});
    }
    p = put_floats(p, target != nullptr ? 1.0 : 0.0);
  }
  p = array(FrameArray::kNodePosition);
  for (const core::NodeState& n : data.nodes) p = put_vec3(p, n.position);
  p = array(FrameArray::kContact);
  std::uint32_t written = 0;
  for (std::uint32_t c = 0; c < rigid && written < contacts; ++c, ++written) {
    const core::Contact& k = data.contacts[c];
    p = put_contact(p, k.position, k.normal, k.depth, k.force);
  }
  for (std::uint32_t c = 0; c < nodal && written < contacts; ++c, ++written) {
    const core::NodeContact& k = data.node_contacts[c];
    p = put_contact(p, k.position, k.normal, k.depth, k.force);
  }
  p = put_vec3(array(FrameArray::kFeedback), report.feedback.force);
  put_vec3(p, report.feedback.torque);
  p = array(FrameArray::kAxisTorque);
  for (double tau : axis_torques) p = put_floats(p, tau);
  put_floats(array(FrameArray::kPenetration), figures.tool_penetration, figures.target_penetration);
  put_floats(array(FrameArray::kDeviceLoop), figures.hand_penetration, figures.handle_force,
             figures.device_port_energy);
  p = array(FrameArray::kGrasp);
  for (const core::GraspState& g : data.grasps)
    p = put_floats(p, g.body, g.net,
                   g.body >= 0 ? g.num_points : g.thread >= 0 ? g.num_thread_nodes : g.num_nodes,
                   g.opening, g.grip_force, g.grasps, g.releases, g.slips, g.thread);
  p = array(FrameArray::kExtraDevice);
  std::byte* t = array(FrameArray::kExtraAxisTorque);
  for (const FrameDeviceInput& d : extra_devices) {
    const PeriodReport& r = *d.report;
    const std::uint32_t device_flags = (r.sample_valid ? kFrameSampleValid : 0u) |
                                       (r.torque_commanded ? kFrameTorqueCommanded : 0u) |
                                       (r.target_ready ? kFrameTargetReady : 0u) |
                                       (d.bus_down ? kFrameBusDown : 0u);
    p = put_floats(p, device_flags, static_cast<std::uint8_t>(r.lifecycle),
                   static_cast<std::uint8_t>(r.startup), static_cast<std::uint8_t>(r.fault_cause),
                   r.sample_faults, d.axis_torques.size());
    p = put_vec3(put_vec3(p, r.feedback.force), r.feedback.torque);
    for (double tau : d.axis_torques) t = put_floats(t, tau);
  }
  p = array(FrameArray::kThread);
  std::byte* x = array(FrameArray::kThreadNode);
  for (const core::ThreadState& th : data.threads) {
    p = put_floats(p, th.broken_segment, th.output.max_tension);
    for (const core::Vec3& node : th.position) x = put_vec3(x, node);
  }
  return o.end;
}

float StateFrameView::f32(std::size_t offset) const noexcept {
  return std::bit_cast<float>(get_le<std::uint32_t>(bytes_ + offset));
}

std::size_t StateFrameView::f32s(std::size_t at, float* out, std::size_t n) const noexcept {
  for (std::size_t i = 0; i < n; ++i, at += kFrameFloatBytes) out[i] = f32(at);
  return at;
}

void StateFrameView::body_pose(std::uint32_t b, float out[7]) const noexcept {
  f32s(item(FrameArray::kBodyPose, b), out, kFramePoseFloats);
}

bool StateFrameView::target_pose(std::uint32_t b, float out[7]) const noexcept {
  float flag = 0.0F;
  f32s(f32s(item(FrameArray::kTargetPose, b), out, kFramePoseFloats), &flag, 1);
  return flag != 0.0F;
}

void StateFrameView::node_position(std::uint32_t n, float out[3]) const noexcept {
  f32s(item(FrameArray::kNodePosition, n), out, kFrameNodeFloats);
}

FrameContact StateFrameView::contact(std::uint32_t c) const noexcept {
  FrameContact k{};
  static_assert(std::size(k.point) + std::size(k.normal) + 1 + std::size(k.force) ==
                kFrameContactFloats);
  std::size_t at = f32s(item(FrameArray::kContact, c), k.point, std::size(k.point));
  at = f32s(at, k.normal, std::size(k.normal));
  at = f32s(at, &k.depth, 1);
  f32s(at, k.force, std::size(k.force));
  return k;
}

void StateFrameView::feedback(float out[6]) const noexcept {
  f32s(item(FrameArray::kFeedback, 0), out, kFrameWrenchFloats);
}

float StateFrameView::axis_torque(std::uint32_t a) const noexcept {
  return f32(item(FrameArray::kAxisTorque, a));
}
float StateFrameView::tool_penetration() const noexcept {
  return f32(item(FrameArray::kPenetration, 0));
}
float StateFrameView::target_penetration() const noexcept {
  float both[kFrameFigureFloats];
  f32s(item(FrameArray::kPenetration, 0), both, kFrameFigureFloats);
  return both[1];
}

void StateFrameView::device_loop(float out[3]) const noexcept {
  f32s(item(FrameArray::kDeviceLoop, 0), out, kFrameDeviceLoopFloats);
}

FrameGrasp StateFrameView::grasp(std::uint32_t g) const noexcept {
  float v[kFrameGraspFloats];
  f32s(item(FrameArray::kGrasp, g), v, kFrameGraspFloats);
  static_assert(kFrameGraspFloats == 9);
  return FrameGrasp{v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]};
}

FrameDevice StateFrameView::extra_device(std::uint32_t d) const noexcept {
  float v[kFrameDeviceFloats];
  f32s(item(FrameArray::kExtraDevice, d), v, kFrameDeviceFloats);
  static_assert(kFrameDeviceFloats == 12);
  // The small integers were written as floats (exact); a garbled one is cut to its type.
  const auto u8 = [](float x) {
    return static_cast<std::uint8_t>(x >= 0.0F && x <= 255.0F ? static_cast<unsigned>(x) : 0u);
  };
  const auto u32 = [](float x) {
    return x >= 0.0F && x < 4294967296.0F ? static_cast<std::uint32_t>(x) : 0u;
  };
  FrameDevice out;
  out.flags = u32(v[0]);
  out.lifecycle = u8(v[1]);
  out.startup = u8(v[2]);
  out.fault_cause = u8(v[3]);
  out.sample_faults = u8(v[4]);
  out.num_axes = u32(v[5]);
  std::copy(v + 6, v + 12, out.feedback);
  return out;
}

float StateFrameView::extra_axis_torque(std::uint32_t a) const noexcept {
  return f32(item(FrameArray::kExtraAxisTorque, a));
}

FrameThread StateFrameView::thread(std::uint32_t t) const noexcept {
  float v[kFrameThreadFloats];
  f32s(item(FrameArray::kThread, t), v, kFrameThreadFloats);
  static_assert(kFrameThreadFloats == 2);
  // The segment index was written as a float (exact below 2^24); a garbled one reads as whole.
  const bool index = v[0] >= 0.0F && v[0] < 16777216.0F;
  return FrameThread{index ? static_cast<std::int32_t>(v[0]) : -1, v[1]};
}

void StateFrameView::thread_node(std::uint32_t n, float out[3]) const noexcept {
  f32s(item(FrameArray::kThreadNode, n), out, kFrameNodeFloats);
}

StateFrameDecodeResult StateFrameDecoder::decode(std::span<const std::byte> bytes,
                                                 StateFrameView& view) {
  auto fail = [](FrameField at, const std::string& what) {
    return StateFrameDecodeResult{"byte " + std::to_string(offset_of(at)) + ": " + what};
  };
  if (bytes.size() < kStateFrameHeaderBytes)
    return fail(FrameField::kMagic, "frame of " + std::to_string(bytes.size()) +
                                        " bytes is shorter than its " +
                                        std::to_string(kStateFrameHeaderBytes) + "-byte header");
  const std::byte* h = bytes.data();
  const std::byte* magic = h + offset_of(FrameField::kMagic);
  if (std::memcmp(magic, kStateFrameMagic, sizeof kStateFrameMagic) != 0)
    return fail(FrameField::kMagic, "not a state frame (magic is not NMVF)");
  const auto version = get_field<FrameField::kVersion>(h);
  if (version != kStateFrameVersion)
    return fail(FrameField::kVersion,
                "frame version " + std::to_string(version) + ", this reader knows " +
                    std::to_string(kStateFrameVersion) +
                    (version < kStateFrameVersion
                         ? " (written by an older numen: record the run again with this one)"
                         : ""));
  const auto header_bytes = get_field<FrameField::kHeaderBytes>(h);
  if (header_bytes != kStateFrameHeaderBytes)
    return fail(FrameField::kHeaderBytes, "header size " + std::to_string(header_bytes) +
                                              ", expected " +
                                              std::to_string(kStateFrameHeaderBytes));
  StateFrameHeader hd;
  hd.frame_bytes = get_field<FrameField::kFrameBytes>(h);
  hd.num_bodies = get_field<FrameField::kNumBodies>(h);
  hd.num_nodes = get_field<FrameField::kNumNodes>(h);
  hd.num_contacts = get_field<FrameField::kNumContacts>(h);
  hd.num_axes = get_field<FrameField::kNumAxes>(h);
  hd.held_body = get_field<FrameField::kHeldBody>(h);
  hd.period = get_field<FrameField::kPeriod>(h);
  hd.time_ns = get_field<FrameField::kTimeNs>(h);
  hd.step_status = get_field<FrameField::kStepStatus>(h);
  hd.flags = get_field<FrameField::kFlags>(h);
  hd.step_ns = get_field<FrameField::kStepNs>(h);
  hd.lifecycle = get_field<FrameField::kLifecycle>(h);
  hd.startup = get_field<FrameField::kStartup>(h);
  hd.fault_cause = get_field<FrameField::kFaultCause>(h);
  hd.sample_faults = get_field<FrameField::kSampleFaults>(h);
  hd.num_grasps = get_field<FrameField::kNumGrasps>(h);
  hd.num_extra_devices = get_field<FrameField::kNumExtraDevices>(h);
  hd.num_extra_axes = get_field<FrameField::kNumExtraAxes>(h);
  hd.num_threads = get_field<FrameField::kNumThreads>(h);
  hd.num_thread_nodes = get_field<FrameField::kNumThreadNodes>(h);
  if (hd.frame_bytes != bytes.size())
    return fail(FrameField::kFrameBytes, "frame size field says " + std::to_string(hd.frame_bytes) +
                                             " bytes, the frame has " +
                                             std::to_string(bytes.size()));
  // Counts are u32: the offsets below are computed in 64 bits and cannot overflow.
  const Offsets o = offsets(hd.num_bodies, hd.num_nodes, hd.num_contacts, hd.num_axes,
                            hd.num_grasps, hd.num_extra_devices, hd.num_extra_axes,
                            hd.num_threads, hd.num_thread_nodes);
  if (o.end != bytes.size())
    return fail(FrameField::kNumBodies,
                "counts (bodies " + std::to_string(hd.num_bodies) + ", nodes " +
                    std::to_string(hd.num_nodes) + ", contacts " + std::to_string(hd.num_contacts) +
                    ", axes " + std::to_string(hd.num_axes) + ", graspers " +
                    std::to_string(hd.num_grasps) + ", other devices " +
                    std::to_string(hd.num_extra_devices) + ", their axes " +
                    std::to_string(hd.num_extra_axes) + ", threads " +
                    std::to_string(hd.num_threads) + ", their nodes " +
                    std::to_string(hd.num_thread_nodes) + ") need " + std::to_string(o.end) +
                    " bytes, the frame has " + std::to_string(bytes.size()));
  if (hd.held_body < -1 || hd.held_body >= static_cast<std::int64_t>(hd.num_bodies))
    return fail(FrameField::kHeldBody, "held body " + std::to_string(hd.held_body) +
                                           " is not -1 or a body index below " +
                                           std::to_string(hd.num_bodies));
  StateFrameView checked;
  checked.bytes_ = bytes.data();
  checked.header_ = hd;
  checked.at_ = o.at;
  // The other devices' axis counts add up to the values of extra_axis_torque (a reader walks
  // them device by device).
  std::uint64_t extra_axes = 0;
  for (std::uint32_t d = 0; d < hd.num_extra_devices; ++d)
    extra_axes += checked.extra_device(d).num_axes;
  if (extra_axes != hd.num_extra_axes)
    return fail(FrameField::kNumExtraAxes,
                "the other devices' axis counts add up to " + std::to_string(extra_axes) +
                    ", the header says " + std::to_string(hd.num_extra_axes));
  view = checked;
  return {};
}

}  // namespace numen::platform
