#pragma once
/// @file pcg.hpp
/// Private to numen::core (core/src/detail): the one preconditioned conjugate
/// gradient loop of the implicit solves (Hestenes & Stiefel 1952; Saad,
/// "Iterative Methods for Sparse Linear Systems", Alg. 9.1). The four solves of
/// the core are its uses: the bodies' block-Jacobi CG (solve_implicit_system),
/// the joints' projected CG (solve_constrained_system), the nets' SSOR CG with
/// Eisenstat's trick and the nets' arrowhead projected CG (net_solve.hpp).
///
/// The kernel owns the iteration, the stopping rule and the non-finite path; the
/// system owns its vectors (fixed-size blocks in the caller's scratch), its
/// operator, its preconditioner and its residual measure. A `System` provides:
///   double apply() noexcept;              // A p (or Eisenstat's K q); returns pᵀ A p
///   double advance(double alpha) noexcept; // x += α p, r −= α A p (a projected CG
///                                          // also preconditions and projects here);
///                                          // returns the residual measure
///   double precondition() noexcept;        // z = P⁻¹ r; returns rᵀ z
///   void direction(double beta) noexcept;  // p = z + β p
/// Header-only and allocation-free: every call is inlined into the caller's loop.

#include <algorithm>
#include <cmath>
#include <limits>

namespace numen::core::detail {

/// Stopping rule of pcg(): converged when the system's residual measure is at or
/// below `tolerance`; at most max(1, max_iterations) iterations.
struct PcgStop {
  double tolerance = 0.0;  ///< On the system's residual measure (relative, dimensionless).
  int max_iterations = 1;  ///< Iteration budget (at least one is run).
};

/// What pcg() ran.
struct PcgResult {
  int iterations = 0;     ///< Iterations run (0 when the start already met the rule).
  double residual = 0.0;  ///< The last residual measure; NaN when non-finite.
  bool finite = true;     ///< false: a non-finite quantity met; the iterate is not usable.
  /// The rule met (and finite).
  bool converged(const PcgStop& stop) const noexcept {
    return finite && residual <= stop.tolerance;
  }
};

/// Preconditioned CG from the system's start (x0, r0, z0 = P⁻¹ r0 and p0 = z0 set
/// by the caller), with `residual0` its residual measure and `rz0` = r0ᵀ z0.
/// Each iteration: α = rᵀz / pᵀAp, advance, stop on the rule, z = P⁻¹ r,
/// β = r'ᵀz' / rᵀz, p = z + β p. Stops early on a breakdown (pᵀAp ≤ 0, or
/// r'ᵀz' ≤ 0: A or P not positive definite numerically, or converged to
/// rounding). The non-finite path, once for every solve: a non-finite start,
/// pᵀAp, residual or rᵀz returns finite = false at once (the caller poisons its
/// unknowns so that step()'s checks roll the step back). Deterministic: the
/// system's fixed summation order. No allocation, no exception.
template <class System>
PcgResult pcg(System& system, double residual0, double rz0, const PcgStop& stop) noexcept {
  PcgResult out;
  out.residual = residual0;
  const auto nonfinite = [&out]() noexcept {
    out.residual = std::numeric_limits<double>::quiet_NaN();
    out.finite = false;
    return out;
  };
  if (!std::isfinite(residual0) || !std::isfinite(rz0)) return nonfinite();
  double rz = rz0;
  const int max_iterations = std::max(1, stop.max_iterations);
  while (out.residual > stop.tolerance && out.iterations < max_iterations) {
    ++out.iterations;
    const double pap = system.apply();
    if (!std::isfinite(pap)) return nonfinite();
    if (!(pap > 0.0)) break;  // breakdown, or converged exactly
    out.residual = system.advance(rz / pap);
    if (!std::isfinite(out.residual)) return nonfinite();
    if (out.residual <= stop.tolerance) break;
    const double rz_new = system.precondition();
    if (!std::isfinite(rz_new)) return nonfinite();
    if (!(rz_new > 0.0)) break;  // converged to rounding
    const double beta = rz_new / rz;
    rz = rz_new;
    system.direction(beta);
  }
  return out;
}

}  // namespace numen::core::detail
