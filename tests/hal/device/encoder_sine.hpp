#pragma once
// A 2 Hz sine on the default trocar's pivot encoder (0.3 rad, 2^14 counts per turn) fed to two
// rate estimators of one kind — one given the exact values, one the quantised ones — for the
// noise, lag and gain tests of RateEstimator and FoawEstimator (simulated time only).

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "numen/hal/device/axis.hpp"
#include "test_constants.hpp"

namespace numen::test::encoder_sine {

/// Counts per radian of the default trocar's pivot encoder (2^14 per turn).
inline constexpr double kCountsPerRad = 16384.0 / (2.0 * kPi);
/// One count, rad.
inline constexpr double kCount = 1.0 / kCountsPerRad;

struct SineRun {
  double noise_max = 0.0;  // max |estimate(quantised) − estimate(exact values)|, rad/s
  double noise_rms = 0.0;
  double lag_s = 0.0;      // phase delay of the estimate (exact values) behind the true rate
  double gain = 0.0;       // its amplitude / the true rate's
  double error_rms = 0.0;  // rms of estimate(quantised) − true rate over the last 2 s, rad/s
};

/// x(t) = A sin(2π f t) sampled every dt for 3 s; `make()` builds a fresh estimator (an object
/// with update(value, time_ns) returning the estimate). The estimate of the exact values is
/// fitted with a cos + b sin over the last 2 s (whole periods) for its gain and phase delay.
template <class Make>
SineRun run_sine(Make make, double dt) {
  hal::AxisConfig axis;
  axis.counts_per_unit = kCountsPerRad;
  axis.min = -1.2;
  axis.max = 1.2;
  constexpr double kA = 0.3, kF = 2.0;
  const double w = 2.0 * kPi * kF;
  auto exact = make();
  auto quantised = make();
  const auto dt_ns = static_cast<std::int64_t>(std::llround(dt * 1e9));
  const int n = static_cast<int>(std::llround(3.0 / dt));
  const int fit_from = static_cast<int>(std::llround(1.0 / dt));
  SineRun out;
  double scc = 0, sss = 0, scs = 0, svc = 0, svs = 0, sq = 0, se = 0;
  int count = 0;
  for (int k = 0; k <= n; ++k) {
    const std::int64_t t_ns = k * dt_ns;
    const double t = static_cast<double>(t_ns) * 1e-9;
    const double x = kA * std::sin(w * t);
    const double xq = hal::counts_to_value(axis, hal::value_to_counts(axis, x));
    const double ve = exact.update(x, t_ns);
    const double vq = quantised.update(xq, t_ns);
    out.noise_max = std::max(out.noise_max, std::abs(vq - ve));
    sq += (vq - ve) * (vq - ve);
    if (k >= fit_from) {
      const double c = std::cos(w * t), s = std::sin(w * t);
      scc += c * c;
      sss += s * s;
      scs += c * s;
      svc += ve * c;
      svs += ve * s;
      const double e = vq - kA * w * c;
      se += e * e;
      ++count;
    }
  }
  out.noise_rms = std::sqrt(sq / (n + 1));
  out.error_rms = std::sqrt(se / count);
  // Least squares ve ≈ a cos(wt) + b sin(wt); the true rate is A w cos(wt).
  const double det = scc * sss - scs * scs;
  const double a = (svc * sss - svs * scs) / det;
  const double b = (svs * scc - svc * scs) / det;
  // a cos + b sin = G A w cos(w t − φ): a = G A w cos φ, b = G A w sin φ.
  out.gain = std::hypot(a, b) / (kA * w);
  out.lag_s = std::atan2(b, a) / w;
  return out;
}

}  // namespace numen::test::encoder_sine
