/// @file kinematics.cpp
/// Jacobian mappings shared by every Kinematics: twist = J q̇, τ = Jᵀ w.

#include "numen/hal/kinematics.hpp"

namespace numen::hal {

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
