#pragma once
/// @file kinematics_check.hpp
/// Test helpers for numen::hal::Kinematics (header only): link Jacobians by central finite
/// differences of link_pose(), rotation vectors, the axis torques τ = Σ_l J_lᵀ w_l and the
/// virtual work Σ_l w_l · δx_l of a finite displacement. Used by the kinematics suites.

#include <cmath>
#include <span>

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/transport/splitmix64.hpp"

namespace numen::test {

/// Rotation vector (unit axis · angle, rad, angle in [0, π]) of a unit quaternion: log(q).
inline core::Vec3 rotation_vector(const core::Quat& q) {
  core::Quat p = q.normalized();
  if (p.w() < 0) p.coeffs() = -p.coeffs();  // q and −q: the same rotation, pick angle <= π
  const double s = p.vec().norm();
  if (s < 1e-300) return 2.0 * p.vec();
  return (2.0 * std::atan2(s, p.w()) / s) * p.vec();
}

/// Displacement of a frame from pose `a` to pose `b`, world frame: [b.p − a.p; log(R_b R_aᵀ)]
/// (m; rad).
inline core::Vec6 pose_difference(const core::Pose& a, const core::Pose& b) {
  core::Vec6 d;
  d << b.position - a.position, rotation_vector(b.orientation * a.orientation.conjugate());
  return d;
}

/// 6 x n Jacobian of link `link` by central differences of link_pose (step h on each axis):
/// column i = pose_difference(pose(q − h e_i), pose(q + h e_i)) / 2h.
inline hal::Jacobian numeric_link_jacobian(const hal::Kinematics& k, int link,
                                           const hal::AxisVector& q, double h = 1e-6) {
  hal::Jacobian j(6, q.size());
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    hal::AxisVector qp = q;
    hal::AxisVector qm = q;
    qp[i] += h;
    qm[i] -= h;
    j.col(i) = pose_difference(k.link_pose(link, qm), k.link_pose(link, qp)) / (2.0 * h);
  }
  return j;
}

/// Axis torques τ = Σ_l J_lᵀ [force_l; torque_l] (wrenches at the links' origins, world).
inline hal::AxisVector link_torques(const hal::Kinematics& k, const hal::AxisVector& q,
                                    std::span<const core::Wrench> w) {
  hal::AxisVector tau = hal::AxisVector::Zero(q.size());
  for (std::size_t l = 0; l < w.size(); ++l) {
    tau += hal::torques_from_wrench(k.link_jacobian(static_cast<int>(l), q), w[l]);
  }
  return tau;
}

/// Work of the link wrenches over the finite displacement q → q + dq, from forward
/// kinematics only: Σ_l [force_l; torque_l] · pose_difference(link_pose(l, q),
/// link_pose(l, q + dq)).
inline double link_virtual_work(const hal::Kinematics& k, const hal::AxisVector& q,
                                const hal::AxisVector& dq, std::span<const core::Wrench> w) {
  double work = 0.0;
  for (std::size_t l = 0; l < w.size(); ++l) {
    const int link = static_cast<int>(l);
    const core::Vec6 dx = pose_difference(k.link_pose(link, q), k.link_pose(link, q + dq));
    work += w[l].force.dot(dx.head<3>()) + w[l].torque.dot(dx.tail<3>());
  }
  return work;
}

/// Uniform double in [lo, hi) from `rng`.
inline double uniform(hal::SplitMix64& rng, double lo, double hi) {
  return lo + (hi - lo) * rng.uniform();
}

/// A wrench with every component uniform in [−scale, scale) (N; N·m).
inline core::Wrench random_wrench(hal::SplitMix64& rng, double scale = 1.0) {
  core::Wrench w;
  w.force = core::Vec3(uniform(rng, -scale, scale), uniform(rng, -scale, scale),
                       uniform(rng, -scale, scale));
  w.torque = core::Vec3(uniform(rng, -scale, scale), uniform(rng, -scale, scale),
                        uniform(rng, -scale, scale));
  return w;
}

}  // namespace numen::test
