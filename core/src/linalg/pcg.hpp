#pragma once
/// @file pcg.hpp
/// Private to numen::core (core/src/linalg): the one preconditioned conjugate
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
/// and, for the error rule (PcgErrorStop) only:
///   double solution_energy() noexcept;     // bᵀ x of the current iterate
/// Two stopping rules: PcgStop on the system's residual measure, PcgErrorStop
/// on an estimate of the iterate's error in the energy norm ‖·‖_A from the
/// iteration's own coefficients (Hestenes & Stiefel 1952, Thm. 6:1; Strakoš &
/// Tichý, "On error estimation in the conjugate gradient method and why it
/// works in finite precision computations", ETNA 13, 2002).
/// Header-only and allocation-free: every call is inlined into the caller's loop.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace numen::core::detail {

/// Stopping rule of pcg() on the residual: converged when the system's
/// residual measure is at or below `tolerance`; at most max(1, max_iterations)
/// iterations.
struct PcgStop {
  double tolerance = 0.0;  ///< On the system's residual measure (relative, dimensionless).
  int max_iterations = 1;  ///< Iteration budget (at least one is run).
};

/// Largest delay of PcgErrorStop (the length of its ring of α_j ρ_j).
inline constexpr int kMaxPcgErrorDelay = 8;

/// Stopping rule of pcg() on the error: converged when the Hestenes–Stiefel
/// estimate of the relative energy-norm error,
///   η_k = √( Σ_{j=k}^{k+d−1} α_j ρ_j / bᵀx_{k+d} ),  ρ_j = r_jᵀ z_j,
/// of iterate k, known after iteration k + d − 1, is at or below `tolerance`
/// (the loop then ends with x_{k+d}). In exact arithmetic CG gives
/// ‖x − x_j‖²_A − ‖x − x_{j+1}‖²_A = α_j ρ_j (Hestenes & Stiefel 1952, Thm. 6:1),
/// so the sum is a lower bound of ‖x − x_k‖²_A that misses only
/// ‖x − x_{k+d}‖²_A, which CG has made small by then; Strakoš & Tichý (2002)
/// show that it stays valid, up to small rounding terms, in finite precision
/// until the error reaches the iteration's attainable accuracy. bᵀx_{k+d} = x_{k+d}ᵀ A x to first order is ‖x‖²_A
/// within a relative η: the test bounds ‖x − x_k‖_A / ‖x‖_A. The returned
/// iterate x_{k+d} is at least as good as x_k (CG's A-norm error decreases
/// monotonically), so η_k bounds the returned error up to the estimate's own
/// accuracy. At most max(1, max_iterations) iterations.
struct PcgErrorStop {
  double tolerance = 0.0;  ///< On η, the relative energy-norm error (dimensionless).
  int max_iterations = 1;  ///< Iteration budget (at least one is run).
  int delay = 1;           ///< d, clamped to [1, kMaxPcgErrorDelay].
  /// F ≥ 0, the least ‖x‖²_A the error is taken relative to (the system's energy units): η_k =
  /// √(Σ α_j ρ_j / max(bᵀx_{k+d}, F)), and the start meets the rule when √(r0ᵀz0 / F) ≤ tolerance
  /// (0 iterations: x0 is within the tolerance of F's scale, r0ᵀz0 standing for ‖x − x0‖²_A within
  /// the preconditioner's condition number). A solution smaller than F's scale is then solved to
  /// tolerance · √F in absolute terms instead of to a relative tolerance of its own vanishing size
  /// (a system at rest: b of rounding size, which the relative rule chases over d + 4 or more
  /// iterations). 0: the relative rule alone.
  double floor = 0.0;
};

/// What pcg() ran.
struct PcgResult {
  int iterations = 0;  ///< Iterations run (0 when the start already met the rule).
  /// The last measure of the rule: the residual measure (PcgStop), or the error
  /// estimate η (PcgErrorStop; +∞ before d iterations ran,
  /// 0 when the residual vanished exactly). NaN when non-finite.
  double residual = 0.0;
  bool finite = true;  ///< false: a non-finite quantity met; the iterate is not usable.
  /// The rule met (and finite).
  template <class Stop>
  bool converged(const Stop& stop) const noexcept {
    return finite && residual <= stop.tolerance;
  }
};

namespace pcg_rule {

/// PcgStop's state: the residual measure the system returns.
struct Residual {
  double tolerance;
  double measure;
  bool met() const noexcept { return measure <= tolerance; }
  template <class System>
  bool after_advance(System&, double residual, double, double) noexcept {
    measure = residual;
    return met();
  }
  void exact() noexcept {}  // the residual measure already says so
};

/// PcgErrorStop's state: the ring of the last d values α_j ρ_j and their
/// running total Σ_j α_j ρ_j = ‖x_j − x0‖²_A (the energy of this solve's
/// correction), the denominator when bᵀx ≤ 0 (b = 0: the solution is 0 and the
/// error is the start's).
struct EnergyError {
  double tolerance;
  int delay;
  double floor = 0.0;  ///< PcgErrorStop::floor.
  double measure = std::numeric_limits<double>::infinity();
  std::array<double, kMaxPcgErrorDelay> ring{};
  int count = 0;
  double total = 0.0;
  bool met() const noexcept { return measure <= tolerance; }
  template <class System>
  bool after_advance(System& system, double, double alpha, double rz) noexcept {
    const double gain = alpha * rz;
    ring[static_cast<std::size_t>(count % delay)] = gain;
    total += gain;
    if (++count < delay) return false;
    double decrease = 0.0;  // Σ of the last d α_j ρ_j, oldest first
    for (int j = count - delay; j < count; ++j) decrease += ring[static_cast<std::size_t>(j % delay)];
    const double energy = system.solution_energy();
    const double norm2 = std::max(energy > 0.0 ? energy : total, floor);
    if (!std::isfinite(energy)) {
      measure = std::numeric_limits<double>::quiet_NaN();
    } else if (decrease <= 0.0) {
      measure = 0.0;  // α ρ vanished: nothing left to gain
    } else {
      measure = norm2 > 0.0 ? std::sqrt(decrease / norm2) : std::numeric_limits<double>::infinity();
    }
    return met();
  }
  void exact() noexcept { measure = 0.0; }  // r = 0: x solves the system
};

/// A result for a non-finite quantity.
inline PcgResult nonfinite(PcgResult out) noexcept {
  out.residual = std::numeric_limits<double>::quiet_NaN();
  out.finite = false;
  return out;
}

/// The loop of pcg() for either rule (see there).
template <class System, class Rule>
PcgResult run(System& system, double rz0, int max_iterations_setting, Rule& rule) noexcept {
  PcgResult out;
  out.residual = rule.measure;
  if (!std::isfinite(rz0)) return nonfinite(out);
  double rz = rz0;
  const int max_iterations = std::max(1, max_iterations_setting);
  while (!rule.met() && out.iterations < max_iterations) {
    ++out.iterations;
    const double pap = system.apply();
    if (!std::isfinite(pap)) return nonfinite(out);
    if (!(pap > 0.0)) break;  // breakdown, or converged exactly
    const double alpha = rz / pap;
    const double residual = system.advance(alpha);
    if (!std::isfinite(residual)) return nonfinite(out);
    const bool met = rule.after_advance(system, residual, alpha, rz);
    out.residual = rule.measure;
    if (std::isnan(rule.measure)) return nonfinite(out);
    if (met) break;
    const double rz_new = system.precondition();
    if (!std::isfinite(rz_new)) return nonfinite(out);
    if (!(rz_new > 0.0)) {  // converged to rounding (exactly, if 0)
      if (rz_new == 0.0) rule.exact();
      out.residual = rule.measure;
      break;
    }
    const double beta = rz_new / rz;
    rz = rz_new;
    system.direction(beta);
  }
  return out;
}

}  // namespace pcg_rule

/// Preconditioned CG from the system's start (x0, r0, z0 = P⁻¹ r0 and p0 = z0 set
/// by the caller), with `residual0` its residual measure and `rz0` = r0ᵀ z0,
/// stopping on the residual measure. Each iteration: α = rᵀz / pᵀAp, advance,
/// stop on the rule, z = P⁻¹ r, β = r'ᵀz' / rᵀz, p = z + β p. Stops early on a
/// breakdown (pᵀAp ≤ 0, or r'ᵀz' ≤ 0: A or P not positive definite
/// numerically, or converged to rounding). The non-finite path, once for every
/// solve: a non-finite start, pᵀAp, residual or rᵀz returns finite = false at
/// once (the caller poisons its unknowns so that step()'s checks roll the step
/// back). Deterministic: the system's fixed summation order. No allocation, no
/// exception.
template <class System>
PcgResult pcg(System& system, double residual0, double rz0, const PcgStop& stop) noexcept {
  pcg_rule::Residual rule{stop.tolerance, residual0};
  if (!std::isfinite(residual0)) return pcg_rule::nonfinite(PcgResult{});
  return pcg_rule::run(system, rz0, stop.max_iterations, rule);
}

/// The same loop stopping on the energy-norm error estimate of PcgErrorStop
/// (needs System::solution_energy()). The start meets the rule only when
/// rz0 = r0ᵀ z0 is 0 (x0 solves the system; 0 iterations, estimate 0) or, with a
/// floor F, when √(rz0 / F) ≤ tolerance (0 iterations, that estimate);
/// otherwise at least d iterations run (the budget permitting). A breakdown
/// or the budget ends the loop with the last estimate (+∞ if fewer than d
/// iterations ran), a vanishing r'ᵀz' with the iterate exact (estimate 0).
/// bᵀx ≤ 0 (b = 0) makes the estimate relative to ‖x_k − x0‖_A instead.
template <class System>
PcgResult pcg(System& system, double rz0, const PcgErrorStop& stop) noexcept {
  pcg_rule::EnergyError rule{stop.tolerance, std::clamp(stop.delay, 1, kMaxPcgErrorDelay),
                             stop.floor > 0.0 ? stop.floor : 0.0};
  if (rz0 == 0.0) {
    rule.measure = 0.0;
  } else if (rule.floor > 0.0 && std::isfinite(rz0) && std::sqrt(rz0 / rule.floor) <= stop.tolerance) {
    rule.measure = std::sqrt(rz0 / rule.floor);  // the start is within the floor's tolerance
  }
  return pcg_rule::run(system, rz0, stop.max_iterations, rule);
}

}  // namespace numen::core::detail
