#pragma once
/// @file geometry_check.hpp
/// Internal (not installed): load-time checks of positions and quaternions given by a scene.

#include <cmath>
#include <stdexcept>
#include <string>

#include "numen/core/types.hpp"

namespace numen::hal::detail {

/// Throws std::invalid_argument "<field> must be finite" if any coordinate is NaN/inf.
inline core::Vec3 checked_position(const core::Vec3& p, const std::string& field) {
  if (!p.allFinite()) throw std::invalid_argument(field + " must be finite");
  return p;
}

/// Throws std::invalid_argument unless q is finite with |‖q‖ − 1| <= 1e-6; returns q normalised.
inline core::Quat checked_unit_quaternion(const core::Quat& q, const std::string& field) {
  const double n = q.coeffs().norm();
  if (!q.coeffs().allFinite() || std::abs(n - 1.0) > 1e-6) {
    throw std::invalid_argument(field + " must be a unit quaternion (norm " + std::to_string(n) +
                                ")");
  }
  return q.normalized();
}

}  // namespace numen::hal::detail
