/// @file kinematics.cpp
/// Jacobian mappings shared by every Kinematics: twist = J q̇, τ = Jᵀ w; link lookup by name.

#include "numen/hal/device/kinematics.hpp"

#include <algorithm>

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

void torques_from_link_wrenches(std::span<const Jacobian> jacobians,
                                std::span<const core::Wrench> wrenches, AxisVector& tau) noexcept {
  if (!jacobians.empty()) tau.resize(jacobians[0].cols());
  tau.setZero();
  const std::size_t used = std::min(jacobians.size(), wrenches.size());
  for (std::size_t l = 0; l < used; ++l) tau += torques_from_wrench(jacobians[l], wrenches[l]);
}

bool all_finite(std::span<const core::Wrench> wrenches) noexcept {
  bool finite = true;
  for (const core::Wrench& w : wrenches) finite = finite && w.force.allFinite() && w.torque.allFinite();
  return finite;
}

}  // namespace numen::hal
