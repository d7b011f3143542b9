/// @file foaw_estimator.cpp
/// First-order adaptive windowing (end fit) velocity estimate of one encoder axis.

#include "numen/hal/device/foaw_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "numen/hal/device/axis.hpp"

namespace numen::hal {

FoawEstimator::FoawEstimator(int max_window, double noise_band, double max_rate,
                             bool wraps) noexcept
    : max_window_(std::clamp(max_window, 1, kFoawMaxWindow)),
      noise_band_(noise_band),
      max_rate_(max_rate),
      wraps_(wraps) {}

double FoawEstimator::value_back(int j) const noexcept {
  return values_[static_cast<std::size_t>((newest_ - j + kCapacity) % kCapacity)];
}

std::int64_t FoawEstimator::time_back(int j) const noexcept {
  return times_ns_[static_cast<std::size_t>((newest_ - j + kCapacity) % kCapacity)];
}

double FoawEstimator::update(double value, std::int64_t time_ns) noexcept {
  double y = value;
  if (count_ > 0) {
    if (time_ns <= time_back(0)) return rate_;
    y = value_back(0) + axis_difference(value, newest_raw_, wraps_);
    if (wraps_ && std::abs(y) > 1000.0) {
      // Rebase the unwrapped history by whole turns (differences are unchanged).
      const double shift = 2.0 * std::numbers::pi * std::round(y / (2.0 * std::numbers::pi));
      for (double& v : values_) v -= shift;
      y -= shift;
    }
    newest_ = (newest_ + 1) % kCapacity;
  }
  values_[static_cast<std::size_t>(newest_)] = y;
  times_ns_[static_cast<std::size_t>(newest_)] = time_ns;
  newest_raw_ = value;
  count_ = std::min(count_ + 1, kCapacity);
  if (count_ < 2) return rate_;

  // Grow the window from 1 while every value inside lies within ±d of the end-fit line. Value j
  // back is inside for a slope b iff |Δ_j − b τ_j| ≤ d (Δ_j = y − y_{k−j}, τ_j = t_k − t_{k−j}),
  // i.e. b ∈ [(Δ_j − d)/τ_j, (Δ_j + d)/τ_j]: the values inside a window bound its slope to the
  // intersection [lo, hi], narrowed by one value per growth (O(N) per update).
  // A value exactly on the band's edge is inside (|…| ≤ d): rounded values on a grid put many
  // there, so the edge is widened by 1e-9 d, far above the slopes' rounding errors.
  const double d = noise_band_ * (1.0 + 1e-9);
  const int longest = std::min(max_window_, count_ - 1);
  auto tau = [&](int j) { return static_cast<double>(time_ns - time_back(j)) * 1e-9; };
  double slope = (y - value_back(1)) / tau(1);
  int window = 1;
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  for (int n = 2; n <= longest; ++n) {
    const double tj = tau(n - 1), dj = y - value_back(n - 1);
    lo = std::max(lo, (dj - d) / tj);
    hi = std::min(hi, (dj + d) / tj);
    const double b = (y - value_back(n)) / tau(n);
    if (!(b >= lo && b <= hi)) break;
    slope = b;
    window = n;
  }
  window_ = window;
  rate_ = std::clamp(slope, -max_rate_, max_rate_);
  return rate_;
}

void FoawEstimator::reset() noexcept {
  values_ = {};
  times_ns_ = {};
  newest_ = 0;
  count_ = 0;
  newest_raw_ = 0.0;
  window_ = 0;
  rate_ = 0.0;
}

}  // namespace numen::hal
