/// @file study_passivity_bounds.cpp
/// The analytic passivity bounds of `numen study passivity` (study_passivity.hpp;
/// docs/passivity.md "Bounds").

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "numen/sim/study/study_passivity.hpp"

namespace numen::sim {

double colgate_bound(const PassivityPoint& p) {
  // Colgate & Schenkel 1997: passive iff b > K T / 2 + |B|.
  return std::max(0.0, 2.0 * (p.device_damping - std::abs(p.damping)) / p.period_s);
}

double abbott_okamura_bound(const PassivityPoint& p) {
  // Abbott & Okamura 2005: K <= max(2b/T, 2 f_c/Δ) (B = 0 in the paper; |B| is taken off b as
  // in Colgate & Schenkel).
  const double coulomb_term = p.resolution > 0.0 ? 2.0 * p.coulomb / p.resolution
                              : p.coulomb > 0.0  ? std::numeric_limits<double>::infinity()
                                                 : 0.0;
  return std::max(colgate_bound(p), coulomb_term);
}

namespace {

/// Colgate & Schenkel's condition for a controller H(z) (force −H(z) x̂), at θ = ωT:
///   b (1 − cos θ) · 2/T > Re{(1 − e^{−jθ}) H(e^{jθ})},  0 < θ <= π,
/// with H(z) = z^{−d} (K + B (1 − z^{−1})/T): K g1(θ) + (B/T) g2(θ) < 2 b (1 − cos θ)/T,
///   g1 = cos dθ − cos (d+1)θ,  g2 = cos dθ − 2 cos (d+1)θ + cos (d+2)θ.
/// Each θ with g1 > 0 bounds K from above; the bound is their minimum over θ → 0 (the limit
/// 2(b + B)/((2d + 1) T), b / (T/2 + dT) for B = 0) and a grid of 20000 points in (0, π].
/// Returns the bound and sets `theta` to the θ that binds.
double frequency_condition(const PassivityPoint& p, double& theta) {
  const double b = p.device_damping, bb = p.damping, t = p.period_s;
  const double d = p.delay_periods;
  // θ → 0: g1 → (2d + 1) θ²/2, g2 → −θ², 1 − cos θ → θ²/2.
  double bound = 2.0 * (b + bb) / ((2.0 * d + 1.0) * t);
  theta = 0.0;
  constexpr int kPoints = 20000;
  for (int i = 1; i <= kPoints; ++i) {
    const double th = std::numbers::pi * i / kPoints;
    const double g1 = std::cos(d * th) - std::cos((d + 1) * th);
    const double g2 = std::cos(d * th) - 2.0 * std::cos((d + 1) * th) + std::cos((d + 2) * th);
    if (g1 <= 1e-12) continue;
    const double k = (2.0 * b * (1.0 - std::cos(th)) - bb * g2) / (t * g1);
    if (k < bound) {
      bound = k;
      theta = th;
    }
  }
  return bound;
}

}  // namespace

double delay_bound(const PassivityPoint& p) {
  double theta = 0.0;
  return std::max(0.0, frequency_condition(p, theta));
}

double delay_bound_frequency(const PassivityPoint& p) {
  double theta = 0.0;
  frequency_condition(p, theta);
  return theta;
}

double dither_bound(const PassivityPoint& p) {
  if (!(p.resolution > 0.0)) return std::numeric_limits<double>::infinity();
  const double a = p.resolution / 100.0;
  return std::max(0.0, 2.0 * p.coulomb / p.resolution +
                           4.0 * a * p.device_damping / (p.period_s * p.resolution) -
                           p.damping / p.period_s);
}

}  // namespace numen::sim
