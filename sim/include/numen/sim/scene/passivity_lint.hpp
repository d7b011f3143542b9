#pragma once
/// @file passivity_lint.hpp
/// The passivity lint of a closed-loop scene (docs/device_plant.md "Passivity lint"): for every
/// axis of the declared plant ([device.plant]) that has a drive and mass, the stiffness K and the
/// damping B the feedback coupling renders on that axis at the control period T, against the two
/// classic conditions for a sampled virtual wall:
///
///   Colgate & Schenkel (J. Robotic Systems 14(1), 1997):   b > K T / 2 + |B|
///   Abbott & Okamura (IEEE T-RO 21(5), 2005):              K ≤ max(2 b / T, 2 f_c / Δ)
///
/// with b the axis's viscous damping, f_c its Coulomb friction and Δ its encoder's count
/// (1 / counts_per_unit). The axis's K and B are the largest diagonal entries of Jᵀ K_c J and
/// Jᵀ B_c J over the trajectory's poses (J the device's Jacobian at the intent; K_c, B_c =
/// diag(k, k, k, k_r, k_r, k_r) and diag(γ, γ, γ, γ_r, γ_r, γ_r) of `[device.feedback]`; direct
/// coupling renders the contacts: the stiffest material pair, no damping). The lint fails an axis
/// when it meets neither condition (the max() form: either the sampled damping or the friction
/// against the quantisation holds it). Load time only: allocates.

#include <string>
#include <vector>

namespace numen::sim {

struct Scene;

/// One plant axis's verdict.
struct PassivityLintRow {
  int axis = 0;              ///< Index in the device's axes.
  std::string axis_name;
  double period_s = 0.0;     ///< T.
  double stiffness = 0.0;    ///< K rendered on the axis (N/m or N·m/rad).
  double damping = 0.0;      ///< B rendered on the axis (N·s/m or N·m·s/rad).
  double device_damping = 0.0;   ///< b.
  double coulomb = 0.0;          ///< f_c.
  double resolution = 0.0;       ///< Δ (m or rad).
  /// Colgate & Schenkel's margin: b − (K T / 2 + |B|) (> 0: passive by it).
  double colgate_margin = 0.0;
  /// Abbott & Okamura's bound max(2 b / T, 2 f_c / Δ) on K.
  double abbott_okamura_bound = 0.0;
  bool passes = true;        ///< Meets at least one of the two conditions.
};

/// The lint's rows for `scene` (empty without [device.plant]).
std::vector<PassivityLintRow> passivity_lint(const Scene& scene);

/// The warning of a failing row: names the keys ([device.plant] damping / coulomb of the axis,
/// [device.feedback]), the values, both bounds and their sources.
std::string passivity_lint_warning(const PassivityLintRow& row);

}  // namespace numen::sim
