/// @file trocar_kinematics.cpp
/// Laparoscopic tool through a trocar: R = R_c Rx(a) Ry(b) Rz(ψ), tip = p_c + d R e_z.

#include "numen/hal/device/trocar_kinematics.hpp"

#include <algorithm>
#include <cmath>

#include "axis_rotation.hpp"
#include "geometry_check.hpp"
#include "numen/hal/device/axis.hpp"

namespace numen::hal {
namespace {

using core::Quat;
using core::Vec3;
using detail::axis_rotation;

constexpr const char* kTrocarLinkNames[TrocarKinematics::kNumLinks] = {"tool", "trocar", "tube",
                                                                       "jaw_1", "jaw_2"};

// +1 for jaw_1, −1 for jaw_2: each jaw turns by ±jaw/2 about the tube's x axis.
double jaw_sign(int link) noexcept { return link == TrocarKinematics::kLinkJaw1 ? 1.0 : -1.0; }

}  // namespace

TrocarKinematics::TrocarKinematics(const TrocarGeometry& trocar, const core::Pose& tool_offset) {
  trocar_.point = detail::checked_position(trocar.point, "trocar.point");
  trocar_.orientation = detail::checked_unit_quaternion(trocar.orientation, "trocar.orientation");
  tool_offset_.position = detail::checked_position(tool_offset.position, "tool_offset.position");
  tool_offset_.orientation =
      detail::checked_unit_quaternion(tool_offset.orientation, "tool_offset.orientation");
}

core::Pose TrocarKinematics::tool_pose(const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  const Quat swing = trocar_.orientation * axis_rotation(q[kPivotX], Vec3::UnitX()) *
                     axis_rotation(q[kPivotY], Vec3::UnitY());
  core::Pose tool;
  tool.orientation = (swing * axis_rotation(q[kRoll], Vec3::UnitZ())).normalized();
  tool.position = trocar_.point + q[kDepth] * (swing * Vec3::UnitZ());
  return tool;
}

core::Pose TrocarKinematics::forward(const AxisVector& q) const noexcept {
  const core::Pose tool = tool_pose(q);
  core::Pose out;
  out.position = tool.position + tool.orientation * tool_offset_.position;
  out.orientation = (tool.orientation * tool_offset_.orientation).normalized();
  return out;
}

Jacobian TrocarKinematics::tube_fixed_jacobian(const AxisVector& q,
                                               const Vec3& origin) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  const Quat rc_a = trocar_.orientation * axis_rotation(q[kPivotX], Vec3::UnitX());
  const Quat swing = rc_a * axis_rotation(q[kPivotY], Vec3::UnitY());
  const Vec3 w_a = trocar_.orientation * Vec3::UnitX();
  const Vec3 w_b = rc_a * Vec3::UnitY();
  const Vec3 s = swing * Vec3::UnitZ();
  const Vec3 r = origin - trocar_.point;  // frame origin from the trocar

  Jacobian j(6, kNumAxes);
  j.setZero();
  j.col(kPivotX) << w_a.cross(r), w_a;
  j.col(kPivotY) << w_b.cross(r), w_b;
  j.col(kDepth) << s, Vec3::Zero();
  j.col(kRoll) << s.cross(r), s;
  // kJaw: zero column, the rigid tube ignores the jaw.
  return j;
}

Jacobian TrocarKinematics::jacobian(const AxisVector& q) const noexcept {
  return tube_fixed_jacobian(q, forward(q).position);
}

const char* TrocarKinematics::link_name(int link) const noexcept {
  return (link >= 0 && link < kNumLinks) ? kTrocarLinkNames[link] : "";
}

core::Pose TrocarKinematics::link_pose(int link, const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  switch (link) {
    case kLinkTrocar: {
      core::Pose sleeve;
      sleeve.position = trocar_.point;
      sleeve.orientation = (trocar_.orientation * axis_rotation(q[kPivotX], Vec3::UnitX()) *
                            axis_rotation(q[kPivotY], Vec3::UnitY()))
                               .normalized();
      return sleeve;
    }
    case kLinkTube:
      return tool_pose(q);
    case kLinkJaw1:
    case kLinkJaw2: {
      core::Pose jaw = tool_pose(q);
      jaw.orientation =
          (jaw.orientation * axis_rotation(0.5 * jaw_sign(link) * q[kJaw], Vec3::UnitX()))
              .normalized();
      return jaw;
    }
    default:
      return forward(q);
  }
}

Jacobian TrocarKinematics::link_jacobian(int link, const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  switch (link) {
    case kLinkTrocar: {
      // The sleeve pivots about p_c (fixed origin); depth, roll and jaw do not move it.
      const Quat rc_a = trocar_.orientation * axis_rotation(q[kPivotX], Vec3::UnitX());
      Jacobian j(6, kNumAxes);
      j.setZero();
      j.col(kPivotX).tail<3>() = trocar_.orientation * Vec3::UnitX();
      j.col(kPivotY).tail<3>() = rc_a * Vec3::UnitY();
      return j;
    }
    case kLinkTube:
      return tube_fixed_jacobian(q, tool_pose(q).position);
    case kLinkJaw1:
    case kLinkJaw2: {
      const core::Pose tube = tool_pose(q);
      Jacobian j = tube_fixed_jacobian(q, tube.position);
      j.col(kJaw).tail<3>() = (0.5 * jaw_sign(link)) * (tube.orientation * Vec3::UnitX());
      return j;
    }
    default:
      return jacobian(q);
  }
}

AxisVector TrocarKinematics::inverse_tool(const core::Pose& tool, double jaw) const noexcept {
  const Vec3 r = tool.position - trocar_.point;
  const double d = r.norm();
  const Vec3 u = d > 1e-9 ? Vec3(r / d) : Vec3(tool.orientation * Vec3::UnitZ());
  const Vec3 uc = trocar_.orientation.conjugate() * u;  // direction in the trocar frame
  const double b = std::asin(std::clamp(uc.x(), -1.0, 1.0));
  const double a = std::atan2(-uc.y(), uc.z());

  // Swing–twist: the twist of R_sᵀ R_tool about z is the roll.
  const Quat swing =
      trocar_.orientation * axis_rotation(a, Vec3::UnitX()) * axis_rotation(b, Vec3::UnitY());
  const Quat rel = swing.conjugate() * tool.orientation;
  double psi = 0.0;
  if (std::abs(rel.w()) + std::abs(rel.z()) > 1e-12) {
    psi = wrap_angle(2.0 * std::atan2(rel.z(), rel.w()));
  }

  AxisVector q(kNumAxes);
  q[kPivotX] = wrap_angle(a);
  q[kPivotY] = b;
  q[kDepth] = d;
  q[kRoll] = psi;
  q[kJaw] = jaw;
  return q;
}

AxisVector TrocarKinematics::inverse(const core::Pose& pose,
                                     const AxisVector& q_free) const noexcept {
  // Tool pose = controlled pose · tool_offset⁻¹.
  core::Pose tool;
  tool.orientation = (pose.orientation * tool_offset_.orientation.conjugate()).normalized();
  tool.position = pose.position - tool.orientation * tool_offset_.position;
  const double jaw = q_free.size() > kJaw ? q_free[kJaw] : 0.0;
  return inverse_tool(tool, jaw);
}

}  // namespace numen::hal
