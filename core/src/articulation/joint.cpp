/// @file joint.cpp
/// Joint constraint rows C(q) and their velocity Jacobians G (paper §4.1,
/// Eq. 4–5). Derivations, with a body's perturbation x += ε v, R ← exp(ε ω) R:
/// a body-fixed point a moves at v + ω × (a − x), a body-fixed direction t at
/// ω × t.
///
/// Linear row C = t·d, t fixed on the parent, d = a_c − a_p:
///   Ċ = (ω_p × t)·d + t·(v_c + ω_c × r_c) − t·(v_p + ω_p × r_p)
///   ⇒ g_child = [tᵀ, (r_c × t)ᵀ],  g_parent = [−tᵀ, −((a_c − x_p) × t)ᵀ],
/// r_c = a_c − x_c, r_p = a_p − x_p (exact).
///
/// Trocar row C = t·e, t fixed on the child, e = a_p − a_c: the same with the
/// roles of the bodies swapped:
///   g_parent = [tᵀ, (r_p × t)ᵀ],  g_child = [−tᵀ, −((a_p − x_c) × t)ᵀ] (exact).
///
/// Angular rows (log, swing, twist): R_rel ← exp(ε R_pjᵀ(ω_c − ω_p)) R_rel to
/// first order, so row k has g_child = [0, t_kᵀ], g_parent = [0, −t_kᵀ] with
/// t_k the parent joint frame's world axis k; exact where C = 0.

#include "numen/core/joint.hpp"

#include <cmath>
#include <numbers>

#include "numen/core/data.hpp"
#include "numen/core/rigid_body.hpp"

namespace numen::core {

namespace {

/// World pose of both joint frames and the quantities every row needs.
struct JointFrames {
  Vec3 anchor_parent;  ///< a_p, m.
  Vec3 anchor_child;   ///< a_c, m.
  Vec3 com_parent;     ///< x_p (zero for the world: unused then), m.
  Vec3 com_child;      ///< x_c, m.
  Mat3 rot_parent;     ///< R_pj: columns x_pj, y_pj, z_pj.
  Mat3 rot_child;      ///< R_cj: columns x_cj, y_cj, z_cj.
  Quat relative;       ///< q_rel = q_pjᵀ q_cj (R_rel), not renormalised.
};

JointFrames joint_frames(const JointModel& joint, const BodyState* parent,
                         const BodyState& child) noexcept {
  JointFrames f;
  Quat q_pj;
  if (parent != nullptr) {
    q_pj = parent->orientation * joint.frame_parent.orientation;
    f.com_parent = parent->position;
    f.anchor_parent = parent->position + parent->orientation * joint.frame_parent.position;
  } else {
    q_pj = joint.frame_parent.orientation;
    f.com_parent = Vec3::Zero();
    f.anchor_parent = joint.frame_parent.position;
  }
  const Quat q_cj = child.orientation * joint.frame_child.orientation;
  f.com_child = child.position;
  f.anchor_child = child.position + child.orientation * joint.frame_child.position;
  f.rot_parent = q_pj.toRotationMatrix();
  f.rot_child = q_cj.toRotationMatrix();
  f.relative = q_pj.conjugate() * q_cj;
  return f;
}

/// Wraps an angle (rad) to (−π, π].
double wrap_angle(double a) noexcept {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  a = std::remainder(a, kTwoPi);  // [−π, π]
  if (a <= -std::numbers::pi) a += kTwoPi;
  return a;
}

/// Twist angle (rad, (−π, π]) of a relative rotation about its z axis:
/// swing–twist decomposition q = q_swing q_twist, q_twist ∝ (w, 0, 0, z).
/// Scale-invariant in q; 0 when the twist is undefined (a half-turn swing).
double twist_angle(const Quat& q) noexcept { return wrap_angle(2.0 * std::atan2(q.z(), q.w())); }

/// Linear row C = t·d (t parent-fixed, exact G).
void linear_row(const JointFrames& f, bool has_parent, const Vec3& t, double offset, int row,
                JointRows& rows) noexcept {
  const Vec3 d = f.anchor_child - f.anchor_parent;
  rows.position_error(row) = t.dot(d) - offset;
  rows.g_child.row(row).head<3>() = t.transpose();
  rows.g_child.row(row).tail<3>() = (f.anchor_child - f.com_child).cross(t).transpose();
  if (has_parent) {
    rows.g_parent.row(row).head<3>() = -t.transpose();
    rows.g_parent.row(row).tail<3>() = -(f.anchor_child - f.com_parent).cross(t).transpose();
  }
}

/// Trocar row C = t·(a_p − a_c) (t child-fixed, exact G).
void trocar_row(const JointFrames& f, bool has_parent, const Vec3& t, int row,
                JointRows& rows) noexcept {
  rows.position_error(row) = t.dot(f.anchor_parent - f.anchor_child);
  rows.g_child.row(row).head<3>() = -t.transpose();
  rows.g_child.row(row).tail<3>() = -(f.anchor_parent - f.com_child).cross(t).transpose();
  if (has_parent) {
    rows.g_parent.row(row).head<3>() = t.transpose();
    rows.g_parent.row(row).tail<3>() = (f.anchor_parent - f.com_parent).cross(t).transpose();
  }
}

/// Angular row with value `c` and axis t (parent joint frame axis, world).
void angular_row(bool has_parent, double c, const Vec3& t, int row, JointRows& rows) noexcept {
  rows.position_error(row) = c;
  rows.g_child.row(row).tail<3>() = t.transpose();
  if (has_parent) rows.g_parent.row(row).tail<3>() = -t.transpose();
}

/// 3 linear rows C = R_pjᵀ d starting at `row`.
void point_rows(const JointFrames& f, bool has_parent, int row, JointRows& rows) noexcept {
  for (int k = 0; k < 3; ++k) linear_row(f, has_parent, f.rot_parent.col(k), 0.0, row + k, rows);
}

/// 2 linear rows C = (x_pj, y_pj)·d starting at `row`.
void line_rows(const JointFrames& f, bool has_parent, int row, JointRows& rows) noexcept {
  for (int k = 0; k < 2; ++k) linear_row(f, has_parent, f.rot_parent.col(k), 0.0, row + k, rows);
}

/// 3 angular rows C = log(R_rel) (parent joint frame) starting at `row`.
void orientation_rows(const JointFrames& f, bool has_parent, int row, JointRows& rows) noexcept {
  const Vec3 c = quat_log(f.relative);
  for (int k = 0; k < 3; ++k) angular_row(has_parent, c(k), f.rot_parent.col(k), row + k, rows);
}

/// 2 swing rows C = (x_pj, y_pj)·(z_pj × z_cj) starting at `row`.
void swing_rows(const JointFrames& f, bool has_parent, int row, JointRows& rows) noexcept {
  const Vec3 n = f.rot_parent.col(2).cross(f.rot_child.col(2));
  for (int k = 0; k < 2; ++k) {
    const Vec3 t = f.rot_parent.col(k);
    angular_row(has_parent, t.dot(n), t, row + k, rows);
  }
}

}  // namespace

int joint_row_count(JointType type, bool prescribed) noexcept {
  if (prescribed && !joint_can_be_prescribed(type)) return 0;
  switch (type) {
    case JointType::kFixed:
      return 6;
    case JointType::kRevolute:
    case JointType::kPrismatic:
      return prescribed ? 6 : 5;
    case JointType::kCylindrical:
      return 4;
    case JointType::kSpherical:
      return 3;
    case JointType::kTrocar:
      return 2;
  }
  return 0;
}

bool joint_can_be_prescribed(JointType type) noexcept {
  return type == JointType::kRevolute || type == JointType::kPrismatic;
}

bool joint_row_is_angular(JointType type, int row) noexcept {
  if (row < 0 || row >= joint_row_count(type, joint_can_be_prescribed(type))) return false;
  switch (type) {
    case JointType::kFixed:
      return row >= 3;  // 3 linear, 3 log
    case JointType::kRevolute:
      return row >= 3;  // 3 linear, 2 swing, [twist]
    case JointType::kPrismatic:
      return row >= 2 && row < 5;  // 2 linear, 3 log, [slide]
    case JointType::kCylindrical:
      return row >= 2;  // 2 linear, 2 swing
    case JointType::kSpherical:
    case JointType::kTrocar:
      return false;
  }
  return false;
}

void evaluate_joint(const JointModel& joint, const BodyState* parent, const BodyState& child,
                    double prescribed_value, JointRows& rows) noexcept {
  rows.position_error.setZero();
  rows.g_child.setZero();
  rows.g_parent.setZero();
  rows.count = joint_row_count(joint.type, joint.prescribed);
  if (rows.count == 0) return;

  const JointFrames f = joint_frames(joint, parent, child);
  const bool has_parent = parent != nullptr;
  switch (joint.type) {
    case JointType::kFixed:
      point_rows(f, has_parent, 0, rows);
      orientation_rows(f, has_parent, 3, rows);
      break;
    case JointType::kRevolute:
      point_rows(f, has_parent, 0, rows);
      swing_rows(f, has_parent, 3, rows);
      if (joint.prescribed) {
        const double c = wrap_angle(twist_angle(f.relative) - prescribed_value);
        angular_row(has_parent, c, f.rot_parent.col(2), 5, rows);
      }
      break;
    case JointType::kPrismatic:
      line_rows(f, has_parent, 0, rows);
      orientation_rows(f, has_parent, 2, rows);
      if (joint.prescribed)
        linear_row(f, has_parent, f.rot_parent.col(2), prescribed_value, 5, rows);
      break;
    case JointType::kCylindrical:
      line_rows(f, has_parent, 0, rows);
      swing_rows(f, has_parent, 2, rows);
      break;
    case JointType::kSpherical:
      point_rows(f, has_parent, 0, rows);
      break;
    case JointType::kTrocar:
      for (int k = 0; k < 2; ++k) trocar_row(f, has_parent, f.rot_child.col(k), k, rows);
      break;
  }
}

double joint_coordinate(const JointModel& joint, const BodyState* parent,
                        const BodyState& child) noexcept {
  switch (joint.type) {
    case JointType::kRevolute:
    case JointType::kCylindrical:
      return twist_angle(joint_frames(joint, parent, child).relative);
    case JointType::kPrismatic: {
      const JointFrames f = joint_frames(joint, parent, child);
      return f.rot_parent.col(2).dot(f.anchor_child - f.anchor_parent);
    }
    case JointType::kFixed:
    case JointType::kSpherical:
    case JointType::kTrocar:
      break;
  }
  return 0.0;
}

double joint_slide(const JointModel& joint, const BodyState* parent,
                   const BodyState& child) noexcept {
  switch (joint.type) {
    case JointType::kCylindrical: {
      const JointFrames f = joint_frames(joint, parent, child);
      return f.rot_parent.col(2).dot(f.anchor_child - f.anchor_parent);
    }
    case JointType::kTrocar: {
      const JointFrames f = joint_frames(joint, parent, child);
      return f.rot_child.col(2).dot(f.anchor_parent - f.anchor_child);
    }
    case JointType::kFixed:
    case JointType::kRevolute:
    case JointType::kPrismatic:
    case JointType::kSpherical:
      break;
  }
  return 0.0;
}

const char* to_string(JointType type) noexcept {
  switch (type) {
    case JointType::kFixed:
      return "fixed";
    case JointType::kRevolute:
      return "revolute";
    case JointType::kPrismatic:
      return "prismatic";
    case JointType::kCylindrical:
      return "cylindrical";
    case JointType::kSpherical:
      return "spherical";
    case JointType::kTrocar:
      return "trocar";
  }
  return "unknown";
}

}  // namespace numen::core
