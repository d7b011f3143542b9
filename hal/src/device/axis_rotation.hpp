#pragma once
/// @file axis_rotation.hpp
/// The rotation of a revolute axis, for the kinematics of hal/src/device (private header).

#include <Eigen/Geometry>

#include "numen/core/types.hpp"

namespace numen::hal::detail {

/// Rotation by `angle` (rad, right-handed) about the unit vector `axis` (the frame it is
/// expressed in is the caller's): the quaternion of Eigen::AngleAxisd. No checks: `axis` must be
/// a unit vector, and a non-finite angle gives a non-finite quaternion.
inline core::Quat axis_rotation(double angle, const core::Vec3& axis) noexcept {
  return core::Quat(Eigen::AngleAxisd(angle, axis));
}

}  // namespace numen::hal::detail
