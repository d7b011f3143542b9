#pragma once
/// @file study_stability_cases.hpp
/// The run driver, the verdict monitor and the case families of `numen study stability`
/// (study_stability.hpp): the building blocks of the study, public so that tests can run single
/// cases and check the monitor.

#include <algorithm>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/study_stability.hpp"

namespace numen::sim::stability {

/// +∞ and quiet NaN, for "no bound" and "not applicable".
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A row with the run's identity filled in (family, case, integrator name, step, mass,
/// stiffness, parameter and its name, ω h); Monitor::fill() adds the verdict.
StabilityRow make_row(const char* family, const char* case_name, core::Integrator integrator,
                      double h, double mass_kg, double stiffness, double parameter,
                      const char* parameter_name, double omega_dt);

/// Watches one run and finds its first failing step (the verdict of study_stability.hpp).
class Monitor {
 public:
  /// `penetration_bound` (m) and `drift_bound` (m, joint position error) may be +∞.
  /// `planned_steps` sets the quarters of the growth ratio. With `travel_mass` > 0 (kg) the
  /// penetration bound grows by one step of travel at the fastest speed the energy allows,
  /// h √(2 (E₀ + W_in) / travel_mass), h = `dt` (s).
  Monitor(const StabilityLimits& limits, double penetration_bound, double drift_bound,
          std::int64_t planned_steps, double travel_mass = 0.0, double dt = 0.0);
  /// Energy at the start (J).
  void start(double energy0) noexcept;
  /// After step `step` (1-based): `energy` (J), cumulated input work (J), the step's deepest
  /// penetration (m) and joint drift (m), the core's rollback counter. Returns false once diverged.
  bool observe(std::int64_t step, double energy, double work_in, double penetration, double drift,
               std::int64_t nonfinite_steps) noexcept;
  /// Marks a failure decided by the caller (torque, input) at `step`.
  void fail(std::int64_t step, const char* reason) noexcept;
  bool diverged() const noexcept { return diverged_step_ >= 0; }
  /// E maximum of the last quarter over that of the second quarter (+∞ when it diverged early).
  double growth_ratio() const noexcept;
  /// Fills the verdict fields of `row` (stable … penetration_bound_m, steps).
  void fill(StabilityRow& row) const;

 private:
  StabilityLimits limits_;
  double penetration_bound_, drift_bound_, travel_mass_, dt_;
  double bound_now_ = 0.0;
  std::int64_t planned_;
  double energy0_ = 0.0, energy_ref_ = 0.0, ratio_max_ = 0.0, penetration_max_ = 0.0;
  double q2_max_ = 0.0, q4_max_ = 0.0, drift_max_ = 0.0;
  std::int64_t steps_ = 0, diverged_step_ = -1, nonfinite_ = 0;
  const char* reason_ = "";
};

/// Runs `steps` steps of `data` under `model`: before step k (0-based) `inputs(k, data)` writes
/// the device inputs; the monitor sees the energy, the input work and the penetration after
/// each step. Stops at the first failing step. Returns the steps run.
template <class Inputs>
std::int64_t drive(const core::Model& model, core::Data& data, std::int64_t steps, Inputs&& inputs,
                   Monitor& monitor) {
  double energy = stored_energy(model, data);
  double work = 0.0;
  monitor.start(energy);
  std::int64_t k = 0;
  for (; k < steps; ++k) {
    inputs(k, data);
    const double with_inputs = stored_energy(model, data);
    work += input_work(model, data, energy, with_inputs);
    core::step(model, data);
    energy = stored_energy(model, data);
    double penetration = data.max_penetration;
    for (const core::NetOutput& o : data.nets)
      penetration = std::max(penetration, o.max_penetration);
    if (!monitor.observe(k + 1, energy, work, penetration, data.max_joint_drift,
                         data.nonfinite_steps))
      return k + 1;
  }
  return k;
}

/// A one-material model without gravity (materials: "default", `pair`).
core::Model empty_model(const core::MaterialPair& pair = {});

/// Case families. Each returns its rows; `progress(label)` is called after every run.
using Tick = std::function<void(const std::string&)>;

/// "coupling": the k × m × h grid, ζ = 0 and 0.85 (study_stability_rigid.cpp).
std::vector<StabilityRow> coupling_family(const StabilityOptions& o, const Tick& tick);
/// Number of runs coupling_family() makes (for the progress bar).
std::int64_t coupling_runs(const StabilityOptions& o);
/// One run of the coupling grid: body of mass m (kg) on a spring k (N/m) of damping ratio ζ,
/// released at rest 10 mm from the target, `steps` steps of h.
StabilityRow coupling_run(core::Integrator integrator, double h, double m, double k, double zeta,
                          std::int64_t steps, const StabilityLimits& limits,
                          Monitor* monitor_out = nullptr);
/// "contact": the k_c × h × m sweep (study_stability_rigid.cpp).
std::vector<StabilityRow> contact_family(const StabilityOptions& o, const Tick& tick);
/// Number of runs contact_family() makes (for the progress bar).
std::int64_t contact_runs(const StabilityOptions& o);
/// One contact run: sphere of mass m on a plane of stiffness k_c and damping ratio zeta_c.
StabilityRow contact_run(core::Integrator integrator, double h, double m, double k_c, double zeta_c,
                         std::int64_t steps, const StabilityLimits& limits);
/// "boundary": the symplectic Euler's limit for ζ = 0 and 0.85 (study_stability_rigid.cpp).
std::vector<StabilityBoundary> boundary_family(const StabilityOptions& o, const Tick& tick);
/// Teleport, spin and capacity cases of "extreme" (study_stability_extreme.cpp).
std::vector<StabilityRow> rigid_extreme_cases(const StabilityOptions& o, const Tick& tick);
/// Number of runs rigid_extreme_cases() makes (for the progress bar).
std::int64_t rigid_extreme_runs(const StabilityOptions& o);
/// "articulation": mass ratios in a revolute pair (study_stability_articulation.cpp).
std::vector<StabilityRow> articulation_family(const StabilityOptions& o, const Tick& tick);
/// Number of runs articulation_family() makes (for the progress bar).
std::int64_t articulation_runs(const StabilityOptions& o);
/// The deformable jump, the trocar at zero insertion and the non-finite bus input of
/// "extreme" (study_stability_scene.cpp). `scene_dir`: the shipped scenes. Cases whose part
/// this build left out (the jump: nets; the others: the trocar's joints) are not run; each
/// gets one "case: reason" line in `skipped`.
std::vector<StabilityRow> scene_extreme_cases(const StabilityOptions& o,
                                              const std::string& scene_dir, const Tick& tick,
                                              std::vector<std::string>& skipped);
/// Progress ticks scene_extreme_cases() makes: 20 per deformable run, 5 per loop run.
std::int64_t scene_extreme_runs(const StabilityOptions& o);

/// "scenes": every shipped scene (`scene_dir`/*.toml) through run_scene() with its contact
/// stiffness and, separately, its coupling stiffness swept to 1e12 N/m (study_stability_scenes.cpp).
/// A scene this build cannot load (NUMEN_WITH_* options) gets one "scenes <name>: reason" line in
/// `skipped`.
std::vector<StabilityRow> scene_stiffness_family(const StabilityOptions& o,
                                                 const std::string& scene_dir, const Tick& tick,
                                                 std::vector<std::string>& skipped);
/// Number of runs scene_stiffness_family() makes (for the progress bar).
std::int64_t scene_stiffness_runs(const StabilityOptions& o, const std::string& scene_dir);

/// The integrators of `o` (all three when empty).
const std::vector<core::Integrator>& integrators_of(const StabilityOptions& o);

}  // namespace numen::sim::stability
