#pragma once
/// @file rate_estimator.hpp
/// RateEstimator: the velocity of one encoder axis from its accepted values — a bounded,
/// first-order low-pass filtered backward difference, discretised exactly for each actual
/// sample interval (docs/target_velocity.md). Its output is the
/// axis rate q̇ behind the target twist J(q) q̇ that the coupling's damper (paper Eq. 2) and the
/// feedback's damper (Eq. 8) use.
///
/// For accepted values x_k at bus timestamps t_k (Δt_k = t_k − t_{k−1} > 0):
///
///     u_k = clamp((x_k ⊖ x_{k−1}) / Δt_k, −v_max, +v_max)       bounded backward difference
///     α_k = 1 − exp(−2π f_c Δt_k)                                exact step of the filter
///     v_k = v_{k−1} + α_k (u_k − v_{k−1}),   v_0 = 0               first-order low-pass
///
/// ⊖ is the plain difference, or the wrapped one (−π, π] on a wrapping axis. α_k is the exact
/// zero-order-hold discretisation of dv/dt = (u − v)/τ with τ = 1/(2π f_c), so a late or lost
/// frame (a longer Δt) is weighted by the time it covers and the cutoff means the same at
/// 1 kHz and 10 kHz. f_c = +∞ gives α = 1: the bare backward difference (bounded).
///
/// - Velocity bound: |v_k| ≤ v_max (the axis's AxisConfig::max_speed; +∞ = no bound) — every
///   u_k is clamped and v_k is a convex combination of them and v_0 = 0. A jump that passes
///   the sample checks (a tracker glitch, a re-grasp) feeds the filter at most v_max: its
///   whole contribution to ∫v dt is at most v_max Δt, not the jump.
/// - Lag: at frequencies f ≪ f_c the estimate is the true rate delayed by
///   group_delay_s(f_c, Δt) = Δt / (exp(Δt/τ) − 1) + Δt/2 ≈ τ (the filter's delay plus the
///   difference's half sample); its gain is 1/√(1 + (f/f_c)²).
/// - Quantisation: values rounded to a step q (error within ±q/2) move the estimate by at most
///   quantisation_bound(f_c, Δt, q) = α q / Δt ≈ 2π f_c q at a constant Δt (the filter's
///   impulse response on (e_k − e_{k−1})/Δt sums to 2α/Δt in absolute value), where the bare
///   difference moves up to q/Δt: ×(1/α) less, 32× at 10 kHz and the default 50 Hz.
///
/// Default cutoff kDefaultVelocityCutoffHz = 50 Hz: τ = 3.2 ms, about twice the default
/// scene's coupling frequency (√(k_t/m) = 141 rad/s, 22.5 Hz), so hand motion (below ~10 Hz)
/// passes with a gain above 0.98, while the quantisation bound of the default trocar's
/// 14-bit pivots is 0.12 rad/s at any rate (bare difference: 0.38 rad/s at 1 kHz, 3.8 rad/s
/// at 10 kHz). The alternative, first-order adaptive windowing, is FoawEstimator
/// (foaw_estimator.hpp); DeviceConfig::velocity_estimator picks one, and docs/target_velocity.md
/// compares the three on the same cases.
///
/// Allocation free, noexcept, no locks; one instance per axis (InstrumentDevice's fixed
/// arrays). Not thread safe.

#include <cstdint>
#include <limits>

namespace numen::hal {

/// Default cutoff f_c of the encoder velocity filter, Hz (DeviceConfig::velocity_cutoff_hz).
inline constexpr double kDefaultVelocityCutoffHz = 50.0;

/// Bounded first-order filtered backward difference of one axis (see the file comment).
class RateEstimator {
 public:
  /// Bare backward difference: f_c = +∞, no bound, no wrapping.
  RateEstimator() noexcept = default;
  /// Cutoff `cutoff_hz` (> 0, +∞ = unfiltered), bound `max_rate` (m/s or rad/s, > 0, +∞ = none),
  /// `wraps`: wrapped differences in (−π, π]. Values are not checked here:
  /// validate(DeviceConfig) and validate_axis() do.
  RateEstimator(double cutoff_hz, double max_rate, bool wraps) noexcept;

  /// Feeds the next accepted value (m or rad) and its bus timestamp (ns); returns the estimate
  /// v_k. The first value after construction or reset() only sets the base (the estimate
  /// stays 0). A timestamp not after the previous one leaves everything unchanged (the next
  /// value's difference covers it).
  double update(double value, std::int64_t time_ns) noexcept;

  /// Forgets the base value and sets the estimate to 0.
  void reset() noexcept;

  /// The current estimate v_k, m/s or rad/s (0 before two values).
  double rate() const noexcept { return rate_; }
  /// True once a difference has been taken since construction or reset().
  bool has_rate() const noexcept { return has_rate_; }
  /// Cutoff f_c, Hz.
  double cutoff_hz() const noexcept { return cutoff_hz_; }
  /// Bound v_max, m/s or rad/s.
  double max_rate() const noexcept { return max_rate_; }

  /// α = 1 − exp(−2π f_c Δt) (1 for f_c = +∞; 0 for Δt <= 0).
  static double smoothing(double cutoff_hz, double dt_s) noexcept;
  /// Low-frequency group delay of the estimate at a constant sample interval Δt, s:
  /// Δt / (exp(2π f_c Δt) − 1) + Δt/2 (Δt/2 for f_c = +∞); ≈ 1/(2π f_c) for Δt ≪ 1/f_c.
  static double group_delay_s(double cutoff_hz, double dt_s) noexcept;
  /// Largest change of the estimate that rounding the values to a step `q` (error ±q/2) can
  /// cause at a constant Δt: α q / Δt (units of q per second).
  static double quantisation_bound(double cutoff_hz, double dt_s, double q) noexcept;

 private:
  double cutoff_hz_ = std::numeric_limits<double>::infinity();
  double max_rate_ = std::numeric_limits<double>::infinity();
  bool wraps_ = false;
  bool has_base_ = false;
  bool has_rate_ = false;
  double base_value_ = 0.0;
  std::int64_t base_time_ns_ = 0;
  double rate_ = 0.0;
};

}  // namespace numen::hal
