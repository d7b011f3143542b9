/// @file net_tissue_contact.cpp
/// The two-scale contact law of a sphere on an organ given by its material
/// (net_tissue_contact.hpp; docs/tissue.md, "The contact").

#include "numen/core/net_tissue_contact.hpp"

#include <algorithm>
#include <cmath>

#include "net/neo_hookean_sphere.hpp"

namespace numen::core {
namespace {

using detail::kNeoHookeanSphereG;
using detail::kNeoHookeanSphereNu;
using detail::kNeoHookeanSphereNus;
using detail::kNeoHookeanSphereX;
constexpr int kKnots = TissueContactLaw::kKnots;
static_assert(detail::kNeoHookeanSpherePoints == kKnots, "the law's knots are the table's");

/// Hertz's g = 4/3 x^1.5.
inline double hertz_g(double x) noexcept { return 4.0 / 3.0 * x * std::sqrt(x); }

/// The x ∈ [lo, hi] where f(x) = 0, f increasing there with f(lo) ≤ 0 ≤ f(hi): Newton from lo,
/// kept in the bracket, bisection where a step leaves it; to 1e-12 relative.
template <class F>
double solve_increasing(F&& f, double lo, double hi) noexcept {
  double x = lo;
  for (int it = 0; it < 100; ++it) {
    const auto [value, slope] = f(x);
    if (value > 0.0) hi = x; else lo = x;
    double next = slope > 0.0 ? x - value / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-12 * x || hi - lo <= 1e-14 * hi) return next;
    x = next;
  }
  return x;
}

/// The smallest x ≥ 0 where g'(x) ≥ `slope` (+∞: none): a scan of the knots, bisection within
/// the first segment that reaches it (past the last knot g' is its last value).
double first_slope_at_least(const TissueContactLaw& law, double slope) noexcept {
  double lo = 0.0;
  for (int i = 0; i < kKnots; ++i) {
    double hi = kNeoHookeanSphereX[i];
    if (tissue_half_space(law, hi).slope >= slope) {
      for (int it = 0; it < 80; ++it) {
        const double mid = 0.5 * (lo + hi);
        if (tissue_half_space(law, mid).slope >= slope) hi = mid; else lo = mid;
      }
      return hi;
    }
    lo = hi;
  }
  return HUGE_VAL;
}

}  // namespace

TissueHalfSpace tissue_half_space(const TissueContactLaw& law, double x) noexcept {
  if (!(x > 0.0)) return {};
  const double* xs = kNeoHookeanSphereX;
  if (x >= xs[kKnots - 1]) {  // past the table: linear with its last slope
    const double xn = xs[kKnots - 1];
    const double r = law.ratio[kKnots - 1], dr = law.ratio_slope[kKnots - 1];
    const double slope = 2.0 * std::sqrt(xn) * r + hertz_g(xn) * dr;
    return {hertz_g(xn) * r + slope * (x - xn), slope};
  }
  double r = 0.0, dr = 0.0;
  if (x <= xs[0]) {  // below the first knot: r linear with its slope there
    dr = law.ratio_slope[0];
    r = law.ratio[0] + dr * (x - xs[0]);
  } else {
    const int i = static_cast<int>(std::upper_bound(xs, xs + kKnots, x) - xs) - 1;
    const double h = xs[i + 1] - xs[i], t = (x - xs[i]) / h;
    const double r0 = law.ratio[i], r1 = law.ratio[i + 1];
    const double m0 = law.ratio_slope[i] * h, m1 = law.ratio_slope[i + 1] * h;
    const double t2 = t * t, t3 = t2 * t;
    r = (2 * t3 - 3 * t2 + 1) * r0 + (t3 - 2 * t2 + t) * m0 + (-2 * t3 + 3 * t2) * r1 + (t3 - t2) * m1;
    dr = ((6 * t2 - 6 * t) * r0 + (3 * t2 - 4 * t + 1) * m0 + (-6 * t2 + 6 * t) * r1 + (3 * t2 - 2 * t) * m1) / h;
  }
  return {hertz_g(x) * r, 2.0 * std::sqrt(x) * r + hertz_g(x) * dr};
}

TissueContactLaw make_tissue_contact_law(double contact_modulus, double poisson_ratio,
                                         double sphere_radius, double patch_radius,
                                         double penalty) noexcept {
  TissueContactLaw law;
  law.modulus = contact_modulus;
  law.radius = sphere_radius;
  law.patch = kPatchMeanCompliance / (contact_modulus * patch_radius);
  law.penalty = penalty;
  // r at the knots for ν: linear between the two rows about it (the nearest row outside).
  const double* nus = kNeoHookeanSphereNu;
  const double nu = std::clamp(poisson_ratio, nus[0], nus[kNeoHookeanSphereNus - 1]);
  int j = 0;
  while (j + 2 < kNeoHookeanSphereNus && nu > nus[j + 1]) ++j;
  const double w = (nu - nus[j]) / (nus[j + 1] - nus[j]);
  for (int i = 0; i < kKnots; ++i) {
    const double g = (1.0 - w) * kNeoHookeanSphereG[j][i] + w * kNeoHookeanSphereG[j + 1][i];
    law.ratio[i] = g / hertz_g(kNeoHookeanSphereX[i]);
  }
  // r' at the knots: the three-point derivative of the non-uniform knots, one-sided at the ends.
  const double* xs = kNeoHookeanSphereX;
  for (int i = 0; i < kKnots; ++i) {
    if (i == 0 || i == kKnots - 1) {
      const int a = i == 0 ? 0 : i - 1;
      law.ratio_slope[i] = (law.ratio[a + 1] - law.ratio[a]) / (xs[a + 1] - xs[a]);
      continue;
    }
    const double h0 = xs[i] - xs[i - 1], h1 = xs[i + 1] - xs[i];
    const double s0 = (law.ratio[i] - law.ratio[i - 1]) / h0, s1 = (law.ratio[i + 1] - law.ratio[i]) / h1;
    law.ratio_slope[i] = (h1 * s0 + h0 * s1) / (h0 + h1);
  }
  // The switch: dd/dF = 1 / (E* R g'(x)) − c_ρ falls to 1/k where g' = 1 / (E* R (c_ρ + 1/k)).
  const double x_s =
      first_slope_at_least(law, 1.0 / (contact_modulus * sphere_radius * (law.patch + 1.0 / penalty)));
  law.switch_x = x_s;
  if (x_s < HUGE_VAL) {
    law.switch_force = contact_modulus * sphere_radius * sphere_radius * tissue_half_space(law, x_s).g;
    law.switch_depth = sphere_radius * x_s - law.patch * law.switch_force;
  } else {
    law.switch_force = HUGE_VAL;
    law.switch_depth = HUGE_VAL;
  }
  return law;
}

double tissue_contact_depth(const TissueContactLaw& law, double force) noexcept {
  if (!(force > 0.0)) return 0.0;
  const double target = force / (law.modulus * law.radius * law.radius);
  double hi = 1.0;
  for (int i = 0; i < 200 && tissue_half_space(law, hi).g < target; ++i) hi *= 2.0;
  const double x = solve_increasing(
      [&](double v) {
        const TissueHalfSpace h = tissue_half_space(law, v);
        return std::pair{h.g - target, h.slope};
      },
      0.0, hi);
  return law.radius * x - law.patch * force;
}

TissueContactForce tissue_contact_force(const TissueContactLaw& law, double depth) noexcept {
  TissueContactForce r;
  if (!(depth > 0.0)) return r;
  if (depth >= law.switch_depth) {
    r.force = law.switch_force + law.penalty * (depth - law.switch_depth);
    r.stiffness = law.penalty;
    return r;
  }
  // d(x) = R x − c_ρ E* R² g(x), increasing below the switch; d(d / R) ≤ d.
  const double er2 = law.modulus * law.radius * law.radius;
  const auto residual = [&](double x) {
    const TissueHalfSpace h = tissue_half_space(law, x);
    return std::pair{law.radius * x - law.patch * er2 * h.g - depth,
                     law.radius - law.patch * er2 * h.slope};
  };
  double hi = law.switch_x;
  if (!(hi < HUGE_VAL)) {
    hi = std::max(2.0 * depth / law.radius, 1e-9);
    for (int i = 0; i < 200 && residual(hi).first < 0.0; ++i) hi *= 2.0;
  }
  const double x = solve_increasing(residual, depth / law.radius, hi);
  const TissueHalfSpace h = tissue_half_space(law, x);
  r.force = er2 * h.g;
  const double compliance = 1.0 / (law.modulus * law.radius * h.slope) - law.patch;  // dd/dF
  r.stiffness = compliance > 0.0 ? std::min(law.penalty, 1.0 / compliance) : law.penalty;
  return r;
}

}  // namespace numen::core
