#pragma once
/// @file kinematics_check.hpp
/// Test helpers for numen::hal::Kinematics (header only): Jacobians by central finite
/// differences of forward() and link_pose(), rotation vectors, the axis torques τ = Σ_l J_lᵀ w_l
/// and the virtual work Σ_l w_l · δx_l of a finite displacement, and the checks every mechanism's
/// suite makes with them (Jacobians against central differences, τ = Jᵀ w by virtual work, the
/// link names and link 0). Used by the kinematics suites (trocar, PHANTOM, pose tracker).

#include <gtest/gtest.h>

#include <cmath>
#include <span>
#include <string>
#include <vector>

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

/// 6 x n Jacobian of the frame `pose_of(q)` (a core::Pose) by central differences (step h on
/// each axis): column i = pose_difference(pose_of(q − h e_i), pose_of(q + h e_i)) / 2h.
template <class PoseOf>
hal::Jacobian central_differences(const hal::AxisVector& q, double h, const PoseOf& pose_of) {
  hal::Jacobian j(6, q.size());
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    hal::AxisVector qp = q;
    hal::AxisVector qm = q;
    qp[i] += h;
    qm[i] -= h;
    j.col(i) = pose_difference(pose_of(qm), pose_of(qp)) / (2.0 * h);
  }
  return j;
}

/// 6 x n Jacobian of link `link` by central differences of link_pose() (central_differences()).
inline hal::Jacobian numeric_link_jacobian(const hal::Kinematics& k, int link,
                                           const hal::AxisVector& q, double h = 1e-6) {
  return central_differences(q, h, [&](const hal::AxisVector& x) { return k.link_pose(link, x); });
}

/// 6 x n Jacobian of the controlled frame by central differences of forward().
inline hal::Jacobian numeric_jacobian(const hal::Kinematics& k, const hal::AxisVector& q,
                                      double h = 1e-6) {
  return central_differences(q, h, [&](const hal::AxisVector& x) { return k.forward(x); });
}

/// Expects `controlled` to be `frame` followed by the tool offset `offset` (given in `frame`):
/// position frame.p + R_frame offset.p, orientation R_frame R_offset, to 1e-12.
inline void expect_offset_applied(const core::Pose& frame, const core::Pose& offset,
                                  const core::Pose& controlled) {
  EXPECT_TRUE(
      controlled.position.isApprox(frame.position + frame.orientation * offset.position, 1e-12));
  EXPECT_LT(controlled.orientation.angularDistance(frame.orientation * offset.orientation), 1e-12);
}

/// Expects |column c of `j` − column c of `fd`| < tol for every column (`what` names the frame in
/// a failure, with both columns).
inline void expect_columns_near(const hal::Jacobian& j, const hal::Jacobian& fd, double tol,
                                const std::string& what) {
  ASSERT_EQ(j.rows(), 6) << what;
  ASSERT_EQ(j.cols(), fd.cols()) << what;
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    EXPECT_LT((j.col(c) - fd.col(c)).norm(), tol) << what << " column " << c << "\n"
                                                  << j.col(c).transpose() << "\n"
                                                  << fd.col(c).transpose();
  }
}

/// Expects jacobian(q) to match central differences of forward() column by column (tol: norm of
/// a column's difference, 1/s or m/s per axis unit).
inline void expect_jacobian_matches_central_differences(const hal::Kinematics& k,
                                                        const hal::AxisVector& q, double tol) {
  expect_columns_near(k.jacobian(q), numeric_jacobian(k, q), tol, "controlled frame");
}

/// Expects every link's link_jacobian(q) to match central differences of its link_pose().
inline void expect_link_jacobians_match_central_differences(const hal::Kinematics& k,
                                                            const hal::AxisVector& q, double tol) {
  for (int l = 0; l < k.num_links(); ++l)
    expect_columns_near(k.link_jacobian(l, q), numeric_link_jacobian(k, l, q), tol,
                        std::string("link ") + k.link_name(l));
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

/// Expects the virtual-work identity of the controlled frame for the wrench `w` (N, N·m, world,
/// at its origin) and the small displacement dq: w · δx (δx from forward() alone) == τ · dq with
/// τ = Jᵀ w, within `tol` (J). Returns τ.
inline hal::AxisVector expect_virtual_work(const hal::Kinematics& k, const hal::AxisVector& q,
                                           const core::Wrench& w, const hal::AxisVector& dq,
                                           double tol) {
  const hal::AxisVector tau = hal::torques_from_wrench(k.jacobian(q), w);
  const core::Vec6 dx = pose_difference(k.forward(q), k.forward(q + dq));
  EXPECT_NEAR(w.force.dot(dx.head<3>()) + w.torque.dot(dx.tail<3>()), tau.dot(dq), tol);
  return tau;
}

/// The link names in order: link_name(l) and find_link() agree with `names`; past the last link
/// and before the first the name is "", and "" or nullptr finds no link.
inline void expect_link_names(const hal::Kinematics& k, std::span<const char* const> names) {
  ASSERT_EQ(k.num_links(), static_cast<int>(names.size()));
  for (int l = 0; l < k.num_links(); ++l) {
    EXPECT_STREQ(k.link_name(l), names[static_cast<std::size_t>(l)]);
    EXPECT_EQ(k.find_link(names[static_cast<std::size_t>(l)]), l);
  }
  EXPECT_STREQ(k.link_name(k.num_links()), "");
  EXPECT_STREQ(k.link_name(-1), "");
  EXPECT_EQ(k.find_link(""), -1);
  EXPECT_EQ(k.find_link(nullptr), -1);
}

/// Link 0 is the controlled frame at q: its pose is forward(q) and its Jacobian jacobian(q),
/// bit for bit; a link index out of range gives link 0.
inline void expect_link_zero_is_the_controlled_frame(const hal::Kinematics& k,
                                                     const hal::AxisVector& q) {
  const core::Pose f = k.forward(q);
  const core::Pose l0 = k.link_pose(0, q);
  EXPECT_EQ(l0.position, f.position);
  EXPECT_EQ(l0.orientation.coeffs(), f.orientation.coeffs());
  EXPECT_EQ(k.link_jacobian(0, q), k.jacobian(q));
  EXPECT_EQ(k.link_pose(k.num_links() + 2, q).position, f.position);
  EXPECT_EQ(k.link_pose(-3, q).position, f.position);
}

/// Σ over the links of link_pose(l, q).position.x() + link_jacobian(l, q).sum(): every link call
/// once, for the allocation tests (the sum keeps the calls from being optimised away).
inline double link_calls_sum(const hal::Kinematics& k, const hal::AxisVector& q) {
  double sum = 0.0;
  for (int l = 0; l < k.num_links(); ++l)
    sum += k.link_pose(l, q).position.x() + k.link_jacobian(l, q).sum();
  return sum;
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

/// One trial of the virtual-work identity over the links: a wrench on every link and a small
/// displacement dq drawn from the rng, the torques τ = Σ_l J_lᵀ w_l and the work of the wrenches.
struct LinkWorkTrial {
  std::vector<core::Wrench> w;  ///< Per link (N, N·m, world, at the link's origin).
  hal::AxisVector dq;           ///< Each axis uniform in [−1e-5, 1e-5).
  hal::AxisVector tau;          ///< link_torques(k, q, w).
  double work = 0.0;            ///< link_virtual_work(k, q, dq, w) (J).
};

/// Draws a LinkWorkTrial at q (wrench components uniform in [−scale, scale)) and expects
/// work == τ · dq to O(|dq|²) (10 |dq|²). Allocates (the wrenches): not for allocation tests.
inline LinkWorkTrial expect_link_virtual_work(const hal::Kinematics& k, const hal::AxisVector& q,
                                              hal::SplitMix64& rng, double scale) {
  LinkWorkTrial t;
  t.w.resize(static_cast<std::size_t>(k.num_links()));
  for (core::Wrench& x : t.w) x = random_wrench(rng, scale);
  t.dq.resize(q.size());
  for (Eigen::Index i = 0; i < q.size(); ++i) t.dq[i] = uniform(rng, -1e-5, 1e-5);
  t.tau = link_torques(k, q, t.w);
  t.work = link_virtual_work(k, q, t.dq, t.w);
  EXPECT_NEAR(t.work, t.tau.dot(t.dq), 10.0 * t.dq.squaredNorm());
  return t;
}

}  // namespace numen::test
