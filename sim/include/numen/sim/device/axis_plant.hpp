#pragma once
/// @file axis_plant.hpp
/// The mechanics of one axis of an emulated haptic device (docs/device_plant.md): what turns
/// the torque numen commands into the motion its encoder reports. Per axis, in the axis's
/// generalized coordinate q (m for a prismatic axis, rad for a revolute one):
///
///   (m + m_x) q̈ = τ_a + f_x − (b + b_x) q̇ − f_f
///
/// - m: the axis's inertia (kg or kg·m²), m_x and b_x what the hand adds (PlantMotion);
/// - b: viscous damping (N·s/m or N·m·s/rad);
/// - τ_a: the torque the drive applies: the command held over the control period (zero-order
///   hold), delayed by `delay_periods` whole periods (a transport delay), through an optional
///   first-order current loop (τ_a → τ_c with time constant `current_lag_s`), saturated at
///   ±`max_torque`;
/// - f_x: the other forces on the axis (the hand, through the device kinematics), constant over
///   a step;
/// - f_f: Coulomb friction f_c with stiction, Karnopp's model (D. Karnopp, "Computer simulation
///   of stick-slip friction in mechanical dynamic systems", J. Dyn. Sys. Meas. Control 107(1),
///   1985) in its event-resolved form: a sliding axis feels f_c against its velocity; an axis
///   at rest stays at rest while |τ_a + f_x| ≤ f_c, and the friction then balances them
///   exactly; a sliding axis whose velocity reaches zero inside a step stops there (the
///   instant is solved exactly) and the rest of the step starts from rest.
///
/// step() integrates this exactly for inputs held constant over the step (the closed-form
/// solution of the linear part between friction events), so the plant's numerics do not
/// decide a passivity result; only the current loop's lag is averaged over the step (its exact
/// mean), which is exact as the step goes to zero. The energies that flow through the axis are
/// integrated exactly on the same solution (energy() below).
///
/// Construction validates and throws std::invalid_argument naming the bad setting; the rest is
/// noexcept and allocation free (fixed-size delay line).

#include <array>
#include <limits>

namespace numen::sim {

/// Longest transport delay an AxisPlant models, whole control periods.
inline constexpr int kMaxPlantDelayPeriods = 64;

/// One axis's mechanics (scene `[device.plant]`, one entry per axis; docs/device_plant.md).
struct AxisPlantSettings {
  double inertia = 0.0;        ///< m, kg or kg·m², finite and > 0.
  double damping = 0.0;        ///< b, N·s/m or N·m·s/rad, finite and >= 0.
  double coulomb = 0.0;        ///< f_c, N or N·m, finite and >= 0 (Karnopp 1985).
  double current_lag_s = 0.0;  ///< Current-loop time constant, s, finite and >= 0 (0: ideal).
  /// The drive's largest torque, N or N·m, > 0 (infinity: no saturation).
  double max_torque = std::numeric_limits<double>::infinity();
  int delay_periods = 0;       ///< Transport delay, periods, 0 .. kMaxPlantDelayPeriods.
};

/// Where the energy that went through an axis went since reset(), J (each exact for the
/// piecewise-constant inputs step() takes).
struct AxisPlantEnergy {
  double drive = 0.0;     ///< ∫ τ_a q̇ dt: work the drive did on the axis.
  double external = 0.0;  ///< ∫ f_x q̇ dt: work of the other forces (the hand).
  double friction = 0.0;  ///< ∫ f_c |q̇| dt >= 0: dissipated by Coulomb friction.
  /// ∫ (b + b_x) q̇² dt >= 0: dissipated by the viscous damping (the balance of the others and
  /// of the kinetic energy).
  double damping = 0.0;
};

/// One axis of an emulated device (see the file comment).
class AxisPlant {
 public:
  /// Throws std::invalid_argument naming the setting if one is out of its range (see
  /// AxisPlantSettings). The axis starts at rest at q = 0 with no torque commanded.
  explicit AxisPlant(const AxisPlantSettings& settings);

  /// Puts the axis at `q` with rate `qdot`, clears the delay line, the current loop and the
  /// energies.
  void reset(double q, double qdot) noexcept;
  /// The drive's command for the coming control period (N or N·m), held until the next call
  /// (ZOH); enters the delay line, so that the drive applies the command of `delay_periods`
  /// calls ago (0 before that many calls). A non-finite command is applied as 0.
  void command(double torque) noexcept;
  /// Advances the axis by `h` s (> 0; nothing for h <= 0) with `external` (N or N·m) acting on
  /// it and `extra_inertia`, `extra_damping` (>= 0) added to m and b, all held over the step.
  void step(double h, double external = 0.0, double extra_inertia = 0.0,
            double extra_damping = 0.0) noexcept;

  double q() const noexcept { return q_; }        ///< Position, m or rad.
  double qdot() const noexcept { return qdot_; }  ///< Rate, m/s or rad/s.
  /// The torque the drive applied over the last step (its mean; N or N·m).
  double applied_torque() const noexcept { return applied_; }
  /// true while the axis is held by stiction (at rest, |τ_a + f_x| <= f_c).
  bool stuck() const noexcept { return stuck_; }
  const AxisPlantEnergy& energy() const noexcept { return energy_; }
  const AxisPlantSettings& settings() const noexcept { return settings_; }

 private:
  /// Slides for `h` s under the net non-friction force `force` with friction `friction` (signed
  /// force, constant) on mass `m`, damping `b`: advances q_, qdot_ and the friction energy.
  void slide(double h, double force, double friction, double m, double b) noexcept;

  AxisPlantSettings settings_;
  double q_ = 0.0;
  double qdot_ = 0.0;
  double current_ = 0.0;   ///< The current loop's output at the end of the last step.
  double applied_ = 0.0;
  bool stuck_ = true;
  std::array<double, kMaxPlantDelayPeriods + 1> delay_line_{};
  int head_ = 0;           ///< Index of the newest command in delay_line_.
  double commanded_ = 0.0; ///< The command the drive follows now (delay_periods calls ago).
  AxisPlantEnergy energy_;
};

}  // namespace numen::sim
