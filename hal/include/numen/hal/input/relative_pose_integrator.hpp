#pragma once
/// @file relative_pose_integrator.hpp
/// RelativePoseIntegrator: turns the events of a relative-displacement device (a mouse, a
/// 3D mouse: EV_REL counts) into a target pose for the tool, with a clutch (motion ignored
/// while released: classic clutching / indexing) and a scale per axis. This is how the
/// Generalized God-Objects paper drives a tool with a plain mouse.
///
/// Event semantics (kernel Documentation/input/event-codes.rst, "EV_SYN"):
///  - events are buffered until EV_SYN/SYN_REPORT, then the whole report is applied at once;
///  - EV_SYN/SYN_DROPPED: the kernel's buffer overran; everything pending and every event up
///    to and including the next SYN_REPORT is discarded (counted). The clutch key may have
///    changed unseen, so a drop disengages the clutch (both modes): kHold engages again when
///    the key is seen pressed or reported pressed by sync_clutch_key() (EvdevPointer calls
///    it after libevdev's resync), kToggle on the next press. Safe: no motion on stale state.
///
/// Clutch: a report whose events change the clutch state moves nothing, whatever order its
/// events come in (within a report the kernel gives no order). Only reports that begin and
/// end with the clutch engaged move the target.
///
/// Frames (docs/architecture.md, Conventions): the target pose is in the world frame. With
/// MotionFrame::kWorld, the translation increment (dx, dy, dz) is added in world axes and the
/// rotation increment turns about world axes (q ← Δq · q). With MotionFrame::kTool, both are
/// in the tool frame at the start of the report (p ← p + R Δp, q ← q · Δq). The rotation
/// increment of one report is the exponential map of the rotation vector (roll, pitch, yaw)
/// = (about x, about y, about z), rad — not an Euler sequence, so the order of axes in a
/// report does not matter. The orientation is normalised after every report.
///
/// Workspace: after each report the position is clamped to the box [workspace_min,
/// workspace_max] (world, m); motion past a wall is lost, not stored, so moving back leaves
/// the wall at once. Clamped reports are counted.
///
/// feed() and the other run-time members are noexcept and allocation free. Not thread safe.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/input/input_event.hpp"

namespace numen::hal {

/// Degree of freedom of the target pose a relative axis drives.
enum class PoseDof : std::uint8_t {
  kX,      ///< Translation along x, m.
  kY,      ///< Translation along y, m.
  kZ,      ///< Translation along z, m.
  kRoll,   ///< Rotation about x, rad.
  kPitch,  ///< Rotation about y, rad.
  kYaw,    ///< Rotation about z, rad.
};

/// One relative axis → one pose DOF. Several axes may drive the same DOF (their increments
/// add); one axis may drive several DOFs through several entries.
struct RelAxisMapping {
  /// EV_REL code, 0 .. REL_MAX (REL_X, REL_Y, REL_Z, REL_RX, REL_RY, REL_RZ, REL_HWHEEL,
  /// REL_WHEEL, ...). A wheel is reported both as REL_WHEEL (detents) and, by newer
  /// kernels, REL_WHEEL_HI_RES (1/120 detent): map one of the two, not both.
  std::uint16_t code = REL_X;
  /// The DOF it drives.
  PoseDof dof = PoseDof::kX;
  /// m per count (kX, kY, kZ) or rad per count (kRoll, kPitch, kYaw); the sign sets the
  /// direction. Finite.
  double scale = 1e-4;
};

/// How the clutch key engages motion.
enum class ClutchMode : std::uint8_t {
  kHold,    ///< Engaged while the key is held down (value != 0).
  kToggle,  ///< Each press (value 1) toggles; releases and autorepeat (value 2) do nothing.
  kNone,    ///< No clutch: always engaged; key events are ignored.
};

/// Frame in which translation and rotation increments are expressed (see the file comment).
enum class MotionFrame : std::uint8_t {
  kWorld,  ///< World axes (default: a mouse on a desk moves the tool in the scene's axes).
  kTool,   ///< The tool's own axes at the start of the report.
};

/// Most axis mappings a RelativePoseIntegrator takes.
inline constexpr std::size_t kMaxRelAxisMappings = 16;

/// Creation settings of a RelativePoseIntegrator (checked by its constructor).
struct RelativePoseIntegratorSettings {
  /// Axis mappings, at most kMaxRelAxisMappings. Default: a desk mouse driving x, y, z: REL_X
  /// → +x and REL_Y → −y at 0.1 mm per count (evdev's REL_Y grows towards the user; pushing
  /// the mouse away moves the tool to +y), REL_WHEEL → +z at 2 mm per detent (wheel away:
  /// up), REL_HWHEEL → yaw at 5° per detent.
  std::vector<RelAxisMapping> axes = {
      {REL_X, PoseDof::kX, 1e-4},
      {REL_Y, PoseDof::kY, -1e-4},
      {REL_WHEEL, PoseDof::kZ, 2e-3},
      {REL_HWHEEL, PoseDof::kYaw, 0.087266462599716474},
  };
  /// EV_KEY code of the clutch key, 0 .. KEY_MAX (BTN_LEFT, BTN_RIGHT, BTN_MIDDLE, a key).
  std::uint16_t clutch_key = BTN_LEFT;
  /// How the clutch key engages motion.
  ClutchMode clutch_mode = ClutchMode::kHold;
  /// Frame of the increments.
  MotionFrame frame = MotionFrame::kWorld;
  /// Target pose at construction and after reset(); its position must lie in the workspace.
  /// The orientation is normalised (must not be zero).
  core::Pose initial_pose{};
  /// Workspace box, world, m: lower corner (may be −infinity). Each entry <= workspace_max.
  core::Vec3 workspace_min = core::Vec3::Constant(-0.5);
  /// Workspace box, world, m: upper corner (may be +infinity).
  core::Vec3 workspace_max = core::Vec3::Constant(0.5);
};

/// Counters of a RelativePoseIntegrator since construction (reset() keeps them).
struct RelativePoseCounters {
  std::uint64_t events = 0;            ///< Events passed to feed().
  std::uint64_t reports = 0;           ///< SYN_REPORTs that closed a report (applied).
  std::uint64_t moving_reports = 0;    ///< Applied reports that moved the target.
  std::uint64_t ignored_reports = 0;   ///< Reports with mapped motion ignored: clutch released
                                       ///< or changed within the report.
  std::uint64_t dropped = 0;           ///< SYN_DROPPED events and drop_pending() calls.
  std::uint64_t discarded_events = 0;  ///< Events discarded by a drop (pending or after it).
  std::uint64_t clamped_reports = 0;   ///< Reports whose position was clamped to the workspace.
  std::uint64_t unmapped_events = 0;   ///< EV_REL events of a code no mapping uses.
  std::uint64_t other_events = 0;      ///< Events of other types or keys (EV_MSC, ...): ignored.
};

/// Integrates relative events into a target pose (see the file comment for the semantics).
class RelativePoseIntegrator {
 public:
  /// Checks the settings; throws std::invalid_argument naming the field: more than
  /// kMaxRelAxisMappings axes, an axis code > REL_MAX, a non-finite scale, clutch_key >
  /// KEY_MAX, a NaN or inverted workspace bound, an initial position outside the workspace or
  /// a zero / non-finite initial orientation.
  explicit RelativePoseIntegrator(const RelativePoseIntegratorSettings& settings = {});

  /// Takes one event (see the file comment). noexcept, allocation free.
  void feed(const InputEvent& event) noexcept;

  /// The reader lost events (libevdev reported LIBEVDEV_READ_STATUS_SYNC and will deliver
  /// the resynchronised state as ordinary events): discards the pending report, counts a
  /// drop, and disengages the clutch (see the file comment). Unlike a
  /// SYN_DROPPED event it does not discard the events that follow.
  void drop_pending() noexcept;

  /// Tells the integrator the clutch key's current state, read from the device (libevdev's
  /// state after a resync). In kHold mode sets the clutch to it; in kToggle mode only records
  /// the key (the toggle state is the integrator's own). Takes effect between reports; a
  /// pending report containing motion is then ignored, as any report across a clutch change.
  void sync_clutch_key(bool pressed) noexcept;

  /// Ends a control period at time `now_ns` (ns, the clock of the events): updates twist()
  /// from the pose change since the previous end_period() call. The first call only sets the
  /// reference. noexcept, allocation free.
  void end_period(std::int64_t now_ns) noexcept;

  /// Moves the target to `pose` (clamped to the workspace, orientation normalised; a
  /// non-finite coordinate takes the initial pose's, a zero orientation identity), drops
  /// the pending report and zeroes the twist; the clutch state is kept. Counters are kept.
  void reset(const core::Pose& pose) noexcept;

  /// Target pose, world frame (position m, unit quaternion).
  const core::Pose& target() const noexcept { return target_; }
  /// Twist estimate over the last period (end_period()): linear m/s and angular rad/s, both
  /// in world coordinates (core::Twist). Zero before two end_period() calls.
  const core::Twist& twist() const noexcept { return twist_; }
  /// True while motion moves the target.
  bool engaged() const noexcept;
  /// True between a SYN_DROPPED and the next SYN_REPORT.
  bool dropping() const noexcept { return dropping_; }
  /// Time stamp of the last applied report (its SYN_REPORT), ns; 0 before the first.
  std::int64_t last_report_ns() const noexcept { return last_report_ns_; }
  /// Counters.
  const RelativePoseCounters& counters() const noexcept { return counters_; }
  /// The settings the integrator was built with.
  const RelativePoseIntegratorSettings& settings() const noexcept { return settings_; }

 private:
  void apply_report(std::int64_t time_ns) noexcept;
  void clear_pending() noexcept;
  bool clamp_position() noexcept;

  RelativePoseIntegratorSettings settings_;
  std::array<RelAxisMapping, kMaxRelAxisMappings> axes_{};
  std::size_t num_axes_ = 0;
  std::array<bool, REL_CNT> mapped_{};           // code used by some mapping
  std::array<std::int64_t, REL_CNT> pending_{};  // counts of the open report, per code
  std::uint64_t pending_events_ = 0;             // events of the open report
  bool pending_motion_ = false;                  // some mapped count != 0 in the open report
  // Clutch: key_down_ is the key as last seen; engaged_ the clutch at the last report
  // boundary; pending_engaged_ what it will be at the end of the open report.
  bool key_down_ = false;
  bool engaged_ = false;
  bool pending_engaged_ = false;
  bool clutch_changed_ = false;  // the clutch changed within the open report
  bool dropping_ = false;
  core::Pose target_{};
  core::Pose period_start_{};
  core::Twist twist_{};
  std::int64_t last_period_ns_ = 0;
  bool have_period_ = false;
  std::int64_t last_report_ns_ = 0;
  RelativePoseCounters counters_{};
};

}  // namespace numen::hal
