/// @file net_tissue_contact.cpp
/// The two-scale contact law of a sphere on an organ given by its material
/// (net_tissue_contact.hpp; docs/tissue.md, "The contact").

#include "numen/core/net_tissue_contact.hpp"

#include <algorithm>
#include <cmath>

#include "net/neo_hookean_sphere.hpp"

namespace numen::core {
namespace {

using detail::kNeoHookeanSphereB;
using detail::kNeoHookeanSphereG;
using detail::kNeoHookeanSphereNu;
using detail::kNeoHookeanSphereNus;
using detail::kNeoHookeanSphereStiffenings;
using detail::kNeoHookeanSphereX;
constexpr int kKnots = TissueContactLaw::kKnots;
static_assert(detail::kNeoHookeanSpherePoints == kKnots, "the law's knots are the table's");
static_assert(kNeoHookeanSphereB[0] == 0.0 &&
                  kNeoHookeanSphereB[kNeoHookeanSphereStiffenings - 1] == kMaxStrainStiffening,
              "the table's blocks span [0, kMaxStrainStiffening]");

/// The lower of the two table entries about `v` in the increasing `knots` of `n` (v clamped to
/// them) and v's weight on the upper one.
struct Bracket {
  int lower = 0;
  double weight = 0.0;
};
Bracket bracket(const double* knots, int n, double v) noexcept {
  v = std::clamp(v, knots[0], knots[n - 1]);
  int j = 0;
  while (j + 2 < n && v > knots[j + 1]) ++j;
  return {j, (v - knots[j]) / (knots[j + 1] - knots[j])};
}

/// √x by Newton's iteration, for the knots' constants at compile time.
constexpr double constexpr_sqrt(double x) {
  double r = x > 1.0 ? x : 1.0;
  for (int i = 0; i < 64; ++i) r = 0.5 * (r + x / r);
  return r;
}

/// √x_i and Hertz's g = 4/3 x_i^1.5 at the knots.
struct KnotConstants {
  double sqrt_x[kKnots] = {};
  double hertz[kKnots] = {};
};
constexpr KnotConstants make_knot_constants() {
  KnotConstants k;
  for (int i = 0; i < kKnots; ++i) {
    k.sqrt_x[i] = constexpr_sqrt(kNeoHookeanSphereX[i]);
    k.hertz[i] = 4.0 / 3.0 * kNeoHookeanSphereX[i] * k.sqrt_x[i];
  }
  return k;
}
constexpr KnotConstants kKnotConstants = make_knot_constants();

/// Hertz's g = 4/3 x^1.5.
inline double hertz_g(double x) noexcept { return 4.0 / 3.0 * x * std::sqrt(x); }

/// g and dg/dx at the knot i.
inline TissueHalfSpace at_knot(const TissueContactLaw& law, int i) noexcept {
  const double r = law.ratio[i], dr = law.ratio_slope[i], h = kKnotConstants.hertz[i];
  return {h * r, 2.0 * kKnotConstants.sqrt_x[i] * r + h * dr};
}

/// g and dg/dx at x ≥ 0 in segment `i`: −1 below the first knot, kKnots − 1 past the last,
/// else [x_i, x_{i+1}].
TissueHalfSpace half_space_in(const TissueContactLaw& law, int i, double x) noexcept {
  if (!(x > 0.0)) return {};
  const double* xs = kNeoHookeanSphereX;
  if (i >= kKnots - 1) {  // past the table: linear with its last slope
    const TissueHalfSpace end = at_knot(law, kKnots - 1);
    return {end.g + end.slope * (x - xs[kKnots - 1]), end.slope};
  }
  double r = 0.0, dr = 0.0;
  if (i < 0) {  // below the first knot: r linear with its slope there
    dr = law.ratio_slope[0];
    r = law.ratio[0] + dr * (x - xs[0]);
  } else {
    const double h = xs[i + 1] - xs[i], t = (x - xs[i]) / h;
    const double r0 = law.ratio[i], r1 = law.ratio[i + 1];
    const double m0 = law.ratio_slope[i] * h, m1 = law.ratio_slope[i + 1] * h;
    const double t2 = t * t, t3 = t2 * t;
    r = (2 * t3 - 3 * t2 + 1) * r0 + (t3 - 2 * t2 + t) * m0 + (-2 * t3 + 3 * t2) * r1 +
        (t3 - t2) * m1;
    dr = ((6 * t2 - 6 * t) * r0 + (3 * t2 - 4 * t + 1) * m0 + (-6 * t2 + 6 * t) * r1 +
          (3 * t2 - 2 * t) * m1) / h;
  }
  return {hertz_g(x) * r, 2.0 * std::sqrt(x) * r + hertz_g(x) * dr};
}

/// The segment of x (half_space_in()).
inline int segment_of(double x) noexcept {
  const double* xs = kNeoHookeanSphereX;
  return static_cast<int>(std::upper_bound(xs, xs + kKnots, x) - xs) - 1;
}

/// The x ∈ [lo, hi] where f(x) = 0, f increasing there with f(lo) ≤ 0 ≤ f(hi): Newton from
/// `x`, kept in the bracket, bisection where a step leaves it; to 1e-12 relative.
template <class F>
double solve_increasing(F&& f, double x, double lo, double hi) noexcept {
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

/// The smallest x ≥ 0 where g'(x) ≥ `slope` (+∞: none): the knots' slopes scanned, bisection
/// within the first segment that reaches it (past the last knot g' is its last value).
double first_slope_at_least(const TissueContactLaw& law, double slope) noexcept {
  for (int i = 0; i < kKnots; ++i) {
    if (at_knot(law, i).slope < slope) continue;
    double lo = i == 0 ? 0.0 : kNeoHookeanSphereX[i - 1], hi = kNeoHookeanSphereX[i];
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (half_space_in(law, i - 1, mid).slope >= slope) hi = mid; else lo = mid;
    }
    return hi;
  }
  return HUGE_VAL;
}

}  // namespace

TissueLawPoissonRange tissue_law_poisson_range() noexcept {
  return {kNeoHookeanSphereNu[0], kNeoHookeanSphereNu[kNeoHookeanSphereNus - 1]};
}

TissueHalfSpace tissue_half_space(const TissueContactLaw& law, double x) noexcept {
  return half_space_in(law, segment_of(x), x);
}

TissueContactLaw make_tissue_contact_law(double contact_modulus, double poisson_ratio,
                                         double strain_stiffening, double sphere_radius,
                                         double patch_radius, double penalty) noexcept {
  TissueContactLaw law;
  law.modulus = contact_modulus;
  law.radius = sphere_radius;
  law.patch = kPatchMeanCompliance / (contact_modulus * patch_radius);
  law.penalty = penalty;
  // r at the knots for ν and b: linear between the two rows and the two blocks about them (the
  // nearest outside).
  const Bracket n = bracket(kNeoHookeanSphereNu, kNeoHookeanSphereNus, poisson_ratio);
  const Bracket s = bracket(kNeoHookeanSphereB, kNeoHookeanSphereStiffenings, strain_stiffening);
  const auto& lo = kNeoHookeanSphereG[s.lower];
  const auto& hi = kNeoHookeanSphereG[s.lower + 1];
  for (int i = 0; i < kKnots; ++i) {
    const double g_lo = (1.0 - n.weight) * lo[n.lower][i] + n.weight * lo[n.lower + 1][i];
    const double g_hi = (1.0 - n.weight) * hi[n.lower][i] + n.weight * hi[n.lower + 1][i];
    law.ratio[i] = ((1.0 - s.weight) * g_lo + s.weight * g_hi) / kKnotConstants.hertz[i];
  }
  // r' at the knots: the three-point derivative of the non-uniform knots, one-sided at the ends.
  const double* xs = kNeoHookeanSphereX;
  law.ratio_slope[0] = (law.ratio[1] - law.ratio[0]) / (xs[1] - xs[0]);
  law.ratio_slope[kKnots - 1] =
      (law.ratio[kKnots - 1] - law.ratio[kKnots - 2]) / (xs[kKnots - 1] - xs[kKnots - 2]);
  for (int i = 1; i + 1 < kKnots; ++i) {
    const double h0 = xs[i] - xs[i - 1], h1 = xs[i + 1] - xs[i];
    const double s0 = (law.ratio[i] - law.ratio[i - 1]) / h0;
    const double s1 = (law.ratio[i + 1] - law.ratio[i]) / h1;
    law.ratio_slope[i] = (h1 * s0 + h0 * s1) / (h0 + h1);
  }
  // The switch: dd/dF = 1 / (E* R g'(x)) − c_ρ falls to 1/k where g' = 1 / (E* R (c_ρ + 1/k)).
  const double x_s = first_slope_at_least(
      law, 1.0 / (contact_modulus * sphere_radius * (law.patch + 1.0 / penalty)));
  law.switch_x = x_s;
  if (x_s < HUGE_VAL) {
    law.switch_force =
        contact_modulus * sphere_radius * sphere_radius * tissue_half_space(law, x_s).g;
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
  int i = 0;  // the first knot at or above the target
  while (i < kKnots && at_knot(law, i).g < target) ++i;
  double x = 0.0;
  if (i == kKnots) {  // past the table: g linear
    const TissueHalfSpace end = at_knot(law, kKnots - 1);
    x = kNeoHookeanSphereX[kKnots - 1] + (target - end.g) / end.slope;
  } else {
    const double lo = i == 0 ? 0.0 : kNeoHookeanSphereX[i - 1], hi = kNeoHookeanSphereX[i];
    x = solve_increasing(
        [&](double v) {
          const TissueHalfSpace h = half_space_in(law, i - 1, v);
          return std::pair{h.g - target, h.slope};
        },
        hi, lo, hi);
  }
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
  // d(x) = R x − c_ρ E* R² g(x), increasing below the switch: the segment whose knots bracket
  // `depth` from the knots' d, then Newton within it.
  const double er2 = law.modulus * law.radius * law.radius;
  const double* xs = kNeoHookeanSphereX;
  int i = 0;  // the first knot with d(x_i) ≥ depth
  double d_lo = 0.0, d_hi = 0.0;
  for (; i < kKnots && xs[i] < law.switch_x; ++i) {
    d_hi = law.radius * xs[i] - law.patch * er2 * at_knot(law, i).g;
    if (d_hi >= depth) break;
    d_lo = d_hi;
  }
  double x = 0.0;
  if (i == kKnots) {  // past the table: g linear, d linear in x
    const TissueHalfSpace end = at_knot(law, kKnots - 1);
    x = (depth + law.patch * er2 * (end.g - end.slope * xs[kKnots - 1])) /
        (law.radius - law.patch * er2 * end.slope);
  } else {
    const double lo = i == 0 ? depth / law.radius : xs[i - 1];
    const double hi = std::min(xs[i], law.switch_x);
    const auto residual = [&](double v) {
      const TissueHalfSpace h = half_space_in(law, i - 1, v);
      return std::pair{law.radius * v - law.patch * er2 * h.g - depth,
                       law.radius - law.patch * er2 * h.slope};
    };
    // Start where the chord between the knots' depths meets `depth` (below the first knot,
    // and at a switch between knots, from the lower bound).
    const bool chord = i > 0 && hi == xs[i] && d_hi > d_lo;
    const double start = chord ? lo + (hi - lo) * (depth - d_lo) / (d_hi - d_lo) : lo;
    x = solve_increasing(residual, start, lo, hi);
  }
  const TissueHalfSpace h = tissue_half_space(law, x);
  r.force = er2 * h.g;
  const double compliance = 1.0 / (law.modulus * law.radius * h.slope) - law.patch;  // dd/dF
  r.stiffness = compliance > 0.0 ? std::min(law.penalty, 1.0 / compliance) : law.penalty;
  return r;
}

}  // namespace numen::core
