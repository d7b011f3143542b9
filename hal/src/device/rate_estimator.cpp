/// @file rate_estimator.cpp
/// Bounded first-order filtered backward difference of one encoder axis.

#include "numen/hal/device/rate_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "numen/hal/device/axis.hpp"

namespace numen::hal {

RateEstimator::RateEstimator(double cutoff_hz, double max_rate, bool wraps) noexcept
    : cutoff_hz_(cutoff_hz), max_rate_(max_rate), wraps_(wraps) {}

double RateEstimator::smoothing(double cutoff_hz, double dt_s) noexcept {
  if (!(dt_s > 0.0)) return 0.0;
  if (std::isinf(cutoff_hz)) return 1.0;
  return -std::expm1(-2.0 * std::numbers::pi * cutoff_hz * dt_s);
}

double RateEstimator::group_delay_s(double cutoff_hz, double dt_s) noexcept {
  if (std::isinf(cutoff_hz)) return 0.5 * dt_s;
  return dt_s / std::expm1(2.0 * std::numbers::pi * cutoff_hz * dt_s) + 0.5 * dt_s;
}

double RateEstimator::quantisation_bound(double cutoff_hz, double dt_s, double q) noexcept {
  return smoothing(cutoff_hz, dt_s) * q / dt_s;
}

double RateEstimator::update(double value, std::int64_t time_ns) noexcept {
  if (!has_base_) {
    base_value_ = value;
    base_time_ns_ = time_ns;
    has_base_ = true;
    return rate_;
  }
  const double dt = static_cast<double>(time_ns - base_time_ns_) * 1e-9;
  if (!(dt > 0.0)) return rate_;
  const double u =
      std::clamp(axis_difference(value, base_value_, wraps_) / dt, -max_rate_, max_rate_);
  const double a = smoothing(cutoff_hz_, dt);
  rate_ = a >= 1.0 ? u : rate_ + a * (u - rate_);
  base_value_ = value;
  base_time_ns_ = time_ns;
  has_rate_ = true;
  return rate_;
}

void RateEstimator::reset() noexcept {
  has_base_ = false;
  has_rate_ = false;
  base_value_ = 0.0;
  base_time_ns_ = 0;
  rate_ = 0.0;
}

}  // namespace numen::hal
