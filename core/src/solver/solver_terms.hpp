#pragma once
/// @file solver_terms.hpp
/// Private to numen::core (core/src/solver): small terms shared by the bodies'
/// solves (integrator.cpp) and the nets' (net_*.cpp) — the velocity of a point
/// of a body, the generalized force of a force at a point, the dot product of
/// block vectors, and the one non-finite result of a solve.

#include <limits>
#include <span>

#include "numen/core/data.hpp"
#include "numen/core/types.hpp"

#include "scratch/data_scratch.hpp"

namespace numen::core::detail {

/// J u = v + ω × r: velocity (m/s, world) of the point at lever arm r (m, world)
/// of a body with twist u = (v, ω).
inline Vec3 point_velocity(const Vec6& u, const Vec3& r) noexcept {
  return u.head<3>() + u.tail<3>().cross(r);
}

/// Jᵀ f = (f, r × f): generalized force (N, N·m; at the COM) of a force f (N)
/// applied at lever arm r (m).
inline Vec6 generalized_force(const Vec3& f, const Vec3& r) noexcept {
  Vec6 g;
  g << f, r.cross(f);
  return g;
}

/// True when `body` is this step's coupled body in the massless (first-order) model of Eq. 2:
/// its twist is set by the law, not solved for.
inline bool is_first_order(const SolverScratch& s, int body) noexcept {
  return s.first_order && body == s.coupled_body;
}

/// Σ aᵢ · bᵢ over two block vectors (spans of Vec6 or Vec3) of the same size,
/// in index order.
template <class A, class B>
double dot(const A& a, const B& b) noexcept {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += a[i].dot(b[i]);
  return s;
}

/// The result of a solve that met a non-finite quantity (detail::pcg()'s
/// finite = false, or a non-finite start): NaN unknowns (Δu, and the nodes' Δv)
/// and residual, so that step()'s checks roll the step back rather than
/// silently dropping every force of the step. Returns false (not converged).
inline bool poison_solve(Data& data) noexcept {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (Vec6& v : data.scratch->solver.delta) v.setConstant(kNaN);
  for (Vec3& v : data.scratch->net.delta) v.setConstant(kNaN);
  data.solver_residual = kNaN;
  return false;
}

}  // namespace numen::core::detail
