/// @file net_tissue_contact.cpp
/// The two-scale contact law of a sphere on an organ given by its material
/// (net_tissue_contact.hpp; docs/tissue.md, "The contact").

#include "numen/core/net_tissue_contact.hpp"

#include <algorithm>
#include <cmath>

namespace numen::core {
namespace {

/// d(x) = A x² − c x³ for x = F^(1/3): the law's depth below the submerging force.
inline double hertz_depth(double a, double c, double x) noexcept { return x * x * (a - c * x); }

/// The x = F^(1/3) ≤ x_hi where hertz_depth(x) = d (0 ≤ d ≤ hertz_depth(x_hi), increasing on
/// [0, x_hi]): Newton from the Hertz root √(d/A) (a lower bound: c x³ ≥ 0), kept in its bracket,
/// bisection where a step leaves it.
double solve_hertz(double a, double c, double d, double x_hi) noexcept {
  double lo = std::min(std::sqrt(d / a), x_hi), hi = x_hi;
  double x = lo;
  for (int it = 0; it < 60; ++it) {
    const double g = hertz_depth(a, c, x) - d;
    if (g > 0.0) hi = x; else lo = x;
    const double slope = x * (2.0 * a - 3.0 * c * x);
    double next = slope > 0.0 ? x - g / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-12 * x) return next;
    x = next;
  }
  return x;
}

}  // namespace

double tissue_contact_depth(const TissueContactLaw& law, double force) noexcept {
  if (!(force > 0.0)) return 0.0;
  if (force <= law.submerge_force) return law.hertz * std::cbrt(force * force) - law.patch * force;
  return law.radius + law.punch * (force - law.submerge_force) - law.patch * force;
}

TissueContactLaw make_tissue_contact_law(double contact_modulus, double sphere_radius,
                                         double patch_radius, double penalty) noexcept {
  TissueContactLaw law;
  law.hertz = std::cbrt(std::pow(3.0 / (4.0 * contact_modulus * std::sqrt(sphere_radius)), 2.0));
  law.patch = kPatchMeanCompliance / (contact_modulus * patch_radius);
  law.radius = sphere_radius;
  law.submerge_force = 4.0 / 3.0 * contact_modulus * sphere_radius * sphere_radius;
  law.punch = 1.0 / (2.0 * contact_modulus * sphere_radius);
  law.penalty = penalty;
  // The switch: the force where dd/dF falls to 1/k (ρ too small for R), if any.
  const double x_stiff = (2.0 / 3.0) * law.hertz / (law.patch + 1.0 / penalty);
  const double x_submerge = std::cbrt(law.submerge_force);
  double force = HUGE_VAL;
  if (x_stiff < x_submerge)
    force = x_stiff * x_stiff * x_stiff;  // stiff within Hertz's range
  else if (law.punch - law.patch <= 1.0 / penalty)
    force = law.submerge_force;  // the submerged sphere's slope is stiffer than k
  law.switch_force = force;
  law.switch_depth = force < HUGE_VAL ? tissue_contact_depth(law, force) : HUGE_VAL;
  return law;
}

TissueContactForce tissue_contact_force(const TissueContactLaw& law, double depth) noexcept {
  TissueContactForce r;
  if (!(depth > 0.0)) return r;
  if (depth >= law.switch_depth) {
    r.force = law.switch_force + law.penalty * (depth - law.switch_depth);
    r.stiffness = law.penalty;
    return r;
  }
  const double hertz_end = std::min(law.submerge_force, law.switch_force);
  if (depth <= tissue_contact_depth(law, hertz_end)) {
    const double x = solve_hertz(law.hertz, law.patch, depth, std::cbrt(hertz_end));
    r.force = x * x * x;
    const double compliance = (2.0 / 3.0) * law.hertz / x - law.patch;  // dd/dF
    r.stiffness = compliance > 0.0 ? std::min(law.penalty, 1.0 / compliance) : law.penalty;
    return r;
  }
  // Submerged: d = R + c_p (F − F_R) − c F.
  const double compliance = law.punch - law.patch;
  r.force = (depth - law.radius + law.punch * law.submerge_force) / compliance;
  r.stiffness = std::min(law.penalty, 1.0 / compliance);
  return r;
}

}  // namespace numen::core
