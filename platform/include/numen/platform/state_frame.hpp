#pragma once
/// @file state_frame.hpp
/// The state frame: one period of the simulated world, as the viewer and any other renderer
/// receive it (docs/viewer.md, "Frames"). A frame is a little-endian byte string of a 64-byte
/// header followed by float32 arrays; its size depends only on the scene (bodies, net nodes,
/// axes) and on the contacts of the period. The loop writes it straight into a preallocated
/// buffer (encode_state_frame(): noexcept, no allocation); readers check it with
/// decode_state_frame(), which never reads past the bytes it is given.
///
/// Layout (offsets in bytes; u32/i32/u64/i64 little-endian, f32 IEEE 754 little-endian):
///
///     0  char[4] magic "NMVF"           32  u64 period index k
///     4  u16 version (1)                40  i64 simulated time t = k·dt, ns
///     6  u16 header bytes (64)          48  u32 core step status (core::StepStatus bits)
///     8  u32 frame bytes (total)        52  u32 flags (StateFrameFlag bits)
///    12  u32 bodies B                   56  u32 wall time of core::step, ns (saturated)
///    16  u32 net nodes N                60  u8 lifecycle (hal::LifecycleState)
///    20  u32 contacts C                 61  u8 start-up phase (hal::StartupPhase)
///    24  u32 axes A                     62  u16 reserved (0)
///    28  i32 attached body (−1: none)
///
///     64                 B × 7 f32  body poses: position (m) x y z, orientation x y z w
///     64 + 28B           B × 8 f32  target poses (the hand's ghost) as above, then 1 if the
///                                   body has a target this period, else 0
///     64 + 60B           N × 3 f32  net node positions (m)
///     64 + 60B + 12N     C × 10 f32 contacts: point (m) x y z, unit normal x y z (pushes
///                                   the first body out), depth (m, > 0), force on the first
///                                   body (N) x y z; rigid contacts first, then node contacts
///     … + 40C            6 f32      feedback wrench sent to the device: force (N) x y z,
///                                   torque (N·m) x y z, world frame, about link 0's origin
///     … + 24             A f32      torque or force sent to each axis (N·m or N)
///     … + 4A             2 f32      tool penetration, hand (target) penetration (m)
///
/// Frame: world (z up in the shipped scenes). Poses are of each body's centre-of-mass frame,
/// as core::BodyState. float32 keeps 0.06 µm at 1 m: ample for display, not for analysis
/// (use --trace for that).

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "numen/core/data.hpp"
#include "numen/platform/control_loop.hpp"

namespace numen::platform {

/// First bytes of every frame.
inline constexpr char kStateFrameMagic[4] = {'N', 'M', 'V', 'F'};
/// Version written by encode_state_frame() and the only one decode_state_frame() accepts.
inline constexpr std::uint16_t kStateFrameVersion = 1;
/// Size of the fixed header, bytes.
inline constexpr std::size_t kStateFrameHeaderBytes = 64;
/// float32 values per body pose, per target, per node, per contact, in the wrench.
inline constexpr std::size_t kFramePoseFloats = 7, kFrameTargetFloats = 8, kFrameNodeFloats = 3,
                             kFrameContactFloats = 10, kFrameWrenchFloats = 6,
                             kFrameFigureFloats = 2;

/// Bits of the header's flags word.
enum StateFrameFlag : std::uint32_t {
  kFrameSampleValid = 1u << 0,      ///< The device sample was fresh and plausible this period.
  kFrameTorqueCommanded = 1u << 1,  ///< Non-zero torque went to at least one drive.
  kFrameOverrun = 1u << 2,          ///< The period overran its deadline (paced runs).
  kFrameTargetReady = 1u << 3,      ///< The device has a target (possibly held).
  kFrameContactsTruncated = 1u << 4,  ///< More contacts than the frame's capacity: the rest
                                      ///< were left out (StateFrameLayout::max_contacts).
};

/// What fixes a frame's size: the scene's counts and the contact capacity. B, N, A are the
/// same in every frame of a run; C varies per period, up to max_contacts.
struct StateFrameLayout {
  std::uint32_t num_bodies = 0;    ///< B: core::Model::num_bodies().
  std::uint32_t num_nodes = 0;     ///< N: core::Model::num_nodes().
  std::uint32_t num_axes = 0;      ///< A: the device's axes.
  std::uint32_t max_contacts = 0;  ///< Contacts a frame carries at most (rigid + node).

  /// Bytes of a frame with `contacts` contacts.
  std::size_t frame_bytes(std::uint32_t contacts) const noexcept;
  /// Bytes of the largest frame (max_contacts contacts): the buffer a writer needs.
  std::size_t max_frame_bytes() const noexcept { return frame_bytes(max_contacts); }
};

/// One contact of a frame, in the frame's order.
struct FrameContact {
  float point[3];   ///< m, world.
  float normal[3];  ///< Unit, world: pushes the first body (or node) out.
  float depth;      ///< m, > 0.
  float force[3];   ///< N on the first body (or node), world.
};

/// The scalars of a frame's header (the arrays are read through StateFrameView).
struct StateFrameHeader {
  std::uint32_t frame_bytes = 0;
  std::uint32_t num_bodies = 0, num_nodes = 0, num_contacts = 0, num_axes = 0;
  std::int32_t attached_body = -1;
  std::uint64_t period = 0;       ///< Period index k.
  std::int64_t time_ns = 0;       ///< Simulated time, ns.
  std::uint32_t step_status = 0;  ///< core::StepStatus bits.
  std::uint32_t flags = 0;        ///< StateFrameFlag bits.
  std::uint32_t step_ns = 0;      ///< Wall time of core::step, ns (saturated at 2³²−1).
  std::uint8_t lifecycle = 0;     ///< hal::LifecycleState.
  std::uint8_t startup = 0;       ///< hal::StartupPhase.
};

/// A checked frame: the header and the offsets of its arrays in the bytes it was decoded from
/// (which must outlive the view). Accessors convert from little-endian float32.
class StateFrameView {
 public:
  const StateFrameHeader& header() const noexcept { return header_; }
  /// Body b's pose, 7 floats (position x y z, orientation x y z w); b < num_bodies.
  void body_pose(std::uint32_t b, float out[7]) const noexcept;
  /// Body b's target pose (7 floats); returns whether the body had a target.
  bool target_pose(std::uint32_t b, float out[7]) const noexcept;
  /// Net node n's position (3 floats, m); n < num_nodes.
  void node_position(std::uint32_t n, float out[3]) const noexcept;
  /// Contact c; c < num_contacts.
  FrameContact contact(std::uint32_t c) const noexcept;
  /// Feedback wrench sent (6 floats: N, N·m).
  void feedback(float out[6]) const noexcept;
  /// Torque or force sent to axis a (N·m or N).
  float axis_torque(std::uint32_t a) const noexcept;
  /// Tool penetration (m): deepest contact of the attached body this period.
  float tool_penetration() const noexcept;
  /// Hand penetration (m): how deep the target pose would sit in the obstacles.
  float target_penetration() const noexcept;

 private:
  friend class StateFrameDecoder;
  float f32(std::size_t offset) const noexcept;
  const std::byte* bytes_ = nullptr;
  StateFrameHeader header_{};
  std::size_t targets_ = 0, nodes_ = 0, contacts_ = 0, wrench_ = 0, axes_ = 0, figures_ = 0;
};

/// Outcome of decode_state_frame(): empty `error` on success.
struct StateFrameDecodeResult {
  std::string error;  ///< What is wrong and at which byte offset; empty when valid.
  bool ok() const noexcept { return error.empty(); }
};

/// Reads frames (setup or consumer side; allocates only to describe an error).
class StateFrameDecoder {
 public:
  /// Checks `bytes` as one frame: magic, version, header size, frame size equal to
  /// bytes.size() and to the size its counts imply. On success `view` refers into `bytes`.
  /// A non-finite float is accepted (it is data); a malformed frame is never read past its
  /// end.
  static StateFrameDecodeResult decode(std::span<const std::byte> bytes, StateFrameView& view);
};

/// Figures of a period that the loop does not hold (the runner measures them).
struct StateFrameFigures {
  std::uint64_t period = 0;         ///< Period index k.
  double tool_penetration = 0.0;    ///< m: deepest contact of the attached body.
  double target_penetration = 0.0;  ///< m: how deep the target pose sits in the obstacles.
};

/// Writes the frame of the period that just ended into `out`: poses, targets, nodes and
/// contacts from `data` (after core::step), time from data.time, status from
/// data.status, flags, step time, lifecycle and the feedback wrench sent from `report`, the
/// axis torques sent from `axis_torques` (layout.num_axes values), the rest from `figures`.
/// Rigid contacts come first, then node contacts, at most layout.max_contacts in all (the
/// rest are cut and kFrameContactsTruncated is set). Targets: the attached body's is
/// data.target, the others' data.body_targets. Returns the bytes written, or 0 when `data`
/// or `axis_torques` do not match the layout or `out` is shorter than
/// layout.max_frame_bytes() (nothing is written then). noexcept, no allocation.
std::size_t encode_state_frame(const StateFrameLayout& layout, const core::Data& data,
                               const PeriodReport& report, std::span<const double> axis_torques,
                               const StateFrameFigures& figures, std::span<std::byte> out) noexcept;

}  // namespace numen::platform
