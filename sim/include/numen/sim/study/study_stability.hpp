#pragma once
/// @file study_stability.hpp
/// `numen study stability`: stiff and extreme cases, one verdict per run (issue 6;
/// docs/stability.md). Families of runs, each for the four integrators
/// (linearly implicit Euler, symplectic Euler, linearised trapezoidal rule, linearised TR-BDF2):
///  - "coupling": one body on the coupling spring of Eq. 2 alone (no gravity, no contact),
///    released at rest 10 mm from a fixed target; stiffness k 1e1…1e8 N/m × mass m 1e-3…1e2 kg ×
///    time step h 1e-4…1e-2 s, undamped (ζ = 0) and with the scenes' damping ζ = 0.85;
///  - "contact": a 10 mm sphere at rest on a plane, its target 20 mm inside; contact stiffness
///    1e2…1e8 N/m × h × mass (coupling scaled with the mass: ω_t = √(k_t/m) = 44.7 rad/s, ζ =
///    0.85), undamped contact and contact damping ratio 0.5; its static penetration F/k uses the
///    stiffness the contact acts with, k_c clamped by the core's time-constant floor
///    (core::contact_stiffness_limit());
///  - "articulation": two bodies joined by a revolute joint (Eq. 4–5), the held one 0.1 kg, the
///    other 0.1 kg × ratio, ratio 1e-4…1e4, target 20 mm aside;
///  - "extreme": a target teleporting 1 m (and half a turn) in one period, free and into a wall;
///    a target spinning at 100 rad/s about a non-principal axis; more contacts than
///    core::kMaxContacts; the deformable probe (sim/scenes/deformable.toml) whose target jumps
///    10 cm into the post; the trocar instrument (sim/scenes/lattice.toml) pulled to zero insertion
///    through the control loop; encoder frames carrying what a NaN or ±Inf becomes on the bus
///    (hal::value_to_counts) through SimBus, InstrumentDevice and ControlLoop, and the sample
///    check and core::Data given NaN/Inf directly.
///  - "boundary": the symplectic Euler on the undamped (and ζ = 0.85) spring swept in ω h and
///    bisected: its measured stability limit against theory (ω h = 2; 2(√(1+ζ²) − ζ) damped).
///  - "scenes": every shipped scene (sim/scenes/*.toml) through run_scene(), its contact stiffness
///    and, separately, its coupling stiffness k_t swept 1e4…1e12 N/m (quick: 1e12); verdict
///    from the run's summary (study_stability_scenes.cpp): no rollback, the tool and every body at
///    most penetration_factor × as deep as the hand went plus 1 mm, free bodies below 10 m/s,
///    joint drift below 5 mm.
///
/// Verdict of a run (StabilityLimits; docs/stability.md gives the reasons):
///  - stable: every step finite and accepted (core::Data::nonfinite_steps stays 0: the core's
///    rollback guard never fired), the energy E (kinetic + coupling, net-spring and tie potentials;
///    stored_energy(); the contacts' potential is bounded through the penetration) never above
///    energy_factor × max(E₀ + W_in, energy_floor_j), with E₀ the energy at the start and W_in the
///    positive work the moving target put in (input_work()), every penetration at most
///    penetration_factor × the case's static penetration F/k plus one step of travel at the fastest
///    speed the energy allows, h √(2 (E₀ + W_in) / m) (contacts are found at the step's start: a
///    body reaching a surface goes one step deep before it is pushed), joint drift below the case's
///    bound; the loop cases also check torques (finite, within the drives' limits, zero while the
///    input is invalid) and that nothing non-finite reached core::Data;
///  - otherwise "diverged at step N" with the first criterion that failed.
/// Study code: allocates, throws InputError for a bad option; not real-time.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/run/energy.hpp"
#include "numen/sim/study/study_shard.hpp"

namespace numen::sim {

/// The thresholds of the verdict (dimensionless factors).
struct StabilityLimits {
  /// E may reach energy_factor × (E₀ + W_in): a passive system never exceeds 1×; the symplectic
  /// Euler's bounded oscillation of an undamped spring reaches E₀ / (1 − ω h / 2) (its invariant
  /// ellipse), so the verdict's limit for it is ω h = 2 (1 − 1 / energy_factor) = 1.98.
  double energy_factor = 100.0;
  /// Floor of the reference energy (J): a body at rest on unstretched springs has E₀ = 0 and
  /// rounding-level energy (< 1e-20 J) must not count as growth; every case puts in > 1e-4 J.
  double energy_floor_j = 1e-9;
  /// Penetration may reach penetration_factor × the static penetration F/k of the case (an
  /// undamped contact loaded suddenly reaches 2 ×).
  double penetration_factor = 3.0;
};

/// What to run.
struct StabilityOptions {
  /// Coarser grids and shorter runs: a few seconds.
  bool quick = false;
  /// Subset of stability_family_names(); empty: all.
  std::vector<std::string> families;
  /// Integrators; empty: study::all_integrators().
  std::vector<core::Integrator> integrators;
  /// Steps per run of the coupling and contact grids (≤ 0: 2000, or 300 with `quick`).
  int grid_steps = -1;
  StabilityLimits limits;
  /// Directory of the shipped scenes (sim/scenes); empty: the source tree's.
  std::string scene_dir;
  /// Progress (work done, total, label of what ran); may be empty.
  std::function<void(double done, double total, const std::string& label)> progress;
  /// The cases to run: those of this shard (docs/studies.md); {0, 1}: all.
  Shard shard;
};

/// One run and its verdict: one line of stability_<family>.csv.
struct StabilityRow {
  std::string family;      ///< "coupling", "contact", "articulation", "extreme", "scenes".
  std::string case_name;   ///< e.g. "coupling-undamped", "teleport-wall", "bus-nonfinite".
  std::string integrator;  ///< Scene-file name ("implicit-euler", …).
  double dt_s = 0.0;
  double mass_kg = 0.0;    ///< The driven body's mass (NaN: not applicable).
  double stiffness = 0.0;  ///< The swept stiffness (N/m; N·m/rad for the spin case; NaN: n/a).
  double parameter =
      0.0;  ///< Case parameter (mass ratio, damping ratio ζ, …; see `parameter_name`).
  std::string parameter_name;  ///< What `parameter` is ("zeta", "mass_ratio", "contact_zeta", …).
  double omega_dt = 0.0;       ///< ω h of the stiffest mode the case is about (NaN: n/a).
  std::int64_t steps = 0;      ///< Steps run (fewer than planned when it diverged).
  bool stable = false;
  std::int64_t diverged_step = -1;  ///< First failing step (1-based), -1 when stable.
  std::string reason;  ///< "" or "non-finite", "energy", "penetration", "drift", "torque", "input".
  double energy_ref_j = 0.0;      ///< E₀ + W_in at the end (J).
  double energy_ratio_max = 0.0;  ///< max over steps of E / (E₀ + W_in) (NaN: not metered).
  double penetration_max_m = 0.0;
  double penetration_bound_m = std::numeric_limits<double>::infinity();
  double drift_max_m = 0.0;  ///< Largest joint position error |C| of a linear row over the run (m).
  std::int64_t nonfinite_steps = 0;  ///< core::Data::nonfinite_steps (rollbacks).
  std::string note;                  ///< Case-specific observations (overflow counts, torque, …).
  std::int64_t case_index = -1;      ///< The case (stability_cases()) that made this row.
};

/// The symplectic Euler's measured stability limit on one spring.
struct StabilityBoundary {
  double zeta = 0.0;             ///< Damping ratio of the coupling.
  double theory_omega_dt = 2.0;  ///< Linear stability limit of the scheme: 2 (√(1+ζ²) − ζ).
  /// Largest ω h without growth (the energy maximum of the last quarter of the run at most
  /// 1.5 × that of the second quarter): the limit of linear stability; bisected to 1e-5.
  double measured_growth_omega_dt = 0.0;
  /// Largest ω h that the full verdict calls stable (bisected to 1e-5). ζ = 0: theory
  /// 2 (1 − 1/energy_factor), the bounded overshoot of the invariant ellipse.
  double measured_verdict_omega_dt = 0.0;
  double verdict_theory_omega_dt = 0.0;  ///< 2 (1 − 1/energy_factor) for ζ = 0; NaN when damped.
  std::int64_t steps = 0;                ///< Steps per run.
  /// The sweep: ω h and the run's max E/E₀ and growth ratio (stability_boundary.csv).
  std::vector<double> omega_dt, energy_ratio, growth_ratio;
  std::int64_t case_index = -1;  ///< The case (stability_cases()) that measured it.
};

/// Everything the study measured.
struct StabilityResult {
  std::vector<StabilityRow> rows;
  std::vector<StabilityBoundary> boundaries;
  /// Cases this build cannot run (NUMEN_WITH_* options), "case: reason" (study::missing_parts()).
  std::vector<std::string> skipped;
  /// Wall time of the study (s); of a merge (merge_stability_shards()): the sum over the shards.
  double wall_s = 0.0;
  std::int64_t cases = 0;  ///< Cases of the whole study (all shards).
  Shard shard;             ///< The shard this result covers ({0, 1}: all, or a merge).
};

/// "coupling", "contact", "articulation", "extreme", "boundary", "scenes".
const std::vector<std::string>& stability_family_names();

/// The study's cases in the order of the one-process run (index k = position), for `--list`:
/// those of `options.shard`. Loads the shipped scenes (family "scenes" and the scene cases of
/// "extreme") but runs nothing. Throws what run_stability_study() throws before it runs.
std::vector<StudyCase> stability_cases(const StabilityOptions& options);

/// Runs the study: the cases of `options.shard`, in order. Throws InputError for an unknown family
/// or for "articulation" named in StabilityOptions::families in a build without joints, what
/// load_scene() throws for the shipped scenes. Cases this build left out (NUMEN_WITH_* options) are
/// otherwise skipped and listed in StabilityResult::skipped.
StabilityResult run_stability_study(const StabilityOptions& options);

/// Positive work the device input puts in over one step of length h, for the study's energy
/// bound: the jump of stored_energy() caused by the new targets at the unchanged state
/// (`energy_after_inputs` − `energy_before_inputs`, the work of a teleport) plus h times the
/// power of the coupling dampers through the target twist, γ_t (v_t − v)·v_t + γ_r (ω_t − ω)·ω_t
/// (dE/dt = F·v_t − γ|v_t − v|² for a spring-damper whose end moves at v_t); only the positive
/// part. Call with the new inputs written to `data`.
double input_work(const core::Model& model, const core::Data& data, double energy_before_inputs,
                  double energy_after_inputs) noexcept;

/// Writes stability_<family>.csv for every family present and stability_boundary.csv into `dir`
/// (created if missing), as one set (write_files_atomically(): a file that cannot be written
/// leaves them all as they were). Throws std::runtime_error naming it.
void write_stability_csv(const StabilityResult& result, const std::string& dir);

/// The shard file of `result` (run with `options`; study_shard.hpp): the options and plan (the
/// manifest a merge compares), the wall time, and per case its rows or boundary, numbers exact.
std::string stability_shard_document(const StabilityResult& result,
                                     const StabilityOptions& options);

/// Reads the N shard files of the stability study in `dir` (stability-shard-<I>-of-<N>.json) and
/// puts their cases back in the one-process order: write_stability_csv() of the result writes
/// the same bytes as the one-process run, format_stability_tables() the same tables. Throws
/// InputError for a missing shard (listing the indices), mismatched N or options, a file that is
/// not a complete shard file, or a case without what its plan gives it (one run: one row, or
/// for the boundary family one boundary; key "case K.rows" or "case K.boundaries").
StabilityResult merge_stability_shards(const std::string& dir);

/// The CSV header line of stability_<family>.csv (no newline); schema in docs/stability.md.
const std::string& stability_csv_header();

/// Verdict tables of docs/stability.md (Markdown): per family and integrator the number of runs
/// stable / diverged, the extreme cases one by one, and the boundary measurements.
std::string format_stability_tables(const StabilityResult& result);

}  // namespace numen::sim
