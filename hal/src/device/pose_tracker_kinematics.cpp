/// @file pose_tracker_kinematics.cpp
/// 6-DOF pose tracker: position and intrinsic Z-Y-X Euler angles, R = Rz(yaw) Ry(pitch) Rx(roll).

#include "numen/hal/device/pose_tracker_kinematics.hpp"

#include <cmath>

#include "axis_rotation.hpp"
#include "geometry_check.hpp"
#include "numen/hal/device/axis.hpp"

namespace numen::hal {
namespace {

using core::Quat;
using core::Vec3;
using detail::axis_rotation;

}  // namespace

PoseTrackerKinematics::PoseTrackerKinematics(const PoseTrackerGeometry& geometry,
                                             const core::Pose& tool_offset) {
  geometry_.base.position =
      detail::checked_position(geometry.base.position, "tracker.base.position");
  geometry_.base.orientation =
      detail::checked_unit_quaternion(geometry.base.orientation, "tracker.base.orientation");
  tool_offset_.position = detail::checked_position(tool_offset.position, "tool_offset.position");
  tool_offset_.orientation =
      detail::checked_unit_quaternion(tool_offset.orientation, "tool_offset.orientation");
}

core::Pose PoseTrackerKinematics::forward(const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  const Quat local = axis_rotation(q[kYaw], Vec3::UnitZ()) *
                     axis_rotation(q[kPitch], Vec3::UnitY()) *
                     axis_rotation(q[kRoll], Vec3::UnitX());
  const Quat r_tool = geometry_.base.orientation * local;
  const Vec3 o = geometry_.base.position + geometry_.base.orientation * Vec3(q[kX], q[kY], q[kZ]);
  core::Pose out;
  out.position = o + r_tool * tool_offset_.position;
  out.orientation = (r_tool * tool_offset_.orientation).normalized();
  return out;
}

Jacobian PoseTrackerKinematics::jacobian(const AxisVector& q) const noexcept {
  eigen_assert(q.size() == kNumAxes);
  const Quat& rb = geometry_.base.orientation;
  const Quat r_yaw = rb * axis_rotation(q[kYaw], Vec3::UnitZ());
  const Quat r_yaw_pitch = r_yaw * axis_rotation(q[kPitch], Vec3::UnitY());
  const Quat r_tool = r_yaw_pitch * axis_rotation(q[kRoll], Vec3::UnitX());
  const Vec3 w_yaw = rb * Vec3::UnitZ();
  const Vec3 w_pitch = r_yaw * Vec3::UnitY();
  const Vec3 w_roll = r_yaw_pitch * Vec3::UnitX();
  const Vec3 r = r_tool * tool_offset_.position;  // controlled origin − tracked origin

  Jacobian j(6, kNumAxes);
  j.setZero();
  j.col(kX).head<3>() = rb * Vec3::UnitX();
  j.col(kY).head<3>() = rb * Vec3::UnitY();
  j.col(kZ).head<3>() = rb * Vec3::UnitZ();
  j.col(kYaw) << w_yaw.cross(r), w_yaw;
  j.col(kPitch) << w_pitch.cross(r), w_pitch;
  j.col(kRoll) << w_roll.cross(r), w_roll;
  return j;
}

AxisVector PoseTrackerKinematics::inverse(const core::Pose& pose,
                                          const AxisVector& /*q_free*/) const noexcept {
  const Quat r_tool = (pose.orientation * tool_offset_.orientation.conjugate()).normalized();
  const Vec3 o = pose.position - r_tool * tool_offset_.position;
  const Quat& rb = geometry_.base.orientation;
  const Vec3 o_local = rb.conjugate() * (o - geometry_.base.position);
  const core::Mat3 m = (rb.conjugate() * r_tool).toRotationMatrix();

  const double cos_pitch = std::hypot(m(0, 0), m(1, 0));
  double yaw = 0.0;
  double roll = 0.0;
  const double pitch = std::atan2(-m(2, 0), cos_pitch);
  if (cos_pitch > 1e-8) {  // balances the two branches' round-off (~1e-8 rad)
    yaw = std::atan2(m(1, 0), m(0, 0));
    roll = std::atan2(m(2, 1), m(2, 2));
  } else {  // gimbal lock: only yaw ∓ roll is defined; put it all in yaw
    yaw = std::atan2(-m(0, 1), m(1, 1));
  }
  AxisVector q(kNumAxes);
  q << o_local.x(), o_local.y(), o_local.z(), wrap_angle(yaw), pitch, wrap_angle(roll);
  return q;
}

}  // namespace numen::hal
