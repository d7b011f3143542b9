#pragma once
/// @file kinematics.hpp
/// Kinematics: the map between an instrument's axis values q and the pose of its controlled
/// frame in the world (forward, inverse) and its geometric Jacobian: encoder values <-> target
/// poses, wrenches <-> axis torques (docs/architecture.md, the period's walk). Fixed capacity
/// kMaxAxes, no heap: vectors and Jacobians are Eigen matrices with a compile-time maximum
/// size, so every call is allocation free.

#include <Eigen/Core>

#include <span>

#include "numen/core/types.hpp"

namespace numen::hal {

/// Most axes an instrument may have.
inline constexpr int kMaxAxes = 8;

/// Most links (frames with their own target: the parts of an articulated instrument) an
/// instrument may have (paper Eq. 6: one coupling spring per body of the articulated tool).
inline constexpr int kMaxLinks = 8;

/// Axis values (m or rad), rates (m/s, rad/s) or torques (N, N·m): n x 1, n <= kMaxAxes,
/// inline storage.
using AxisVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxAxes, 1>;

/// Geometric Jacobian, 6 x n (n <= kMaxAxes), inline storage. Rows 0–2: linear velocity of
/// the controlled frame's origin (m/s per unit rate); rows 3–5: angular velocity (rad/s per
/// unit rate); world coordinates. Twist = J q̇; axis torques τ = Jᵀ [force; torque] for a
/// wrench applied at the controlled frame's origin (virtual work).
using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxAxes>;

/// Kinematic model of an instrument. Implementations are immutable after construction and
/// every member is noexcept and allocation free. Preconditions (checked by eigen_assert in
/// debug builds): argument vectors have num_axes() entries.
class Kinematics {
 public:
  virtual ~Kinematics() = default;

  /// Number of axes n (1..kMaxAxes).
  virtual int num_axes() const noexcept = 0;

  /// World pose of the controlled frame at axis values q (n x 1).
  virtual core::Pose forward(const AxisVector& q) const noexcept = 0;

  /// Geometric Jacobian (6 x n) of the controlled frame at q; see Jacobian.
  virtual Jacobian jacobian(const AxisVector& q) const noexcept = 0;

  /// Axis values that place the controlled frame at (or, for a constrained instrument, as
  /// close as the constraint allows to) `pose`. Axes the pose does not determine (the
  /// trocar instrument's jaw) are copied from `q_free`, which has n entries or is empty
  /// (then they are 0). Wrapping angles are returned in (−π, π].
  virtual AxisVector inverse(const core::Pose& pose, const AxisVector& q_free) const noexcept = 0;

  /// Links of the instrument: frames whose world pose the axes determine, one per part of
  /// an articulated instrument (paper Eq. 6). Link 0 is always the controlled frame
  /// (link_pose(0, q) == forward(q), link_jacobian(0, q) == jacobian(q)). Default: 1.
  virtual int num_links() const noexcept { return 1; }
  /// Name of a link (static string; scene files bind bodies to links by name). Link 0 is
  /// "tool". Returns "" for an index out of range.
  virtual const char* link_name(int link) const noexcept { return link == 0 ? "tool" : ""; }
  /// World pose of link `link` (0 <= link < num_links()) at axis values q.
  virtual core::Pose link_pose(int link, const AxisVector& q) const noexcept {
    (void)link;
    return forward(q);
  }
  /// Geometric Jacobian (6 x n, world, linear part at the link's origin) of link `link`.
  /// Axis torques balancing wrenches w_l applied at the links' origins: τ = Σ_l J_lᵀ w_l.
  virtual Jacobian link_jacobian(int link, const AxisVector& q) const noexcept {
    (void)link;
    return jacobian(q);
  }
  /// Index of the link called `name` (exact, case-sensitive comparison with link_name()),
  /// or -1 if no link has that name or `name` is null. O(num_links()), no allocation.
  int find_link(const char* name) const noexcept;

 protected:
  Kinematics() = default;
  Kinematics(const Kinematics&) = default;
  Kinematics& operator=(const Kinematics&) = default;
};

/// Twist of the controlled frame for axis rates q̇: [v; ω] = J q̇ (world frame, v at the
/// controlled frame's origin).
core::Twist twist_from_rates(const Jacobian& jacobian, const AxisVector& qdot) noexcept;

/// Axis torques balancing a wrench applied at the controlled frame's origin (world frame):
/// τ = Jᵀ [force; torque] (principle of virtual work). Result has J.cols() entries, N or N·m.
AxisVector torques_from_wrench(const Jacobian& jacobian, const core::Wrench& wrench) noexcept;

/// The axis torques of one wrench per link (paper Eq. 8 per body, mapped by virtual work):
/// τ = Σ_l J_lᵀ [force_l; torque_l] into `tau`, over the first min(jacobians, wrenches) links,
/// w_l in world coordinates about link l's origin and J_l that link's Jacobian (6 × n). `tau`
/// gets n = jacobians[0].cols() entries (its size unchanged without a Jacobian), zero before
/// the sum. Computes as it is: a non-finite wrench gives a non-finite τ.
void torques_from_link_wrenches(std::span<const Jacobian> jacobians,
                                std::span<const core::Wrench> wrenches, AxisVector& tau) noexcept;

/// Every force and torque of `wrenches` is finite.
bool all_finite(std::span<const core::Wrench> wrenches) noexcept;

}  // namespace numen::hal
