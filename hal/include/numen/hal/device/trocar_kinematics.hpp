#pragma once
/// @file trocar_kinematics.hpp
/// TrocarKinematics: a laparoscopic instrument passing through a trocar, the fixed insertion
/// point (remote centre of motion) of minimally invasive surgery (paper §5: "trocar pivot
/// (2 rotations), tube slides and rolls, jaw opening imposed"). See docs/protocol.md.
///
/// Axes q = (a, b, d, ψ, jaw):
///   a   pivot about the trocar frame's x axis, rad;
///   b   pivot about the resulting (once rotated) y axis, rad;
///   d   insertion depth from the trocar point to the tool tip along the shaft, m;
///   ψ   roll of the tool about the shaft, rad;
///   jaw jaw opening, rad (carried along, no effect on the rigid tool's pose).
/// Tool frame (origin at the tip, z along the shaft towards the tip):
///   R = R_c · Rx(a) · Ry(b) · Rz(ψ),   tip = p_c + d · R e_z
/// with p_c the trocar point and R_c the trocar frame (its z axis is the nominal shaft
/// direction into the patient), both in world. Controlled frame = tool frame · tool_offset.
///
/// Links (Kinematics::link_pose; the parts of the articulated laparoscopic tool, paper §5):
///   0 "tool"    controlled frame: tool frame · tool_offset (== forward());
///   1 "trocar"  the pivoting sleeve: origin p_c, orientation R_s = R_c · Rx(a) · Ry(b)
///               (no roll; z along the shaft towards the tip);
///   2 "tube"    the tool frame: origin at the tip, R_s · Rz(ψ) (== tool_pose());
///   3 "jaw_1"   origin at the tip (the jaw hinge), orientation tube · Rx(+jaw/2);
///   4 "jaw_2"   origin at the tip, orientation tube · Rx(−jaw/2).
/// The jaws open symmetrically about the tube frame's x axis (each by half the opening), so
/// at jaw = 0 both jaw frames coincide with the tube frame.

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// Where the trocar is, in world coordinates.
struct TrocarGeometry {
  /// Trocar (insertion) point p_c, m, world.
  core::Vec3 point = core::Vec3::Zero();
  /// Trocar frame R_c in world; its z axis is the nominal shaft direction (into the patient).
  core::Quat orientation = core::Quat::Identity();
};

/// Kinematics of a tool constrained through a trocar; five axes (a, b, d, ψ, jaw).
class TrocarKinematics final : public Kinematics {
 public:
  static constexpr int kPivotX = 0;   ///< Index of a (rad).
  static constexpr int kPivotY = 1;   ///< Index of b (rad).
  static constexpr int kDepth = 2;    ///< Index of d (m).
  static constexpr int kRoll = 3;     ///< Index of ψ (rad).
  static constexpr int kJaw = 4;      ///< Index of the jaw opening (rad).
  static constexpr int kNumAxes = 5;  ///< Number of axes.

  static constexpr int kLinkTool = 0;    ///< Link "tool": the controlled frame.
  static constexpr int kLinkTrocar = 1;  ///< Link "trocar": the pivoting sleeve at p_c.
  static constexpr int kLinkTube = 2;    ///< Link "tube": the tool frame (tip).
  static constexpr int kLinkJaw1 = 3;    ///< Link "jaw_1": opened by +jaw/2 about the tube's x.
  static constexpr int kLinkJaw2 = 4;    ///< Link "jaw_2": opened by −jaw/2 about the tube's x.
  static constexpr int kNumLinks = 5;    ///< Number of links.

  /// `trocar`: trocar point and frame in world; `tool_offset`: pose of the controlled frame in
  /// the tool (tip) frame. Throws std::invalid_argument if a position is not finite or a
  /// quaternion is not unit length within 1e-6 (they are normalised otherwise).
  explicit TrocarKinematics(const TrocarGeometry& trocar, const core::Pose& tool_offset = {});

  /// Number of axes: 5.
  int num_axes() const noexcept override { return kNumAxes; }

  /// World pose of the controlled frame (tool frame · tool_offset).
  core::Pose forward(const AxisVector& q) const noexcept override;

  /// World pose of the tool frame (tip, z along the shaft), without tool_offset.
  core::Pose tool_pose(const AxisVector& q) const noexcept;

  /// 6 x 5 geometric Jacobian of the controlled frame, world frame. With s = R e_z the shaft
  /// direction and p the controlled origin:
  ///   ω_a = R_c e_x, ω_b = R_c Rx(a) e_y, ω_ψ = s, ω_d = ω_jaw = 0;
  ///   v_i = ω_i × (p − p_c) for a, b, ψ;  v_d = s;  v_jaw = 0.
  Jacobian jacobian(const AxisVector& q) const noexcept override;

  /// Number of links: 5 ("tool", "trocar", "tube", "jaw_1", "jaw_2"; see the file comment).
  int num_links() const noexcept override { return kNumLinks; }

  /// Name of link `link` (static string), "" out of range.
  const char* link_name(int link) const noexcept override;

  /// World pose of link `link` at q (see the file comment). An index out of [0, 5) gives
  /// link 0 (the controlled frame).
  core::Pose link_pose(int link, const AxisVector& q) const noexcept override;

  /// 6 x 5 geometric Jacobian of link `link` at q, world frame, linear rows at the link's
  /// origin o_l. With ω_a, ω_b, s as for jacobian() and x_t = R_s Rz(ψ) e_x the tube's x axis:
  ///   tool:   jacobian();
  ///   trocar: ω_a, ω_b in the a, b columns; v = 0 (its origin p_c is fixed); d, ψ, jaw: 0;
  ///   tube:   columns of jacobian() with o_l = tip: v_a,b = ω_a,b × (tip − p_c), v_d = s,
  ///           ω_ψ = s, v_ψ = 0; jaw: 0;
  ///   jaw_1 / jaw_2: the tube's columns, plus ω_jaw = ±½ x_t (v_jaw = 0: the hinge is the
  ///           origin). An index out of [0, 5) gives link 0's.
  /// Axis torques for wrenches w_l at the links' origins: τ = Σ_l J_lᵀ w_l.
  Jacobian link_jacobian(int link, const AxisVector& q) const noexcept override;

  /// Axes for a controlled-frame pose: the tool pose is pose · tool_offset⁻¹, then
  /// inverse_tool(); the jaw is q_free[kJaw] (0 if q_free is empty).
  AxisVector inverse(const core::Pose& pose, const AxisVector& q_free) const noexcept override;

  /// Axes for a recorded tool (tip) pose and jaw opening:
  ///   d = |tip − p_c|; shaft direction u = (tip − p_c)/d from the tip POSITION (the recorded
  ///   orientation may include a wrist); with u' = R_cᵀ u: b = asin(u'_x), a = atan2(−u'_y, u'_z);
  ///   ψ = twist about the shaft of R_sᵀ R_tool (swing–twist decomposition), with
  ///   R_s = R_c Rx(a) Ry(b).
  /// What is lost: the tool is rigid and constrained through the trocar, so only the tip
  /// position and the roll survive; any wrist bend (the swing of the recorded orientation
  /// away from the shaft) is discarded, and forward(inverse(pose)) has the recorded tip
  /// position but the orientation R_s Rz(ψ). At d < 1e-9 m the direction is taken from the
  /// recorded orientation's z axis. b is in [−π/2, π/2]; a and ψ in (−π, π].
  AxisVector inverse_tool(const core::Pose& tool, double jaw) const noexcept;

  /// The trocar geometry (quaternion normalised).
  const TrocarGeometry& trocar() const noexcept { return trocar_; }
  /// Pose of the controlled frame in the tool frame (quaternion normalised).
  const core::Pose& tool_offset() const noexcept { return tool_offset_; }

 private:
  // Jacobian of a frame fixed to the tube whose world origin is `origin` (a, b, d, ψ columns;
  // jaw column zero).
  Jacobian tube_fixed_jacobian(const AxisVector& q, const core::Vec3& origin) const noexcept;

  TrocarGeometry trocar_;
  core::Pose tool_offset_;
};

}  // namespace numen::hal
