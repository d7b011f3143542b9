#pragma once
/// @file study_stability_cases.hpp
/// The run driver, the verdict monitor and the case families of `numen study stability`
/// (study_stability.hpp): the building blocks of the study, public so that tests can run single
/// cases and check the monitor.

#include <algorithm>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_shard.hpp"
#include "numen/sim/study/study_stability.hpp"

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

/// Work units of one case of each kind, ≈ its CPU cost relative to a 2000-step grid run (the
/// progress bar's estimate).
inline constexpr double kGridWeight = 1.0, kExtremeWeight = 5.0, kArticulationWeight = 10.0,
                        kSceneWeight = 20.0, kBoundaryWeight = 1500.0, kStiffSceneWeight = 40.0;

/// One case of the study's plan: what `--list` prints (StudyCase), its work units and the run,
/// which appends its rows (or boundary) to a result. The run depends on the case only.
struct PlannedCase {
  StudyCase info;
  double weight = 1.0;
  std::function<void(StabilityResult&)> run;
};

/// The study's cases in the order of the one-process run (PlannedCase::info.index = position),
/// and the cases this build left out, "case: reason" (study::missing_parts()).
struct Plan {
  std::vector<PlannedCase> cases;
  std::vector<std::string> skipped;
  /// Appends a case with the next index.
  void add(const char* family, std::string name, std::string parameters, double weight,
           std::function<void(StabilityResult&)> run);
};

/// "integrator=<name> key=value …" (values %.6g): StudyCase::parameters of a stability case.
std::string case_parameters(core::Integrator integrator,
                            std::initializer_list<std::pair<const char*, double>> values);

/// The whole plan of `o`: its families in the order of stability_family_names(). Throws
/// InputError for an unknown family or "articulation" asked for in a build without joints, and
/// what load_scene() throws for the shipped scenes (`scene_dir`: o.scene_dir or the source
/// tree's).
Plan plan_study(const StabilityOptions& o);

/// "coupling": the k × m × h grid, ζ = 0 and 0.85 (study_stability_rigid.cpp).
void plan_coupling(const StabilityOptions& o, Plan& plan);
/// One run of the coupling grid: body of mass m (kg) on a spring k (N/m) of damping ratio ζ,
/// released at rest 10 mm from the target, `steps` steps of h.
StabilityRow coupling_run(core::Integrator integrator, double h, double m, double k, double zeta,
                          std::int64_t steps, const StabilityLimits& limits,
                          Monitor* monitor_out = nullptr);
/// "contact": the k_c × h × m sweep (study_stability_rigid.cpp).
void plan_contact(const StabilityOptions& o, Plan& plan);
/// One contact run: sphere of mass m on a plane of stiffness k_c and damping ratio zeta_c.
StabilityRow contact_run(core::Integrator integrator, double h, double m, double k_c, double zeta_c,
                         std::int64_t steps, const StabilityLimits& limits);
/// "boundary": the symplectic Euler's limit for ζ = 0 and 0.85, one case each
/// (study_stability_rigid.cpp).
void plan_boundary(const StabilityOptions& o, Plan& plan);
/// The boundary measurement of one damping ratio ζ (a sweep in ω h, then bisection).
StabilityBoundary boundary_run(double zeta, bool quick, const StabilityLimits& limits);
/// Teleport, spin and capacity cases of "extreme" (study_stability_extreme.cpp).
void plan_rigid_extreme(const StabilityOptions& o, Plan& plan);
/// "articulation": mass ratios in a revolute pair (study_stability_articulation.cpp).
void plan_articulation(const StabilityOptions& o, Plan& plan);
/// The deformable jump, the trocar at zero insertion and the non-finite bus input of
/// "extreme" (study_stability_scene.cpp). `scene_dir`: the shipped scenes. Cases whose part
/// this build left out (the jump: nets; the others: the trocar's joints) are not planned; each
/// gets one "case: reason" line in Plan::skipped.
void plan_scene_extreme(const StabilityOptions& o, const std::string& scene_dir, Plan& plan);
/// Per-spring constants of a net (core::NetSettings' masses, springs and ties) for "organ-plunge-
/// per-spring".
struct PerSpringOrgan {
  double mass = 0.0;               ///< kg, all nodes.
  double stiffness = 0.0;          ///< N/m, structural springs.
  double damping = 0.0;            ///< N·s/m.
  double bending_stiffness = 0.0;  ///< N/m.
  double bending_damping = 0.0;    ///< N·s/m.
  double tie_stiffness = 0.0;      ///< N/m per node.
  double tie_damping = 0.0;        ///< N·s/m per node.
};

/// "organ-plunge" of "extreme" (study_stability_organ.cpp): the organ of `scene` (a net on an
/// anchored body; sim/scenes/default.toml) as the scene gives it (by its material, rebuilt from its
/// surface as the scene loader built it, or per spring) and a one-sphere god-object of the held
/// body's mass and coupling whose target jumps 40 mm into it in one period; `horizon` s of steps
/// of `h`. With `per_spring` ("organ-plunge-per-spring"), the organ's surface net is given those
/// constants per spring instead. Throws std::invalid_argument for a scene without an organ or a
/// held body, or a surface the net refuses.
StabilityRow organ_run(const Scene& scene, core::Integrator integrator, double h,
                       const StabilityLimits& limits, double horizon,
                       const PerSpringOrgan* per_spring = nullptr);

/// The shipped organ's material (sim/scenes/default.toml; docs/tissue.md, "The shipped organ keeps
/// its feel"): E = 100 kPa, ν = 0.45, ρ = 1000 kg/m³, β = 1 ms, ℓ = 20 mm, strain stiffening b = 1.
inline constexpr core::NetMaterial kShippedOrganMaterial{100e3, 0.45, 1000.0, 1e-3, 0.020, 1.0};
/// The constants per spring sim/scenes/default.toml's organ had before it was given its material
/// (issue 67; docs/organs.md, "Organs"): 70 g, structural springs 200 N/m and 0.1 N·s/m, bending
/// springs 50 N/m and 0.03 N·s/m, ties 100 N/m and 0.17 N·s/m per node.
inline constexpr PerSpringOrgan kShippedPerSpringOrgan{0.07, 200.0, 0.1, 50.0, 0.03, 100.0, 0.17};
/// "scenes": every shipped scene (`scene_dir`/*.toml) through run_scene() with its contact
/// stiffness and, separately, its coupling stiffness swept to 1e12 N/m
/// (study_stability_scenes.cpp). A scene this build cannot load (NUMEN_WITH_* options) gets one
/// "scenes <name>: reason" line in Plan::skipped.
void plan_scene_stiffness(const StabilityOptions& o, const std::string& scene_dir, Plan& plan);

/// Joint drift (m, largest joint-constraint error over the run) above which a case with joints
/// is unstable: the articulation cases and the shipped scenes with joints.
inline constexpr double kDriftBound = 0.005;

/// The integrators of `o` (all three when empty).
const std::vector<core::Integrator>& integrators_of(const StabilityOptions& o);

}  // namespace numen::sim::stability
