#pragma once
/// @file soft_constraint_mapping.hpp
/// numen's springs (penalty contacts, coupling springs: a stiffness k in N/m and a damping c in
/// N·s/m acting on a body of mass m) expressed as MuJoCo soft-constraint parameters
/// (docs/peer.md, "Contact and weld softness").
///
/// MuJoCo (Todorov 2014; MuJoCo documentation, Modeling → Solver parameters) solves each
/// constraint row in acceleration space: with impedance d, the direct reference
/// solref = (−K, −B) and a constant impedance solimp = (d, d, width, 0.5, 2), a row of inverse
/// effective mass A obeys
///     a₁ + B v + K r = (1 − d) a₀
/// (a₀: the acceleration without this constraint, r: the violation, v its rate). Its force is
/// f = (K r + B v + …) / ((1 − d) A), so at rest under any other force (a spring, gravity,
/// another constraint) it acts as a force spring of stiffness K / ((1 − d) A) — and in a
/// transient it rings at ω = √K. The mapping keeps what the measured quantities depend on:
///   static stiffness  K = (1 − d) k A          (same rest penetration F / k as numen)
///   damping ratio     B = 2 ζ √K, ζ = c / (2 √(k m))   (same ζ as numen's spring)
/// with A = 1/m (a row through the centre of mass; lever arms are left out). d is the smallest
/// impedance that keeps MuJoCo's own rule "time constant ≥ 2 Δt" (the refsafe rule) for the
/// mapped spring, 1/√K ≥ 2 Δt, i.e. d = 1 − 1 / (4 ω² Δt²), ω = √(k/m), and at least
/// kMinImpedance. As d → 0 the row would be numen's penalty spring exactly (K = k/m, B = c/m,
/// a₁ = a₀ − K r − B v), but MuJoCo is not stable there: the mocap weld of the wall scene
/// (d = 1e-4, 1e-3, 1e-2, 0.1) sends the free joint's rotation to a bad qacc within 0.6 s of
/// the contact, while d = 0.5 and 0.9 run the 3 s (docs/peer.md). With d ≥ ½ a row rings at
/// √(1 − d) ω ≤ 0.71 ω, slower than numen's spring, while keeping the same rest penetration.

namespace numen::peer {

/// Smallest impedance the mapping uses (file comment: measured stability floor).
inline constexpr double kMinImpedance = 0.5;

/// MuJoCo parameters of one soft-constraint row (direct solref, constant impedance).
struct SoftConstraint {
  double impedance = 0.0;  ///< d in [mjMINIMP, mjMAXIMP]: solimp = (d, d, 0.001, 0.5, 2).
  double stiffness = 0.0;  ///< K (1/s²): solref[0] = −K.
  double damping = 0.0;    ///< B (1/s): solref[1] = −B.
};

/// Maps a spring of stiffness `k` (N/m, > 0) and damping `c` (N·s/m, ≥ 0) acting on a body of
/// `mass` (kg, > 0) at time step `dt` (s, > 0) to MuJoCo (file comment). Throws
/// std::invalid_argument naming the argument out of range.
SoftConstraint match_spring(double k, double c, double mass, double dt);

/// Force-level stiffness (N/m) of a row with parameters `s` and inverse effective mass 1/`mass`
/// at rest: K m / (1 − d). Inverse of match_spring's stiffness (for tests and docs).
double static_stiffness(const SoftConstraint& s, double mass) noexcept;

}  // namespace numen::peer
