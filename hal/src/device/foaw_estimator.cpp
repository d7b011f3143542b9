/// @file foaw_estimator.cpp
/// First-order adaptive windowing (end fit) velocity estimate of one encoder axis.

#include "numen/hal/device/foaw_estimator.hpp"

#include <algorithm>
#include <cmath>
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

  // Grow the window from 1 while every value inside lies within ±d of the end-fit line.
  const int longest = std::min(max_window_, count_ - 1);
  double slope = (y - value_back(1)) / (static_cast<double>(time_ns - time_back(1)) * 1e-9);
  int window = 1;
  for (int n = 2; n <= longest; ++n) {
    const double b = (y - value_back(n)) / (static_cast<double>(time_ns - time_back(n)) * 1e-9);
    bool inside = true;
    for (int j = 1; j < n && inside; ++j) {
      const double line = y - b * (static_cast<double>(time_ns - time_back(j)) * 1e-9);
      inside = std::abs(value_back(j) - line) <= noise_band_;
    }
    if (!inside) break;
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
