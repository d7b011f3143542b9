#pragma once
/// @file joint.hpp
/// Joints of an articulated god-object (paper §4.1, Eq. 4–5): the catalogue,
/// and the constraint function C(q) of each joint with its velocity Jacobian
///   Ċ = G_child u_child + G_parent u_parent − v_ref,
/// u = (v, ω) the world twist of a body at its COM (BodyState). Used by the
/// articulation solve (articulation.hpp).
///
/// Frames. A joint has a frame on its parent (`frame_parent`, in the parent's
/// COM frame, or in the world when parent = -1) and a frame on its child
/// (`frame_child`, in the child's COM frame). The joint axis is the z axis of
/// these frames. At joint coordinate zero the two frames coincide in the world.
/// Notation below: a_p, a_c the frames' world origins (anchors); R_pj, R_cj
/// their world orientations; d = a_c − a_p; R_rel = R_pjᵀ R_cj;
/// x_pj, y_pj, z_pj the parent frame's world axes.
///
/// Constraint rows by type (rows in this order):
///   fixed        3 linear  C = R_pjᵀ d;            3 angular C = log(R_rel) (parent joint frame)
///   revolute     3 linear  C = R_pjᵀ d;            2 swing   C = (x_pj, y_pj) · (z_pj × z_cj)
///                [prescribed: 1 twist  C = φ − φ*,  φ = twist angle of R_rel about z]
///   prismatic    2 linear  C = (x_pj, y_pj) · d;   3 angular C = log(R_rel)
///                [prescribed: 1 slide  C = z_pj · d − s*]
///   cylindrical  2 linear  C = (x_pj, y_pj) · d;   2 swing   (slides along and rolls about z)
///   spherical    3 linear  C = R_pjᵀ d
///   trocar       2 rows    C = (x_cj, y_cj) · (a_p − a_c): the child's z axis line
///                (through a_c) passes through the fixed point a_p — the remote
///                centre of motion of laparoscopy. The child keeps pivoting
///                (2 rotations), sliding along and rolling about its axis.
/// Swing rows equal the x, y components of log(R_rel) to first order; the
/// prescribed twist row is wrapped to (−π, π]. Angular rows have
/// G = ±[0, t_kᵀ] (t_k = x_pj, y_pj, z_pj: + child, − parent).
/// Linear rows are in m, angular rows in rad. G is exact at the evaluation
/// configuration for linear rows, and for angular rows equals ∂C/∂q to first
/// order in C (exact when C = 0), which is what Baumgarte stabilisation needs.

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "numen/core/types.hpp"

namespace numen::core {

struct BodyState;

/// Joint types of the catalogue (see file comment for their rows).
enum class JointType : std::uint8_t {
  kFixed,        ///< 0 DOF: welds the child to the parent.
  kRevolute,     ///< 1 DOF: rotation about z.
  kPrismatic,    ///< 1 DOF: translation along z.
  kCylindrical,  ///< 2 DOF: translation along and rotation about z.
  kSpherical,    ///< 3 DOF: rotation about the anchor (ball joint).
  kTrocar,       ///< 4 DOF: the child's z axis passes through the parent's anchor (RCM).
};

/// Most constraint rows of one joint (a fixed joint, or a prescribed revolute).
inline constexpr int kMaxJointRows = 6;

/// Row-major storage of up to kMaxJointRows constraint rows against one body's
/// twist (6 columns: linear then angular). Rows [0, JointRows::count) are valid;
/// the others are zero.
using JointJacobian = Eigen::Matrix<double, kMaxJointRows, 6, Eigen::RowMajor>;
/// Up to kMaxJointRows per-row values (m or rad, m/s or rad/s, N or N·m).
using JointVector = Eigen::Matrix<double, kMaxJointRows, 1>;

/// A joint between a parent body (or the world) and a child body.
struct JointModel {
  std::string name;
  JointType type = JointType::kRevolute;
  int parent = -1;    ///< Parent body index; -1: the world.
  int child = 0;      ///< Child body index (≠ parent).
  Pose frame_parent;  ///< Joint frame in the parent's COM frame (world frame if parent = -1). m.
  Pose frame_child;   ///< Joint frame in the child's COM frame. m.
  /// The joint's coordinate (revolute: angle φ, rad; prismatic: slide s, m) is
  /// imposed from Data::joint_prescribed instead of simulated (the paper
  /// imposes the jaw opening). Only revolute and prismatic joints.
  bool prescribed = false;
  int num_rows = 0;   ///< Derived by finalize_model(): joint_row_count(type, prescribed).
};

/// Number of constraint rows of a joint type (see file comment); 0 for a
/// prescribed flag on a type that cannot be prescribed.
int joint_row_count(JointType type, bool prescribed) noexcept;

/// True for the types whose coordinate can be prescribed (revolute, prismatic).
bool joint_can_be_prescribed(JointType type) noexcept;

/// True if row `row` (0-based, < joint_row_count()) of a joint of this type is
/// angular (rad), false if linear (m). Trocar rows are linear; row 5 (the
/// prescribed row) is angular for a revolute, linear for a prismatic. Rows out
/// of range (< 0, or ≥ joint_row_count(type, joint_can_be_prescribed(type))) give false.
bool joint_row_is_angular(JointType type, int row) noexcept;

/// Constraint rows of one joint at one configuration.
struct JointRows {
  int count = 0;                              ///< Rows in use (JointModel::num_rows).
  JointVector position_error = JointVector::Zero();  ///< C(q), m or rad.
  JointJacobian g_child = JointJacobian::Zero();     ///< ∂Ċ/∂u_child.
  JointJacobian g_parent = JointJacobian::Zero();    ///< ∂Ċ/∂u_parent; zero for the world.
};

/// Evaluates C and G of `joint` for the parent state `parent` (nullptr: the
/// world) and the child state `child`. `prescribed_value` is φ* (rad) or s*
/// (m) for a prescribed joint, ignored otherwise. Rows in the order of the
/// file comment. Velocities of the states are not read.
void evaluate_joint(const JointModel& joint, const BodyState* parent, const BodyState& child,
                    double prescribed_value, JointRows& rows) noexcept;

/// The joint's natural coordinate at a configuration, for observation and
/// prescription: revolute and cylindrical: twist angle φ of R_rel about z (rad,
/// (−π, π]); prismatic: slide z_pj · d (m); others: 0.
double joint_coordinate(const JointModel& joint, const BodyState* parent,
                        const BodyState& child) noexcept;

/// Slide of a cylindrical or trocar joint (m); 0 for other types.
/// Cylindrical: z_pj · d. Trocar: z_cj · (a_p − a_c), the signed distance
/// along the child's axis from a_c to the foot of a_p, i.e. the insertion
/// depth (positive when a_p lies ahead of a_c along +z_cj; the parent frame's
/// orientation plays no part).
double joint_slide(const JointModel& joint, const BodyState* parent,
                   const BodyState& child) noexcept;

/// Name of a joint type as used in scene files: "fixed", "revolute",
/// "prismatic", "cylindrical", "spherical", "trocar".
const char* to_string(JointType type) noexcept;

}  // namespace numen::core
