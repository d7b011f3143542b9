/// @file kinematics.cpp
/// Jacobian mappings shared by every Kinematics: twist = J q̇, τ = Jᵀ w; link lookup by name.

#include "numen/hal/device/kinematics.hpp"

#include <cstring>

namespace numen::hal {

int Kinematics::find_link(const char* name) const noexcept {
  if (name == nullptr) return -1;
  const int n = num_links();
  for (int l = 0; l < n; ++l) {
    const char* candidate = link_name(l);
    if (candidate != nullptr && std::strcmp(candidate, name) == 0) return l;
  }
  return -1;
}

core::Twist twist_from_rates(const Jacobian& jacobian, const AxisVector& qdot) noexcept {
  eigen_assert(qdot.size() == jacobian.cols());
  core::Vec6 v = core::Vec6::Zero();
  for (Eigen::Index i = 0; i < jacobian.cols(); ++i) v += jacobian.col(i) * qdot[i];
  core::Twist t;
  t.linear = v.head<3>();
  t.angular = v.tail<3>();
  return t;
}

AxisVector torques_from_wrench(const Jacobian& jacobian, const core::Wrench& wrench) noexcept {
  core::Vec6 w;
  w << wrench.force, wrench.torque;
  AxisVector tau(jacobian.cols());
  for (Eigen::Index i = 0; i < jacobian.cols(); ++i) tau[i] = jacobian.col(i).dot(w);
  return tau;
}

}  // namespace numen::hal
