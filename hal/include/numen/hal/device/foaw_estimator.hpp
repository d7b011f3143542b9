#pragma once
/// @file foaw_estimator.hpp
/// FoawEstimator: the velocity of one encoder axis from its accepted values by first-order
/// adaptive windowing, end-fit variant (FOAW-end; Janabi-Sharifi, Hayward & Chen, "Discrete-time
/// adaptive windowing for velocity estimation", IEEE Trans. Control Systems Technology 8(6),
/// 2000), bounded like RateEstimator (docs/target_velocity.md).
///
/// For accepted values y_k at bus timestamps t_k, a window of n intervals is the line through
/// the newest value and the one n samples back (the end-fit line):
///
///     b_n = (y_k − y_{k−n}) / (t_k − t_{k−n})                       slope of the window
///     L_n(t) = y_k − b_n (t_k − t)                                   the line through y_k
///     n is accepted if |y_{k−j} − L_n(t_{k−j})| ≤ d for j = 1 … n−1  every point in the band
///     n_k = the largest accepted n, grown from 1 and stopped at the first refusal
///           or at N (the maximum window)
///     q̇_k = clamp(b_{n_k}, −v_max, +v_max)
///
/// d is the noise band: a line the signal stays within ±d of cannot be told from it, so the
/// window grows while the motion is a line to within the noise (a long window: the noise's
/// effect, ≤ 2d / (t_k − t_{k−n}), shrinks) and shrinks when it bends (a short window: small
/// lag). Values rounded to a step q lie within ±q/2 of the motion: the default d is that half
/// count (DeviceConfig::foaw_noise_counts = 0.5, divided by the axis's counts_per_unit). The
/// end-fit line runs through two rounded values, so a point of a straight motion can lie up to
/// q from it: a band of one count lets the window grow much longer on fine encoders at high
/// rates (docs/architecture.md has both measured).
/// The paper's uniform T is replaced by the values' own timestamps, so a lost frame is weighted
/// by the time it spans, as in RateEstimator.
///
/// - Velocity bound: |q̇_k| ≤ v_max (the axis's max_speed; +∞ = none). A jump that passes the
///   sample checks refuses every window across it but n = 1: the bound alone limits it (one
///   period at v_max), and the window regrows from the jump as the values stay still.
/// - Lag: the slope of a line through y_k and y_{k−n} is the rate at t_k − (t_k − t_{k−n})/2
///   on a parabola: about half the window, which the band keeps short where the motion bends.
/// - Quantisation: on a window of n intervals at a constant Δt the estimate's rounding error is
///   at most q / (n Δt) (two values, each within ±q/2), so at most q/Δt (n = 1, the bare
///   difference) and typically ÷n.
/// - Wrapping axes: the history holds the unwrapped values (each new value is the previous
///   one plus the wrapped difference), rebased by whole turns when it grows past 1000 rad.
/// - Work: O(N) per value. Value j back is inside the band of a slope b iff
///   b ∈ [(Δ_j − d)/τ_j, (Δ_j + d)/τ_j] (Δ_j = y_k − y_{k−j}, τ_j = t_k − t_{k−j}), so the values
///   inside a window bound its slope to the intersection of their intervals, narrowed by one
///   value as the window grows by one. State: N + 1 values and timestamps.
///
/// Allocation free, noexcept, no locks; one instance per axis (InstrumentDevice's fixed arrays).
/// Not thread safe.

#include <array>
#include <cstdint>
#include <limits>

namespace numen::hal {

/// Largest FOAW window, in sample intervals: the capacity of FoawEstimator's history
/// (DeviceConfig::foaw_max_window is 1 … this).
inline constexpr int kFoawMaxWindow = 32;
/// Default noise band of FOAW, encoder counts: the quantisation half count.
inline constexpr double kDefaultFoawNoiseCounts = 0.5;

/// First-order adaptive window velocity estimate (end fit) of one axis (see the file comment).
class FoawEstimator {
 public:
  /// Window up to kFoawMaxWindow, noise band 0 (only exact lines widen the window), no bound,
  /// no wrapping.
  FoawEstimator() noexcept = default;
  /// Window up to `max_window` intervals (clamped into 1 … kFoawMaxWindow; 1 = the bounded
  /// bare backward difference), noise band `noise_band` (m or rad, >= 0), bound `max_rate`
  /// (m/s or rad/s, > 0, +∞ = none), `wraps`: wrapped differences in (−π, π]. Values are not
  /// checked here: validate(DeviceConfig) and validate_axis() do.
  FoawEstimator(int max_window, double noise_band, double max_rate, bool wraps) noexcept;

  /// Feeds the next accepted value (m or rad) and its bus timestamp (ns); returns the estimate
  /// q̇_k. The first value after construction or reset() only starts the history (the
  /// estimate stays 0). A timestamp not after the newest one leaves everything unchanged.
  double update(double value, std::int64_t time_ns) noexcept;

  /// Forgets the history and sets the estimate to 0.
  void reset() noexcept;

  /// The current estimate q̇_k, m/s or rad/s (0 before two values).
  double rate() const noexcept { return rate_; }
  /// True once a difference has been taken since construction or reset().
  bool has_rate() const noexcept { return window_ > 0; }
  /// Window n_k of the current estimate, intervals (0 before two values).
  int window() const noexcept { return window_; }
  /// Maximum window N, intervals.
  int max_window() const noexcept { return max_window_; }
  /// Noise band d, m or rad.
  double noise_band() const noexcept { return noise_band_; }
  /// Bound v_max, m/s or rad/s.
  double max_rate() const noexcept { return max_rate_; }

 private:
  static constexpr int kCapacity = kFoawMaxWindow + 1;  // N intervals need N + 1 values

  // The value and timestamp j samples back (0: the newest); j < count_.
  double value_back(int j) const noexcept;
  std::int64_t time_back(int j) const noexcept;

  int max_window_ = kFoawMaxWindow;
  double noise_band_ = 0.0;
  double max_rate_ = std::numeric_limits<double>::infinity();
  bool wraps_ = false;
  std::array<double, kCapacity> values_{};  // unwrapped, ring buffer
  std::array<std::int64_t, kCapacity> times_ns_{};
  int newest_ = 0;  // index of the newest entry
  int count_ = 0;   // entries held, 0 … kCapacity
  double newest_raw_ = 0.0;  // the newest value as given (wrapped)
  int window_ = 0;
  double rate_ = 0.0;
};

}  // namespace numen::hal
