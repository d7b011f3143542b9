#pragma once
/// @file pose_tracker_kinematics.hpp
/// PoseTrackerKinematics: a 6-DOF hand controller or pose tracker that reports a position and
/// intrinsic Z-Y-X Euler angles (yaw, pitch, roll) of its tracked frame. See docs/protocol.md.
///
/// Axes q = (x, y, z, yaw, pitch, roll): x, y, z in m, angles in rad, all in the tracker's
/// base frame. Tracked (tool) frame in the base frame:
///   R = Rz(yaw) · Ry(pitch) · Rx(roll),  origin (x, y, z)
/// World pose of the controlled frame = base · tool · tool_offset. With the default identity
/// base and tool_offset the axes are the controlled frame's pose in world. Yaw and roll wrap;
/// pitch is in [−π/2, π/2] and the Jacobian is singular at |pitch| = π/2 (gimbal lock).

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// Where the tracker's base frame is, in world coordinates.
struct PoseTrackerGeometry {
  /// Pose of the tracker's base (measurement) frame in world. Identity by default.
  core::Pose base;
};

/// Kinematics of a 6-DOF pose tracker; six axes (x, y, z, yaw, pitch, roll).
class PoseTrackerKinematics final : public Kinematics {
 public:
  static constexpr int kX = 0;        ///< Index of x (m).
  static constexpr int kY = 1;        ///< Index of y (m).
  static constexpr int kZ = 2;        ///< Index of z (m).
  static constexpr int kYaw = 3;      ///< Index of yaw, about z (rad).
  static constexpr int kPitch = 4;    ///< Index of pitch, about the once-rotated y (rad).
  static constexpr int kRoll = 5;     ///< Index of roll, about the twice-rotated x (rad).
  static constexpr int kNumAxes = 6;  ///< Number of axes.

  /// `geometry`: tracker base in world; `tool_offset`: pose of the controlled frame in the
  /// tracked frame. Throws std::invalid_argument if a position is not finite or a quaternion
  /// is not unit length within 1e-6.
  explicit PoseTrackerKinematics(const PoseTrackerGeometry& geometry = {},
                                 const core::Pose& tool_offset = {});

  /// Number of axes: 6.
  int num_axes() const noexcept override { return kNumAxes; }

  /// World pose of the controlled frame.
  core::Pose forward(const AxisVector& q) const noexcept override;

  /// 6 x 6 geometric Jacobian of the controlled frame, world frame. With R_b the base
  /// rotation, o the tracked origin and p the controlled origin (world):
  ///   x, y, z:  v = R_b e_i, ω = 0;
  ///   ω_yaw = R_b e_z, ω_pitch = R_b Rz(yaw) e_y, ω_roll = R_b Rz(yaw) Ry(pitch) e_x,
  ///   v = ω × (p − o) for the angles.
  Jacobian jacobian(const AxisVector& q) const noexcept override;

  /// Axes for a controlled-frame pose (exact inverse; q_free unused). At gimbal lock
  /// (|pitch| = π/2) roll is set to 0 and yaw carries the combined angle.
  AxisVector inverse(const core::Pose& pose, const AxisVector& q_free) const noexcept override;

  /// Tracker base in world (quaternion normalised).
  const PoseTrackerGeometry& geometry() const noexcept { return geometry_; }
  /// Pose of the controlled frame in the tracked frame (quaternion normalised).
  const core::Pose& tool_offset() const noexcept { return tool_offset_; }

 private:
  PoseTrackerGeometry geometry_;
  core::Pose tool_offset_;
};

}  // namespace numen::hal
