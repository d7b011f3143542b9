#pragma once
/// @file rotation.hpp
/// Rotations for test poses: the unit quaternion of a rotation by `angle` (rad) about `axis` (any
/// non-zero length: it is normalised), and the angle between two orientations. Header-only; needs Eigen only.

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "numen/core/types.hpp"

namespace numen::test {

/// Rotation by `angle` rad about `axis` (normalised here).
inline core::Quat rot(double angle, const core::Vec3& axis) {
  return core::Quat(Eigen::AngleAxisd(angle, axis.normalized()));
}

/// The angle (rad, in [0, π]) of the rotation from `a` to `b` (neither needs unit length).
inline double angle_between(const core::Quat& a, const core::Quat& b) {
  return 2.0 * std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized()))));
}

}  // namespace numen::test
