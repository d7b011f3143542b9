/// @file study_stability_scenes.cpp
/// Family "scenes" of `numen study stability` (study_stability.hpp): every shipped scene
/// (sim/scenes/*.toml) that `numen run` runs (not probe.toml, which has no trajectory: a scene
/// stepped by its caller, Scene::run_missing) run as `numen run` runs it (run_scene(): simulated bus, encoders, device
/// checks, the control loop, the core), with one stiffness swept over decades up to 1e12 N/m:
///  - "contact-stiffness": every material pair's penalty stiffness k_c (bodies' and net nodes'
///    contacts), damping and friction as shipped;
///  - "coupling-stiffness": every body's translational coupling stiffness k_t (Eq. 2 / Eq. 6;
///    bodies without one keep none), its damping from the scenes' ratio ζ = 0.85,
///    γ_t = 2 ζ √(m k_t); the admittance scene's probe has no spring (the measured force drives
///    it), so there the device-side hand stiffness is what the wrench comes from and the row
///    sweeps the other bodies' springs only (none: the run is the shipped one).
/// Verdict of a run (from its RunSummary): stable when no step was rolled back as non-finite
/// (core::Data::nonfinite_steps = 0), the deepest contact of the tool and of any body is at most
/// penetration_factor × the deepest the hand itself went (the tool's spheres placed at the
/// device's targets: the god-object, pulled by springs toward the hand and pushed out by the
/// contacts, does not go deeper than the hand in equilibrium; a suddenly loaded undamped contact
/// overshoots to 2×) plus 1 mm (one period of travel at 1 m/s, faster than any recorded hand),
/// no free body faster than 10 m/s and joint drift below 5 mm (as the loop cases of "extreme").
/// The note gives the contacts clamped by the core's time-constant floor
/// (core::SolverSettings::contact_max_omega_dt) and the free-space tracking error.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim::stability {
namespace {

constexpr double kSlack = 0.001;        // m: one 1 ms period at 1 m/s
constexpr double kMaxFreeSpeed = 10.0;  // m/s
constexpr double kZeta = 0.85;          // the scenes' coupling damping ratio

std::vector<double> stiffnesses(const StabilityOptions& o) {
  if (o.quick) return {1e12};
  return {1e4, 1e6, 1e8, 1e10, 1e12};
}

/// Simulated seconds per run (at most the scene's own duration): 10 s (quick: 8 s), long enough
/// for the default scene's hand to go into the organ (from 3 s) and for its tool to be thrown
/// away at 1e9–1e12 N/m without the core's contact floor (at 7–8 s); the scenes with nets run
/// at ~1.6× real time, so 4 s (quick: 0.5 s).
double duration(const StabilityOptions& o, const Scene& scene) {
  const bool nets = !scene.model.nets.empty();
  const double t = nets ? (o.quick ? 0.5 : 4.0) : (o.quick ? 8.0 : 10.0);
  return std::min(t, scene.duration_s);
}

std::vector<std::string> scene_files(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".toml") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

Scene with_contact_stiffness(const Scene& base, double k) {
  Scene s = base;
  for (core::MaterialPair& p : s.model.material_pairs) p.stiffness = k;
  return s;
}

Scene with_coupling_stiffness(const Scene& base, double k) {
  Scene s = base;
  for (core::BodyModel& b : s.model.bodies) {
    if (!(b.coupling.k_t > 0.0)) continue;
    b.coupling.k_t = k;
    b.coupling.gamma_t = core::damping_from_ratio(kZeta, b.mass, k);
  }
  return s;
}

StabilityRow scene_run(const Scene& scene, const std::string& name, const char* sweep,
                       core::Integrator integrator, double k, const StabilityLimits& limits,
                       double seconds) {
  Scene s = scene;
  s.model = study::with_scheme(scene.model, integrator, scene.model.dt, "stability study");
  RunOptions options;
  options.duration_s = seconds;
  const RunSummary sum = run_scene(s, options);
  StabilityRow r = make_row("scenes", sweep, integrator, s.model.dt, kNaN, k, kNaN, "", kNaN);
  r.case_name = std::string(sweep) + " " + name;
  r.parameter_name = "scene";
  r.energy_ratio_max = kNaN;
  r.steps = sum.steps;
  r.nonfinite_steps = sum.nonfinite_steps;
  r.penetration_max_m = 1e-3 * std::max(sum.tool_penetration_max_mm, sum.any_penetration_max_mm);
  r.penetration_bound_m = limits.penetration_factor * 1e-3 * sum.target_penetration_max_mm + kSlack;
  r.drift_max_m = 1e-3 * sum.joint_drift_max_mm;
  const char* why = nullptr;
  if (sum.nonfinite_steps > 0 || !std::isfinite(r.penetration_max_m))
    why = "non-finite";
  else if (sum.divergence.latched)
    why = "diverged";  // the run's own monitor stopped it (divergence.hpp)
  else if (r.penetration_max_m > r.penetration_bound_m)
    why = "penetration";
  else if (!(sum.free_body_speed_max_mps <= kMaxFreeSpeed))
    why = "speed";
  else if (!(r.drift_max_m <= kDriftBound))
    why = "drift";
  r.stable = why == nullptr;
  r.reason = why ? why : "";
  r.diverged_step = r.stable ? -1 : sum.steps;  // the summary has no first failing period
  char note[320];
  std::snprintf(note, sizeof note,
                "hand %.3g mm deep, tool %.3g mm, any body %.3g mm; %lld steps with clamped "
                "contacts; free-space tracking error RMS %.3g mm, max %.3g mm; %lld non-finite",
                sum.target_penetration_max_mm, sum.tool_penetration_max_mm,
                sum.any_penetration_max_mm, static_cast<long long>(sum.contact_clamped_steps),
                sum.tracking_error_free_rms_mm, sum.tracking_error_free_max_mm,
                static_cast<long long>(sum.nonfinite_steps));
  r.note = note;
  return r;
}

}  // namespace

void plan_scene_stiffness(const StabilityOptions& o, const std::string& dir, Plan& plan) {
  const StabilityLimits limits = o.limits;
  for (const std::string& file : scene_files(dir)) {
    const std::string name = std::filesystem::path(file).stem().string();
    std::shared_ptr<const Scene> scene;
    try {
      SceneOverrides caller;  // loaded as a caller would, to tell a scene that cannot run
      caller.caller_steps = true;
      Scene loaded = load_scene(file, caller);
      if (!loaded.run_missing.empty()) continue;  // stepped by its caller: nothing to run
      loaded.plant.reset();  // study::load_replayed_scene()
      scene = std::make_shared<const Scene>(std::move(loaded));
    } catch (const std::exception& e) {  // a part this build left out (NUMEN_WITH_*)
      const std::string missing = study::missing_parts(true, true);
      if (missing.empty()) throw;
      plan.skipped.push_back("scenes " + name + ": " + e.what());
      continue;
    }
    const double seconds = duration(o, *scene);
    for (core::Integrator integrator : integrators_of(o))
      for (double k : stiffnesses(o)) {
        plan.add("scenes", "contact-stiffness " + name,
                 case_parameters(integrator, {{"k", k}, {"duration_s", seconds}}),
                 kStiffSceneWeight, [=](StabilityResult& r) {
                   r.rows.push_back(scene_run(with_contact_stiffness(*scene, k), name,
                                              "contact-stiffness", integrator, k, limits, seconds));
                 });
        plan.add(
            "scenes", "coupling-stiffness " + name,
            case_parameters(integrator, {{"k", k}, {"duration_s", seconds}}), kStiffSceneWeight,
            [=](StabilityResult& r) {
              r.rows.push_back(scene_run(with_coupling_stiffness(*scene, k), name,
                                         "coupling-stiffness", integrator, k, limits, seconds));
            });
      }
  }
}

}  // namespace numen::sim::stability
