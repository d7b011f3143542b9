#pragma once
/// @file phantom_kinematics.hpp
/// PhantomKinematics: a PHANToM-like impedance haptic arm (SensAble PHANToM Premium 1.0 class):
/// a turret turning about a vertical axis, a two-link arm (upper arm and forearm) in the
/// turret's vertical plane, and a three-axis gimbal carrying the stylus at the end of the
/// forearm. Motors drive the turret, the shoulder and the elbow; the gimbal is measured only.
/// See docs/protocol.md.
///
/// Convention (ours, after M. C. Çavuşoğlu, D. Feygin, F. Tendick, "A Critical Study of the
/// Mechanical and Electrical Properties of the PHANToM Haptic Interface and Improvements for
/// High Performance Control", Presence 11(6), 2002: the elbow is driven from the base through
/// a parallelogram / capstan, so the elbow encoder reads the forearm's pitch relative to the
/// turret, not relative to the upper arm). All rotations are right-handed about the named axis.
///
/// Base frame B (PhantomGeometry::base, a pose in world): origin at the shoulder (where the
/// turret axis meets the shoulder axis), z_B up along the turret axis, x_B the arm's reach
/// direction at q0 = 0 (towards the user), y_B = z_B × x_B. R_b, s: base orientation and
/// origin in world.
///
/// Axes q = (q0, q1, q2, q3, q4, q5), rad:
///   q0 turret yaw about z_B:                 R_T = R_b · Rz(q0);
///   q1 shoulder pitch about the turret y:    R_U = R_T · Ry(q1), elbow e = s + l1 · R_U e_x
///      (q1 = 0: upper arm horizontal; q1 > 0 lowers the elbow);
///   q2 elbow pitch about the turret y, measured from the turret (absolute, parallelogram):
///      R_F = R_T · Ry(q2), gimbal centre g = e − l2 · R_F e_z
///      (q2 = 0: forearm hanging vertically down from the elbow; q2 > 0 swings the gimbal back
///      towards the turret axis). Moving q1 alone translates the forearm without turning it;
///   q3 gimbal yaw about the forearm axis z_F, q4 gimbal pitch about the yawed y, q5 stylus
///      roll about the pen:  R_S = R_F · Rz(q3) · Ry(q4) · Rx(q5).
/// Stylus frame: origin at the gimbal centre g, x_S along the pen (q = 0: the pen points along
/// x_B, away from the base). Controlled frame = stylus frame · tool_offset.
///
/// At q = 0 the arm forms an "L": elbow at s + l1 x_B, gimbal centre at s + l1 x_B − l2 z_B,
/// stylus frame = base orientation. In the turret's vertical plane the gimbal centre is at
/// reach ρ = l1 cos q1 − l2 sin q2 and height h = −l1 sin q1 − l2 cos q2 from the shoulder.
/// Singularities: the arm stretched (q2 − q1 = −π/2) or folded (q2 − q1 = +π/2); the gimbal
/// centre on the turret axis (ρ = 0); gimbal lock at |q4| = π/2 (pen along the forearm).
///
/// Links (Kinematics::link_pose), each a frame in world:
///   0 "tool"       the controlled frame (== forward());
///   1 "turret"     origin s, orientation R_T (turns with q0 only);
///   2 "upper_arm"  origin s (the shoulder), orientation R_U (upper arm along x);
///   3 "forearm"    origin e (the elbow), orientation R_F (forearm along −z, towards g);
///   4 "stylus"     origin g (the gimbal centre), orientation R_S.

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// Where a PHANToM-like arm is, and its link lengths.
struct PhantomGeometry {
  /// Pose of the base frame B in world: origin at the shoulder, z up along the turret axis,
  /// x the reach direction at q0 = 0 (see the file comment). Identity by default.
  core::Pose base;
  /// Upper arm length, shoulder to elbow, m, finite and > 0 (PHANToM Premium 1.0: ~0.14 m).
  double l1 = 0.14;
  /// Forearm length, elbow to gimbal centre, m, finite and > 0 (PHANToM Premium 1.0: ~0.14 m).
  double l2 = 0.14;
};

/// Kinematics of a PHANToM-like haptic arm; six revolute axes (turret, shoulder, elbow, gimbal
/// yaw, gimbal pitch, stylus roll). Immutable after construction; every member noexcept and
/// allocation free except the constructor.
class PhantomKinematics final : public Kinematics {
 public:
  static constexpr int kTurret = 0;       ///< Index of q0, turret yaw (rad).
  static constexpr int kShoulder = 1;     ///< Index of q1, shoulder pitch (rad).
  static constexpr int kElbow = 2;        ///< Index of q2, elbow (forearm) pitch (rad).
  static constexpr int kGimbalYaw = 3;    ///< Index of q3, gimbal yaw about the forearm (rad).
  static constexpr int kGimbalPitch = 4;  ///< Index of q4, gimbal pitch (rad).
  static constexpr int kStylusRoll = 5;   ///< Index of q5, stylus roll about the pen (rad).
  static constexpr int kNumAxes = 6;      ///< Number of axes.

  static constexpr int kLinkTool = 0;      ///< Link "tool": the controlled frame.
  static constexpr int kLinkTurret = 1;    ///< Link "turret": at the shoulder, turns with q0.
  static constexpr int kLinkUpperArm = 2;  ///< Link "upper_arm": at the shoulder.
  static constexpr int kLinkForearm = 3;   ///< Link "forearm": at the elbow.
  static constexpr int kLinkStylus = 4;    ///< Link "stylus": at the gimbal centre.
  static constexpr int kNumLinks = 5;      ///< Number of links.

  /// `geometry`: base pose in world and link lengths; `tool_offset`: pose of the controlled
  /// frame in the stylus frame. Throws std::invalid_argument if a position is not finite, a
  /// quaternion is not unit length within 1e-6 (they are normalised otherwise), or a length
  /// is not finite and > 0.
  explicit PhantomKinematics(const PhantomGeometry& geometry = {},
                             const core::Pose& tool_offset = {});

  /// Number of axes: 6.
  int num_axes() const noexcept override { return kNumAxes; }

  /// World pose of the controlled frame (stylus frame · tool_offset).
  core::Pose forward(const AxisVector& q) const noexcept override;

  /// World pose of the stylus frame (origin at the gimbal centre), without tool_offset.
  core::Pose stylus_pose(const AxisVector& q) const noexcept;

  /// 6 x 6 geometric Jacobian of the controlled frame, world frame, linear rows at its origin
  /// p. With z_b = R_b e_z, y_T = R_T e_y, ω3 = R_F e_z, ω4 = R_F Rz(q3) e_y,
  /// ω5 = R_F Rz(q3) Ry(q4) e_x:
  ///   q0: [z_b × (p − s); z_b]     q1: [y_T × (e − s); 0]   (the forearm translates)
  ///   q2: [y_T × (p − e); y_T]     q3..q5: [ω_i × (p − g); ω_i].
  Jacobian jacobian(const AxisVector& q) const noexcept override;

  /// Axes for a controlled-frame pose (q_free: n entries or empty). The stylus pose is
  /// pose · tool_offset⁻¹. Position of the gimbal centre in B → q0..q2:
  ///   q0 = atan2(y, x) (the turret faces the target; q_free[0], or 0, when the target is
  ///   within 1e-12 m of the turret axis), then the planar two-link solution on the branch
  ///   |q2 − q1| < π/2 (elbow above the shoulder–gimbal line, as on the PHANToM; forward() of
  ///   any q with angles in (−π, π], ρ > 0, |q2 − q1| < π/2 and |q4| < π/2 is inverted
  ///   exactly). A target farther than
  ///   l1 + l2 or nearer than |l1 − l2| from the shoulder is moved radially onto that boundary
  ///   (a target at the shoulder itself: straight below it); the result is always finite.
  /// Orientation → gimbal: R_Fᵀ R_S = Rz(q3) Ry(q4) Rx(q5) (Z-Y-X Euler), q4 in [−π/2, π/2];
  /// at gimbal lock (cos q4 < 1e-8) q5 = q_free[5] (or 0) and q3 takes the rest. The
  /// orientation is always reproduced exactly. Angles are returned in (−π, π].
  AxisVector inverse(const core::Pose& pose, const AxisVector& q_free) const noexcept override;

  /// Number of links: 5 ("tool", "turret", "upper_arm", "forearm", "stylus").
  int num_links() const noexcept override { return kNumLinks; }

  /// Name of link `link` (static string), "" out of range.
  const char* link_name(int link) const noexcept override;

  /// World pose of link `link` at q (see the file comment). An index out of [0, 5) gives
  /// link 0 (the controlled frame).
  core::Pose link_pose(int link, const AxisVector& q) const noexcept override;

  /// 6 x 6 geometric Jacobian of link `link`, world frame, linear rows at the link's origin
  /// (notation of jacobian(); columns not listed are zero):
  ///   turret:    q0: [0; z_b];
  ///   upper_arm: q0: [0; z_b], q1: [0; y_T];
  ///   forearm:   q0: [z_b × (e − s); z_b], q1: [y_T × (e − s); 0], q2: [0; y_T];
  ///   stylus:    q0: [z_b × (g − s); z_b], q1: [y_T × (e − s); 0], q2: [y_T × (g − e); y_T],
  ///              q3..q5: [0; ω_i];
  ///   tool:      jacobian(). An index out of [0, 5) gives link 0's.
  /// Axis torques for wrenches w_l at the links' origins: τ = Σ_l J_lᵀ w_l.
  Jacobian link_jacobian(int link, const AxisVector& q) const noexcept override;

  /// Base pose (quaternion normalised) and link lengths.
  const PhantomGeometry& geometry() const noexcept { return geometry_; }
  /// Pose of the controlled frame in the stylus frame (quaternion normalised).
  const core::Pose& tool_offset() const noexcept { return tool_offset_; }

 private:
  // World frames of one configuration.
  struct Frames {
    core::Quat turret, upper_arm, forearm, stylus;  // R_T, R_U, R_F, R_S
    core::Vec3 elbow, gimbal;                       // e, g
  };
  Frames frames(const AxisVector& q) const noexcept;
  // Jacobian of a frame fixed to the stylus whose world origin is `origin`.
  Jacobian stylus_fixed_jacobian(const AxisVector& q, const Frames& f,
                                 const core::Vec3& origin) const noexcept;

  PhantomGeometry geometry_;
  core::Pose tool_offset_;
};

}  // namespace numen::hal
