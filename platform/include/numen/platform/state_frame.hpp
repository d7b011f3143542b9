#pragma once
/// @file state_frame.hpp
/// The state frame: one period of the simulated world, as the viewer and any other renderer
/// receive it (docs/viewer.md, "Frames"). A frame is a little-endian byte string of an 84-byte
/// header followed by float32 arrays; its size depends only on the scene (bodies, net nodes,
/// axes, graspers, the loop's other devices and their axes, suture threads and their nodes) and
/// on the contacts of the period. The loop writes it straight into a preallocated
/// buffer (encode_state_frame(): noexcept, no allocation); readers check it with
/// decode_state_frame(), which never reads past the bytes it is given.
///
/// Layout: kStateFrameFields (the header's fields: name, byte offset, type) and
/// kStateFrameArrays (the float32 arrays after it: name, floats per item, the header count the
/// item repeats), below. The encoder, the decoder, the viewer page (the view server sends
/// both lists in its session message) and `numen figures --all` all read these two lists.
/// u16/u32/i32/u64/i64 are little-endian, f32 IEEE 754 little-endian.
///
/// Frame: world (z up in the shipped scenes). Poses are of each body's centre-of-mass frame,
/// as core::BodyState. float32 keeps 0.06 µm at 1 m: ample for display, not for analysis
/// (use --trace for that).

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "numen/core/data.hpp"
#include "numen/platform/control_loop.hpp"

namespace numen::platform {

/// First bytes of every frame.
inline constexpr char kStateFrameMagic[4] = {'N', 'M', 'V', 'F'};
/// Version written by encode_state_frame() and the only one decode_state_frame() accepts.
/// 5: the suture threads (num_threads, num_thread_nodes, thread, thread_node; issue 69).
/// 6: a grasp item's held thread (its ninth float; docs/thread.md "The thread in the jaws").
inline constexpr std::uint16_t kStateFrameVersion = 6;
/// Size of the fixed header, bytes.
inline constexpr std::size_t kStateFrameHeaderBytes = 84;

/// Bytes of each float32 of the arrays.
inline constexpr std::size_t kFrameFloatBytes = sizeof(float);
static_assert(kFrameFloatBytes == 4);

/// Wire type of a header field: unsigned or signed integers of 1 to 8 bytes (little-endian),
/// or four bytes taken as they are (char[4]).
enum class FrameFieldType : std::uint8_t { kU8, kU16, kU32, kI32, kU64, kI64, kChar4 };

/// Bytes a field of type `t` occupies.
constexpr std::size_t frame_field_bytes(FrameFieldType t) noexcept {
  switch (t) {
    case FrameFieldType::kU8: return 1;
    case FrameFieldType::kU16: return 2;
    case FrameFieldType::kU32:
    case FrameFieldType::kI32:
    case FrameFieldType::kChar4: return 4;
    case FrameFieldType::kU64:
    case FrameFieldType::kI64: return 8;
  }
  return 0;
}

/// The name of `t` in the docs and the session message: "u8", "u16", "u32", "i32", "u64",
/// "i64", "char[4]".
constexpr std::string_view frame_field_type_name(FrameFieldType t) noexcept {
  switch (t) {
    case FrameFieldType::kU8: return "u8";
    case FrameFieldType::kU16: return "u16";
    case FrameFieldType::kU32: return "u32";
    case FrameFieldType::kI32: return "i32";
    case FrameFieldType::kU64: return "u64";
    case FrameFieldType::kI64: return "i64";
    case FrameFieldType::kChar4: return "char[4]";
  }
  return "";
}

/// The header's fields, in their order: each one's index in kStateFrameFields. kHeldBody's
/// name on the wire is `attached_body` (the viewer's protocol, kept).
enum class FrameField : std::uint8_t {
  kMagic, kVersion, kHeaderBytes, kFrameBytes, kNumBodies, kNumNodes, kNumContacts, kNumAxes,
  kHeldBody, kPeriod, kTimeNs, kStepStatus, kFlags, kStepNs, kLifecycle, kStartup, kFaultCause,
  kSampleFaults, kNumGrasps, kNumExtraDevices, kNumExtraAxes, kNumThreads, kNumThreadNodes
};

/// One field of the header.
struct StateFrameField {
  FrameField id;          ///< Its index in kStateFrameFields.
  std::string_view name;  ///< Everywhere the field is named: StateFrameHeader, the page, the docs.
  std::size_t offset;     ///< Byte offset in the frame.
  FrameFieldType type;    ///< Wire type (its size: frame_field_bytes()).
};

/// The 84-byte header, field by field (names as StateFrameHeader's members):
///
///     magic          "NMVF" (kStateFrameMagic)
///     version        kStateFrameVersion (6)
///     header_bytes   kStateFrameHeaderBytes (84)
///     frame_bytes    the whole frame, bytes
///     num_bodies     B: bodies
///     num_nodes      N: net nodes
///     num_contacts   C: contacts
///     num_axes       A: device axes
///     attached_body  the held body's index, −1: none
///     period         period index k
///     time_ns        simulated time t = k·dt, ns
///     step_status    core::StepStatus bits of the period's core::step
///     flags          StateFrameFlag bits
///     step_ns        wall time of core::step, ns (saturated at 2³²−1)
///     lifecycle      hal::LifecycleState
///     startup        hal::StartupPhase
///     fault_cause    hal::FaultCause of the latched safe state (the device's first_fault()),
///                    0 (kNone) while none is latched
///     sample_faults  hal::SampleFault bits of the device's samples in the periods since the
///                    previous frame of the stream (OR'ed: a rejection between two frames is
///                    not lost to the decimation); the period's own when every period is sent
///     num_grasps     G: graspers (core::Model::grasps)
///     num_extra_devices  D: the loop's devices after the first (device 0, whose state the
///                    fields above and the feedback and axis_torque arrays carry): 0 for one
///                    device
///     num_extra_axes E: their axes, all together
///     num_threads    H: suture threads (core::Model::threads; 0 without)
///     num_thread_nodes T: their nodes, all together (Σ segments + 1)
/// The device fields above (flags but kFrameOverrun and kFrameContactsTruncated, lifecycle,
/// startup, fault_cause, sample_faults) are device 0's; the other devices' are in the
/// extra_device array.
inline constexpr std::array<StateFrameField, 23> kStateFrameFields{{
    {FrameField::kMagic, "magic", 0, FrameFieldType::kChar4},
    {FrameField::kVersion, "version", 4, FrameFieldType::kU16},
    {FrameField::kHeaderBytes, "header_bytes", 6, FrameFieldType::kU16},
    {FrameField::kFrameBytes, "frame_bytes", 8, FrameFieldType::kU32},
    {FrameField::kNumBodies, "num_bodies", 12, FrameFieldType::kU32},
    {FrameField::kNumNodes, "num_nodes", 16, FrameFieldType::kU32},
    {FrameField::kNumContacts, "num_contacts", 20, FrameFieldType::kU32},
    {FrameField::kNumAxes, "num_axes", 24, FrameFieldType::kU32},
    {FrameField::kHeldBody, "attached_body", 28, FrameFieldType::kI32},
    {FrameField::kPeriod, "period", 32, FrameFieldType::kU64},
    {FrameField::kTimeNs, "time_ns", 40, FrameFieldType::kI64},
    {FrameField::kStepStatus, "step_status", 48, FrameFieldType::kU32},
    {FrameField::kFlags, "flags", 52, FrameFieldType::kU32},
    {FrameField::kStepNs, "step_ns", 56, FrameFieldType::kU32},
    {FrameField::kLifecycle, "lifecycle", 60, FrameFieldType::kU8},
    {FrameField::kStartup, "startup", 61, FrameFieldType::kU8},
    {FrameField::kFaultCause, "fault_cause", 62, FrameFieldType::kU8},
    {FrameField::kSampleFaults, "sample_faults", 63, FrameFieldType::kU8},
    {FrameField::kNumGrasps, "num_grasps", 64, FrameFieldType::kU32},
    {FrameField::kNumExtraDevices, "num_extra_devices", 68, FrameFieldType::kU32},
    {FrameField::kNumExtraAxes, "num_extra_axes", 72, FrameFieldType::kU32},
    {FrameField::kNumThreads, "num_threads", 76, FrameFieldType::kU32},
    {FrameField::kNumThreadNodes, "num_thread_nodes", 80, FrameFieldType::kU32},
}};

/// The declaration of header field `f`.
constexpr const StateFrameField& frame_field(FrameField f) noexcept {
  return kStateFrameFields[static_cast<std::size_t>(f)];
}

/// The arrays after the header, in their order: each one's index in kStateFrameArrays.
enum class FrameArray : std::uint8_t {
  kBodyPose, kTargetPose, kNodePosition, kContact, kFeedback, kAxisTorque, kPenetration,
  kDeviceLoop, kGrasp, kExtraDevice, kExtraAxisTorque, kThread, kThreadNode
};

/// One float32 array after the header: `count` items of `floats` floats each.
struct StateFrameArray {
  FrameArray id;                    ///< Its index in kStateFrameArrays.
  std::string_view name;            ///< The name StateFrameView's accessor and the page use.
  std::size_t floats;               ///< float32 values per item.
  std::optional<FrameField> count;  ///< Header count of items (B, N, C, A, G, D, E, H, T); none: one item.
};

/// The arrays, in order from byte kStateFrameHeaderBytes, each item's floats:
///
///     body_pose      B × 7   position (m) x y z, orientation x y z w
///     target_pose    B × 8   target pose (the hand's ghost) as above, then 1 if the body has
///                            a target this period, else 0
///     node_position  N × 3   net node position (m) x y z
///     contact        C × 10  point (m) x y z, unit normal x y z (pushes the first body out),
///                            depth (m, > 0), force on the first body (N) x y z; rigid contacts
///                            first, then node contacts
///     feedback       1 × 6   feedback wrench sent to the device: force (N) x y z, torque (N·m)
///                            x y z, world frame, about link 0's origin
///     axis_torque    A × 1   torque or force sent to the axis (N·m or N)
///     penetration    1 × 2   tool penetration, hand (target) penetration (m)
///     device_loop    1 × 3   the closed loop's figures (docs/device_plant.md): the hand's
///                            penetration (m, its intent's; the target's in replay), the
///                            force of the hand on the handle (N, 0 in replay), the energy
///                            that flowed into the device port so far (J, Hannaford & Ryu's
///                            observer; 0 in replay)
///     grasp          G × 8   each grasper (core::GraspState, docs/grasping.md): the held body
///                            (−1: none), the net whose tissue it holds (−1: none), the held
///                            nodes (tissue) or grip springs (a body), the jaws' opening (rad),
///                            the grip's pull (N), and its grasps, releases and slips since
///                            the run's start (counts: a grasp that starts and ends between two
///                            frames of a decimated stream still shows in them)
///     extra_device   D × 12  each of the loop's other devices (1, 2, … in the loop's order;
///                            FrameDevice): its flags (StateFrameFlag bits kFrameSampleValid,
///                            kFrameTorqueCommanded, kFrameTargetReady, kFrameBusDown),
///                            lifecycle, startup, fault_cause, sample_faults (as device 0's
///                            header fields, OR'ed since the previous frame likewise), its axis
///                            count, its feedback wrench sent (force N x y z, torque N·m x y z,
///                            world, about its link 0's origin, as feedback)
///     extra_axis_torque E × 1 the torque or force sent to each axis of those devices, device
///                            1's axes first, then device 2's, ... (each device's count in its
///                            item)
///     thread         H × 2   each suture thread (core::ThreadState, in Model::threads order):
///                            the segment it broke at (−1: whole; the view draws it in two
///                            pieces), its largest segment tension this period (N)
///     thread_node    T × 3   the threads' node positions (m) x y z, thread 0's segments + 1
///                            nodes first, then thread 1's, ...
inline constexpr std::array<StateFrameArray, 13> kStateFrameArrays{{
    {FrameArray::kBodyPose, "body_pose", 7, FrameField::kNumBodies},
    {FrameArray::kTargetPose, "target_pose", 8, FrameField::kNumBodies},
    {FrameArray::kNodePosition, "node_position", 3, FrameField::kNumNodes},
    {FrameArray::kContact, "contact", 10, FrameField::kNumContacts},
    {FrameArray::kFeedback, "feedback", 6, std::nullopt},
    {FrameArray::kAxisTorque, "axis_torque", 1, FrameField::kNumAxes},
    {FrameArray::kPenetration, "penetration", 2, std::nullopt},
    {FrameArray::kDeviceLoop, "device_loop", 3, std::nullopt},
    {FrameArray::kGrasp, "grasp", 9, FrameField::kNumGrasps},
    {FrameArray::kExtraDevice, "extra_device", 12, FrameField::kNumExtraDevices},
    {FrameArray::kExtraAxisTorque, "extra_axis_torque", 1, FrameField::kNumExtraAxes},
    {FrameArray::kThread, "thread", 2, FrameField::kNumThreads},
    {FrameArray::kThreadNode, "thread_node", 3, FrameField::kNumThreadNodes},
}};

/// The declaration of array `a`.
constexpr const StateFrameArray& frame_array(FrameArray a) noexcept {
  return kStateFrameArrays[static_cast<std::size_t>(a)];
}

namespace detail {
/// The fields are in kStateFrameFields at their id's index, tile the header from byte 0 to
/// kStateFrameHeaderBytes without gap or overlap, in order, each at a multiple of its size.
constexpr bool frame_fields_tile_the_header() noexcept {
  std::size_t at = 0;
  for (std::size_t i = 0; i < kStateFrameFields.size(); ++i) {
    const StateFrameField& f = kStateFrameFields[i];
    const std::size_t bytes = frame_field_bytes(f.type);
    if (static_cast<std::size_t>(f.id) != i || f.offset != at || bytes == 0 ||
        f.offset % bytes != 0 || f.name.empty())
      return false;
    at += bytes;
  }
  return at == kStateFrameHeaderBytes;
}
/// The arrays are at their id's index, have floats, and repeat a u32 count of the header.
constexpr bool frame_arrays_are_well_formed() noexcept {
  for (std::size_t i = 0; i < kStateFrameArrays.size(); ++i) {
    const StateFrameArray& a = kStateFrameArrays[i];
    if (static_cast<std::size_t>(a.id) != i || a.floats == 0 || a.name.empty()) return false;
    if (a.count && *a.count != FrameField::kNumBodies && *a.count != FrameField::kNumNodes &&
        *a.count != FrameField::kNumContacts && *a.count != FrameField::kNumAxes &&
        *a.count != FrameField::kNumGrasps && *a.count != FrameField::kNumExtraDevices &&
        *a.count != FrameField::kNumExtraAxes && *a.count != FrameField::kNumThreads &&
        *a.count != FrameField::kNumThreadNodes)
      return false;
  }
  return true;
}
}  // namespace detail
static_assert(detail::frame_fields_tile_the_header(),
              "kStateFrameFields must tile the 84-byte header in order, without overlap");
static_assert(detail::frame_arrays_are_well_formed(),
              "kStateFrameArrays: ids in order, floats > 0, counts of bodies/nodes/contacts/axes/"
              "graspers/devices/their axes/threads/their nodes");
static_assert(frame_field(FrameField::kMagic).type == FrameFieldType::kChar4 &&
              sizeof kStateFrameMagic == frame_field_bytes(FrameFieldType::kChar4));

/// float32 values per body pose, per target, per node, per contact, in the wrench, in the
/// figures (kStateFrameArrays' items).
inline constexpr std::size_t kFramePoseFloats = frame_array(FrameArray::kBodyPose).floats,
                             kFrameTargetFloats = frame_array(FrameArray::kTargetPose).floats,
                             kFrameNodeFloats = frame_array(FrameArray::kNodePosition).floats,
                             kFrameContactFloats = frame_array(FrameArray::kContact).floats,
                             kFrameWrenchFloats = frame_array(FrameArray::kFeedback).floats,
                             kFrameFigureFloats = frame_array(FrameArray::kPenetration).floats,
                             kFrameDeviceLoopFloats = frame_array(FrameArray::kDeviceLoop).floats,
                             kFrameGraspFloats = frame_array(FrameArray::kGrasp).floats,
                             kFrameDeviceFloats = frame_array(FrameArray::kExtraDevice).floats,
                             kFrameThreadFloats = frame_array(FrameArray::kThread).floats;
static_assert(kFrameTargetFloats == kFramePoseFloats + 1, "a target is a pose and its flag");

/// Bits of the header's flags word.
enum StateFrameFlag : std::uint32_t {
  kFrameSampleValid = 1u << 0,      ///< The device sample was fresh and plausible this period.
  kFrameTorqueCommanded = 1u << 1,  ///< Non-zero torque went to at least one drive.
  kFrameOverrun = 1u << 2,          ///< The period overran its deadline (paced runs).
  kFrameTargetReady = 1u << 3,      ///< The device has a target (possibly held).
  kFrameContactsTruncated = 1u << 4,  ///< More contacts than the frame's capacity: the rest
                                      ///< were left out (StateFrameLayout::max_contacts).
  kFrameBusDown = 1u << 5,  ///< The device's bus is not working (hal::BusState other than kOk:
                            ///< a CAN bus off or error passive, a network tracker's connection
                            ///< lost; StateFrameFigures::bus_down).
};

/// What fixes a frame's size: the scene's counts and the contact capacity. B, N, A, G, D, E, H,
/// T are the same in every frame of a run; C varies per period, up to max_contacts.
struct StateFrameLayout {
  std::uint32_t num_bodies = 0;    ///< B: core::Model::num_bodies().
  std::uint32_t num_nodes = 0;     ///< N: core::Model::num_nodes().
  std::uint32_t num_axes = 0;      ///< A: the device's axes.
  std::uint32_t max_contacts = 0;  ///< Contacts a frame carries at most (rigid + node).
  std::uint32_t num_grasps = 0;    ///< G: core::Model::grasps.size().
  std::uint32_t num_extra_devices = 0;  ///< D: the loop's devices after device 0.
  std::uint32_t num_extra_axes = 0;     ///< E: their axes, all together.
  std::uint32_t num_threads = 0;        ///< H: core::Model::threads.size().
  /// T: the threads' nodes, all together (Σ ThreadModel::segments + 1; 0 without threads).
  std::uint32_t num_thread_nodes = 0;

  /// Bytes of a frame with `contacts` contacts.
  std::size_t frame_bytes(std::uint32_t contacts) const noexcept;
  /// Bytes of the largest frame (max_contacts contacts): the buffer a writer needs.
  std::size_t max_frame_bytes() const noexcept { return frame_bytes(max_contacts); }
};

/// One grasper of a frame (kStateFrameArrays' grasp item; core::GraspState).
struct FrameGrasp {
  float body;       ///< The held body, −1: none.
  float net;        ///< The net whose tissue is held, −1: none.
  float held;       ///< Held nodes (tissue, a thread) or grip springs (a body); 0: nothing held.
  float opening;    ///< The jaws' opening (rad).
  float grip_force; ///< The grip's pull on what it holds (N).
  float grasps;     ///< Grasps started since the run's start.
  float releases;   ///< Grasps ended by the jaws opening.
  float slips;      ///< Grasps ended by the pull exceeding the grip's limit.
  float thread;     ///< The thread (Model::threads) whose nodes are held, −1: none.
};

/// One of the loop's other devices in a frame (kStateFrameArrays' extra_device item).
struct FrameDevice {
  std::uint32_t flags = 0;        ///< StateFrameFlag bits (sample valid, torque, target ready,
                                  ///< bus down).
  std::uint8_t lifecycle = 0;     ///< hal::LifecycleState.
  std::uint8_t startup = 0;       ///< hal::StartupPhase.
  std::uint8_t fault_cause = 0;   ///< hal::FaultCause of its latched safe state (0: none).
  std::uint8_t sample_faults = 0; ///< hal::SampleFault bits since the previous frame (OR'ed).
  std::uint32_t num_axes = 0;     ///< Its axes (its values in extra_axis_torque).
  float feedback[6] = {};         ///< Feedback wrench sent: N x y z, N·m x y z, world.
};

/// One suture thread of a frame (kStateFrameArrays' thread item; core::ThreadState).
struct FrameThread {
  /// The segment it broke at (core::ThreadState::broken_segment): its nodes i and i + 1 are no
  /// longer joined; −1: whole.
  std::int32_t broken_segment = -1;
  float max_tension = 0.0F;  ///< Its largest segment tension this period (N, ≥ 0).
};

/// One contact of a frame, in the frame's order.
struct FrameContact {
  float point[3];   ///< m, world.
  float normal[3];  ///< Unit, world: pushes the first body (or node) out.
  float depth;      ///< m, > 0.
  float force[3];   ///< N on the first body (or node), world.
};

/// The scalars of a frame's header (the arrays are read through StateFrameView); members
/// are named as their kStateFrameFields entries.
struct StateFrameHeader {
  std::uint32_t frame_bytes = 0;
  std::uint32_t num_bodies = 0, num_nodes = 0, num_contacts = 0, num_axes = 0;
  std::int32_t held_body = -1;
  std::uint64_t period = 0;       ///< Period index k.
  std::int64_t time_ns = 0;       ///< Simulated time, ns.
  std::uint32_t step_status = 0;  ///< core::StepStatus bits.
  std::uint32_t flags = 0;        ///< StateFrameFlag bits.
  std::uint32_t step_ns = 0;      ///< Wall time of core::step, ns (saturated at 2³²−1).
  std::uint8_t lifecycle = 0;     ///< hal::LifecycleState.
  std::uint8_t startup = 0;       ///< hal::StartupPhase.
  std::uint8_t fault_cause = 0;   ///< hal::FaultCause of the latched safe state (0: none).
  std::uint8_t sample_faults = 0; ///< hal::SampleFault bits since the previous frame (OR'ed).
  std::uint32_t num_grasps = 0;   ///< G: graspers.
  std::uint32_t num_extra_devices = 0;  ///< D: the loop's devices after device 0.
  std::uint32_t num_extra_axes = 0;     ///< E: their axes, all together.
  std::uint32_t num_threads = 0;        ///< H: suture threads.
  std::uint32_t num_thread_nodes = 0;   ///< T: their nodes, all together.
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
  /// Tool penetration (m): deepest contact of the held body this period.
  float tool_penetration() const noexcept;
  /// Hand penetration (m): how deep the target pose would sit in the obstacles.
  float target_penetration() const noexcept;
  /// The closed loop's figures (kStateFrameArrays' device_loop): hand penetration (m), force
  /// on the handle (N), device port energy (J).
  void device_loop(float out[3]) const noexcept;
  /// Grasper g; g < num_grasps.
  FrameGrasp grasp(std::uint32_t g) const noexcept;
  /// The loop's device d + 1 (d < num_extra_devices; device 0 is the header's).
  FrameDevice extra_device(std::uint32_t d) const noexcept;
  /// Torque or force sent to value a of extra_axis_torque (a < num_extra_axes).
  float extra_axis_torque(std::uint32_t a) const noexcept;
  /// Suture thread t (t < num_threads).
  FrameThread thread(std::uint32_t t) const noexcept;
  /// Thread node n's position (3 floats, m, world): the threads' nodes in order, thread 0's
  /// first (n < num_thread_nodes).
  void thread_node(std::uint32_t n, float out[3]) const noexcept;

 private:
  friend class StateFrameDecoder;
  float f32(std::size_t offset) const noexcept;
  /// Reads `n` floats from byte `at` on into `out`; returns the byte after them.
  std::size_t f32s(std::size_t at, float* out, std::size_t n) const noexcept;
  /// Byte offset of item `i` of array `a`.
  std::size_t item(FrameArray a, std::size_t i) const noexcept {
    return at_[static_cast<std::size_t>(a)] + kFrameFloatBytes * frame_array(a).floats * i;
  }
  const std::byte* bytes_ = nullptr;
  StateFrameHeader header_{};
  std::array<std::size_t, kStateFrameArrays.size()> at_{};  // each array's byte offset
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
  /// bytes.size() and to the size its counts imply, the other devices' axis counts adding up to
  /// num_extra_axes. On success `view` refers into `bytes` (unchanged otherwise). A frame of
  /// another version (4: an older numen's, before the threads) is refused naming both versions.
  /// A non-finite float is accepted (it is data); a malformed frame is never read past its
  /// end.
  static StateFrameDecodeResult decode(std::span<const std::byte> bytes, StateFrameView& view);
};

/// Figures of a period that the loop does not hold (the runner measures them).
struct StateFrameFigures {
  std::uint64_t period = 0;         ///< Period index k.
  double tool_penetration = 0.0;    ///< m: deepest contact of the held body.
  double target_penetration = 0.0;  ///< m: how deep the target pose sits in the obstacles.
  /// m: how deep the hand's intent sits in the obstacles (closed loop; the target's in replay).
  double hand_penetration = 0.0;
  double handle_force = 0.0;  ///< N: |force of the hand on the handle| (closed loop; 0 in replay).
  double device_port_energy = 0.0;  ///< J: energy into the device port so far (0 in replay).
  /// The device's bus is not working this period (hal::Bus::state() other than kOk): the
  /// frame's kFrameBusDown.
  bool bus_down = false;
};

/// One of the loop's other devices, as encode_state_frame() writes it (its extra_device item and
/// its values of extra_axis_torque).
struct FrameDeviceInput {
  /// Its report of the period (flags, lifecycle, start-up, fault cause, sample faults, the
  /// feedback wrench sent); not null.
  const PeriodReport* report = nullptr;
  std::span<const double> axis_torques;  ///< The torques or forces sent to its axes.
  bool bus_down = false;                 ///< Its bus is not working (kFrameBusDown).
};

/// Writes the frame of the period that just ended into `out`: poses, targets, nodes and
/// contacts from `data` (after core::step), time from data.time, status from
/// data.status, flags, step time, lifecycle, fault cause, sample faults and the feedback wrench
/// sent from `report` (kFrameBusDown from figures.bus_down), the
/// axis torques sent from `axis_torques` (layout.num_axes values), the rest from `figures`.
/// Rigid contacts come first, then node contacts, at most layout.max_contacts in all (the
/// rest are cut and kFrameContactsTruncated is set). Targets: the held body's is
/// data.target, the others' data.body_targets. Graspers from data.grasps. The loop's other
/// devices from `extra_devices` (layout.num_extra_devices of them, their axis torques
/// layout.num_extra_axes in all). The suture threads from data.threads (their broken segment,
/// largest tension and node positions). Returns the bytes written, or 0 when `data` (bodies,
/// nodes, graspers, threads and their nodes), `axis_torques` or `extra_devices` do not match the
/// layout or `out` is shorter than layout.max_frame_bytes() (nothing is written then). noexcept,
/// no allocation.
std::size_t encode_state_frame(const StateFrameLayout& layout, const core::Data& data,
                               const PeriodReport& report, std::span<const double> axis_torques,
                               const StateFrameFigures& figures, std::span<std::byte> out,
                               std::span<const FrameDeviceInput> extra_devices = {}) noexcept;

}  // namespace numen::platform
