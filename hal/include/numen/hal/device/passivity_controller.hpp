#pragma once
/// @file passivity_controller.hpp
/// hal::PassivityController: the time-domain passivity observer and controller of Hannaford &
/// Ryu (IEEE T-RA 18(1), 2002, "Time-domain passivity control of haptic interfaces") on the
/// port between the controller and an impedance device, one port per axis
/// (docs/passivity.md, "Passivity controller").
///
/// Port variables of axis i in period n (impedance causality: the device imposes the flow, the
/// rendered environment answers with the effort):
///   v(n)  the axis rate (m/s or rad/s): ImpedanceDevice::write() gives the backward
///         difference (q(n) − q(n−1))/T of the axis values, as the paper does — the period's
///         displacement Δq the sample decoded (DeviceSample::dq) over T;
///   τ(n)  the axis torque the rendered environment sends to the device (N or N·m);
///   f(n) = −τ(n)  the effort the device's motion meets at the environment's port, so that
///         f·v is the power flowing INTO the rendered environment (a virtual spring being
///         compressed, τ = −k x with x, v > 0, has f v = k x v > 0: it stores energy).
/// Observer (with the controller's own dissipation of the earlier periods):
///   E(n) = E(n−1) + T f(n) v(n) = E(n−1) − T τ(n) v(n),   E(0) = 0.
/// E(n) < 0: the rendered environment (with the sampling, the rate estimate and the hold) has
/// produced energy on that axis since the start. Controller: when
/// E(n) < 0 and |v(n)| > v_min, a variable damper
///   α(n) = −E(n) / (T v(n)²)   (N·s/m or N·m·s/rad),   τ(n) ← τ(n) − α(n) v(n),
/// which dissipates exactly T α(n) v(n)² = −E(n) over the period; that energy is put back:
///   E(n) ← E(n) + T α(n) v(n)² = 0.
/// For |v| <= v_min (velocity_threshold) the controller does not act (α would be unbounded and
/// the rate estimate is noise there); E keeps its deficit until the axis moves.
///
/// The torque the drive finally receives may differ from the controlled one (the clamp and
/// the soft start of ImpedanceDevice::write() come after); sent() books the difference,
/// E(n) ← E(n) − T (τ_sent − τ_controlled) v(n), so E is the energy of what was sent.
///
/// The sampled product T τ(n) v(n) does not see the energy a held torque delivers while the
/// axis moves on to q(n+1): it books a virtual spring as passive over any closed path, so the
/// controller does not lift a wall beyond Colgate & Schenkel's 2b/T (docs/passivity.md
/// "Passivity controller", measured).
///
/// Energy limit (optional, E_max, J; +∞ = the paper's observer): after each update
///   E(n) ← min(E(n), E_max),
/// the upper bound of an energy tank (Franken, Stramigioli, Misra, Secchi, Macchelli, IEEE T-RO
/// 27(4), 2011). The paper's observer counts every joule the environment has dissipated since
/// the start (a god-object's contacts, a coupling's damper) as margin, so a render that later
/// produces energy is not damped until it has given all of it back; with E_max the margin is
/// at most E_max. Capping E only ever lowers it, so the controlled port stays passive; the
/// price is more damping (less transparency) for a smaller E_max.
///
/// Axes are chosen by a bit mask (bit i: axis i); the others are neither observed nor
/// controlled. Every member except the constructor is noexcept, allocation free and lock free.
/// Not thread safe: the real-time thread that owns the device owns it.

#include <array>
#include <cstdint>
#include <limits>
#include <span>

#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// The smallest |v| at which the controller acts, default (m/s or rad/s): 1 mm/s on a
/// prismatic axis, 1 mrad/s on a revolute one.
inline constexpr double kDefaultPassivityVelocityThreshold = 1e-3;

/// Settings of one device's PassivityController (DeviceConfig::passivity; scene section
/// `[device.passivity]`, docs/scenes.md).
struct PassivitySettings {
  /// Observe and control (false: ImpedanceDevice::write() leaves the torques alone).
  bool enabled = false;
  /// Bit i: axis i is observed and controlled (bits >= the axis count are ignored).
  std::uint32_t axis_mask = 0;
  /// v_min, m/s or rad/s, finite and >= 0: the controller acts only for |v| > v_min.
  double velocity_threshold = kDefaultPassivityVelocityThreshold;
  /// E_max, J, > 0 (+∞: no limit, the paper's observer): the most energy E_i may hold.
  double energy_limit = std::numeric_limits<double>::infinity();
};

/// Counters of a PassivityController since construction or reset().
struct PassivityCounters {
  /// apply() calls in which the controller added damping on at least one axis.
  std::uint64_t acting_periods = 0;
  /// Energy the controller's dampers dissipated, Σ T α v² over every axis and period (J).
  double dissipated_j = 0.0;
  /// Per axis: periods the controller acted on the axis (entries >= n are 0).
  std::array<std::uint64_t, kMaxAxes> axis_acting_periods{};
};

/// The passivity observer and controller of one device's axes (see the file comment).
class PassivityController {
 public:
  /// Controls nothing (num_axes() == 0).
  PassivityController() = default;
  /// `num_axes` in [0, kMaxAxes], `period_s` T > 0 and finite, `axis_mask` the axes controlled,
  /// `velocity_threshold` v_min >= 0 and finite, `energy_limit` E_max > 0 (+∞: none). Throws
  /// std::invalid_argument otherwise.
  PassivityController(int num_axes, double period_s, std::uint32_t axis_mask,
                      double velocity_threshold = kDefaultPassivityVelocityThreshold,
                      double energy_limit = std::numeric_limits<double>::infinity());
  /// The same from a device's settings (PassivitySettings::enabled is not read).
  PassivityController(int num_axes, double period_s, const PassivitySettings& settings)
      : PassivityController(num_axes, period_s, settings.axis_mask, settings.velocity_threshold,
                            settings.energy_limit) {}

  /// One period: for every axis i < num_axes() in the mask and in `allowed` (bit i), observes
  /// E_i with torque[i] and rate[i] and, if E_i < 0 and |rate[i]| > v_min, adds −α v to
  /// torque[i] (in place). Entries missing from `torque` / `rate` count as 0; non-finite values
  /// skip the axis (the caller's gate handles them). Returns the number of axes it acted on.
  int apply(std::span<double> torque, std::span<const double> rate,
            std::uint32_t allowed = ~0u) noexcept;
  /// Books what was sent after apply() (see the file comment): E_i −= T (sent[i] − τ_i) v_i on
  /// the axes the last apply() observed, τ_i the torque apply() left.
  void sent(std::span<const double> sent_torque) noexcept;

  /// E_i, J: energy that has flowed into the rendered environment on axis i (0 for an axis
  /// outside [0, num_axes()) or not controlled).
  double energy(int axis) const noexcept;
  /// α_i of the last apply(), N·s/m or N·m·s/rad (0: the controller did not act).
  double damping(int axis) const noexcept;
  /// Counters since construction or reset().
  const PassivityCounters& counters() const noexcept { return counters_; }
  int num_axes() const noexcept { return n_; }
  std::uint32_t axis_mask() const noexcept { return mask_; }
  double period_s() const noexcept { return period_; }
  /// E = 0 and α = 0 on every axis, counters zeroed.
  void reset() noexcept;

 private:
  int n_ = 0;
  double period_ = 1e-3;
  std::uint32_t mask_ = 0;
  double v_min_ = kDefaultPassivityVelocityThreshold;
  double e_max_ = std::numeric_limits<double>::infinity();
  std::array<double, kMaxAxes> energy_{};
  std::array<double, kMaxAxes> alpha_{};
  // The last apply(): the torque it left and the rate it used, per observed axis (bit mask).
  std::array<double, kMaxAxes> torque_{};
  std::array<double, kMaxAxes> rate_{};
  std::uint32_t observed_ = 0;
  PassivityCounters counters_;
};

}  // namespace numen::hal
