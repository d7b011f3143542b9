#pragma once
/// @file device_config.hpp
/// DeviceConfig: everything the scene says about one tracked instrument on the bus — its kind,
/// its axes (CANopen ids, scaling, limits, drives), the sample checks' limits, the tool offset
/// and the kind's geometry. Built at load time (may allocate, may throw), read-only afterwards.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/axis.hpp"
#include "numen/hal/phantom_kinematics.hpp"
#include "numen/hal/pose_tracker_kinematics.hpp"
#include "numen/hal/trocar_kinematics.hpp"

namespace numen::hal {

/// Which kinematics an instrument has.
enum class DeviceKind : std::uint8_t {
  kTrocarInstrument,  ///< Laparoscopic tool through a trocar: 5 axes (TrocarKinematics).
  kPoseTracker,       ///< 6-DOF hand controller / pose tracker: 6 axes (PoseTrackerKinematics).
  kPhantom,           ///< PHANToM-like haptic arm: 6 axes, 3 driven (PhantomKinematics).
};

/// Short English name of a DeviceKind (static string): "trocar instrument", "pose tracker",
/// "phantom"; "unknown" for a value outside the enum.
const char* to_string(DeviceKind kind) noexcept;

/// Number of axes a device kind has (5 trocar instrument, 6 pose tracker, 6 phantom); 0 for a
/// value outside the enum.
int expected_axis_count(DeviceKind kind) noexcept;

/// Configuration of one instrument. Checked by validate().
struct DeviceConfig {
  /// Name used in error messages and traces.
  std::string name = "device";
  /// Kinematic kind; fixes the number and meaning of the axes.
  DeviceKind kind = DeviceKind::kTrocarInstrument;
  /// Axes in the kind's order (TrocarKinematics::kPivotX.., PoseTrackerKinematics::kX..,
  /// PhantomKinematics::kTurret..).
  std::vector<AxisConfig> axes;
  /// Control period, s, > 0 (used for the default max sample age).
  double control_period_s = 1e-3;
  /// Oldest acceptable encoder sample, s (now − frame timestamp); unset = 3 control periods.
  std::optional<double> max_sample_age_s;
  /// Allowance of the jump check on top of max_speed · Δt, encoder counts, >= 0
  /// (quantisation and jitter).
  double jump_tolerance_counts = 2.0;
  /// Pose of the controlled frame in the tool frame (tool tip frame for a trocar instrument,
  /// tracked frame for a pose tracker, stylus frame for a phantom). Identity: the controlled
  /// frame is the tool frame.
  core::Pose tool_offset;
  /// Trocar point and frame in world (kTrocarInstrument only).
  TrocarGeometry trocar;
  /// Tracker base frame in world (kPoseTracker only).
  PoseTrackerGeometry tracker;
  /// Arm base frame in world and link lengths (kPhantom only).
  PhantomGeometry phantom;

  /// The max sample age in effect, s: max_sample_age_s or 3 · control_period_s.
  double effective_max_sample_age_s() const noexcept {
    return max_sample_age_s ? *max_sample_age_s : 3.0 * control_period_s;
  }
};

/// Throws std::invalid_argument with a message naming the device and the field if `config`
/// is invalid: wrong axis count for the kind, an invalid axis (validate_axis()), COB-IDs
/// outside 0x001–0x7FF, equal to 0x080 (SYNC) or used twice, non-positive period or age,
/// negative jump tolerance, non-finite positions, non-unit quaternions (|‖q‖ − 1| > 1e-6),
/// phantom link lengths not finite and > 0. Only the geometry of the config's kind is checked.
void validate(const DeviceConfig& config);

/// A trocar instrument with typical trainer values; nodes first_node_id .. +4 for
/// (pivot_x, pivot_y, depth, roll, jaw); drives on pivot_x, pivot_y and depth (0x200 + node).
/// Resolutions: 2^14 counts/rev on angles, 10 µm on depth. Throws if the ids exceed 127.
DeviceConfig make_default_trocar_config(std::uint8_t first_node_id = 1);

/// A non-haptic pose tracker with typical values; nodes first_node_id .. +5 for
/// (x, y, z, yaw, pitch, roll), 1 µm and 1 µrad resolution, no drives. Throws if the ids
/// exceed 127.
DeviceConfig make_default_pose_tracker_config(std::uint8_t first_node_id = 1);

/// A PHANToM Premium 1.0-like haptic arm (l1 = l2 = 0.14 m, base at the world origin); nodes
/// first_node_id .. +5 for (turret, shoulder, elbow, gimbal_yaw, gimbal_pitch, stylus_roll);
/// drives (0x200 + node) on turret, shoulder and elbow only, as on a PHANToM (rated 0.25 N·m,
/// saturated at 1.0 N·m: ~7 N at the 0.14 m gimbal); 2^16 counts/rev on the driven axes
/// (motor encoders through the capstan), 2^14 on the gimbal. Plausibility ranges around the
/// "L" home posture q = 0: turret ±1.0 rad, shoulder ±0.8 rad, elbow −1.0..0.7 rad (the
/// gimbal centre stays in front of the turret axis), gimbal yaw ±2.6 rad, gimbal pitch
/// ±1.2 rad (clear of the gimbal lock), stylus roll wraps; max speeds 10 rad/s on the arm,
/// 30 rad/s on the gimbal. Throws if the ids exceed 127.
DeviceConfig make_default_phantom_config(std::uint8_t first_node_id = 1);

}  // namespace numen::hal
