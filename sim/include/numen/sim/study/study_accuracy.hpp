#pragma once
/// @file study_accuracy.hpp
/// `numen study accuracy`: work-precision data per integrator (issue 6; docs/accuracy.md).
/// For each time step h of a grid (default 1e-2 s … 1e-5 s, h = 10 ms / n),
/// each integrator (linearly implicit Euler, symplectic Euler, linearised trapezoidal rule,
/// linearised TR-BDF2)
/// and each case, the position error (max and RMS, mm) and the orientation error (max and
/// RMS, mrad) against the CPU time per simulated second, and the observed order of
/// convergence (slope of the log-log fit) next to the theoretical one. Cases:
///  - "free-body": the coupled rigid body in free space (paper Eq. 1–2 without contact) against
///    the closed form of the damped oscillator, translational and rotational about a principal
///    axis (exact: the coupling torque is linear in the angle there and ω × Iω = 0);
///  - "wall": a sphere god-object pushed 20 mm into a plane while sliding along it (penalty
///    contact with damping and viscous friction), smooth (quintic) target motion;
///  - "wall-smoothed": the same with the smoothed C¹ contact onset (core::MaterialPair::
///    onset_depth = 0.1 mm): what the penalty law's onset costs the second-order schemes;
///  - "articulated": the articulated instrument of sim/scenes/lattice.toml following the shipped
///    recording (sim/data), its axis values interpolated by a C¹ cubic (Catmull–Rom) through
///    samples every 40 ms so that the input does not cap every scheme at first order;
///  - "deformable": the deformable probe of sim/scenes/deformable.toml on the same input, over
///    the window where it is swept into the post.
/// Windows of the recording: articulated 3.5–4.1 s (the jaws reach the tissue at 3.7 s),
/// deformable 2.65–2.85 s (the probe's nodes reach the post at 2.65 s); the free body and the
/// wall run 1 s. The scene cases' linear solves run to a relative residual of 1e-9.
/// The last four are compared with a reference run of the trapezoidal rule at a much finer
/// step (AccuracyOptions::reference_dt), itself checked against a run at half that step
/// (ReferenceCheck). Errors are taken every 10 ms of simulated time (a multiple of every step
/// of the grid): at each sample the largest error over the tool's points (bodies' centres of
/// mass and net nodes) and frames (bodies' orientations). The trapezoidal rule and TR-BDF2 are
/// fed their time-dependent inputs (targets) at the step's middle t + h/2, the Euler schemes at the
/// step's start t (what the control loop does): docs/dynamics.md. Study code: allocates,
/// throws InputError for a scene that cannot be loaded; not real-time.
/// Schema of the CSV files: docs/accuracy.md.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/sim/study/study_shard.hpp"

namespace numen::sim {

/// What to run.
struct AccuracyOptions {
  /// Time steps (s). Empty: 10 ms / n for n = 1, 2, 5, 10, …, 1000 (1e-2 … 1e-5 s), or with
  /// `quick` n = 1, 2, 5, 10, 20, 50, 100 (1e-2 … 1e-4 s). Each must divide 10 ms.
  std::vector<double> steps;
  /// Shorter horizons (×0.3), a coarser grid and references at 2e-5 s: a few seconds.
  bool quick = false;
  /// Subset of "free-body", "wall", "wall-smoothed", "articulated", "deformable"; empty: all.
  std::vector<std::string> cases;
  /// Integrators to compare; empty: implicit Euler, symplectic Euler, trapezoidal, TR-BDF2.
  std::vector<core::Integrator> integrators;
  /// Simulated time of every case (s, a multiple of 10 ms); ≤ 0: each case's own horizon.
  double horizon_s = -1.0;
  /// Step of the reference runs (s); ≤ 0: 1e-6 (rigid cases), 2e-6 (deformable), or 2e-5
  /// with `quick`. Checked against a run at reference_dt / 2.
  double reference_dt = -1.0;
  /// The fit of the observed order uses the steps h ≤ fit_max_dt that did not diverge and
  /// whose error is at least 10 × the case's error floor (ReferenceCheck, or 1e-9 mm for the
  /// closed form): the asymptotic range.
  double fit_max_dt = 1e-3;
  /// Directory of the shipped scenes (sim/scenes); empty: the source tree's.
  std::string scene_dir;
  /// Called after every run with the work done and the total (arbitrary units, ≈ CPU cost)
  /// and a label ("wall trapezoidal dt=1e-04"); may be empty.
  std::function<void(double done, double total, const std::string& label)> progress;
  /// The cases to run: those of this shard (docs/studies.md); {0, 1}: all. A study case
  /// (accuracy_cases()) is one case and integrator over the whole grid of steps; each shard
  /// that runs a case computes the case's reference (and its check at half the step) itself.
  Shard shard;
};

/// One run: a case, an integrator, a step. One line of accuracy.csv.
struct AccuracyRow {
  std::string case_name;
  std::string integrator;  ///< Scene-file name ("implicit-euler", …).
  double dt_s = 0.0;
  std::int64_t steps = 0;
  double horizon_s = 0.0;  ///< Simulated time (s).
  double position_error_max_mm = 0.0;
  double position_error_rms_mm = 0.0;  ///< RMS over the 10 ms samples of the per-sample max.
  double orientation_error_max_mrad = 0.0;
  double orientation_error_rms_mrad = 0.0;
  double cpu_s_per_sim_s = 0.0;  ///< Thread CPU time of the stepping loop / simulated time.
  bool diverged = false;         ///< Non-finite steps rolled back, or an error above 1 m.
  std::int64_t nonfinite_steps = 0;
  std::string reference;  ///< "closed-form" or "trapezoidal dt=…".
  std::int64_t case_index = -1;  ///< The study case (accuracy_cases()) of this run.
};

/// The observed order of one case and integrator.
struct AccuracyFit {
  std::string case_name;
  std::string integrator;
  double observed_order =
      0.0;  ///< Least-squares slope of log(position error max) vs log(h); NaN: < 3 points.
  double observed_order_rotation = 0.0;  ///< Same for the orientation error (NaN: < 3 points).
  double theoretical_order = 1.0;        ///< 1 (Euler schemes) or 2 (trapezoidal, TR-BDF2).
  int points = 0;                        ///< Steps used by the position fit.
  double fit_dt_min = 0.0;               ///< Smallest and largest step of the position fit (s).
  double fit_dt_max = 0.0;
  double error_at_1ms_mm = 0.0;  ///< Position error max at h = 1 ms (NaN: not on the grid).
  double cpu_at_1ms = 0.0;       ///< CPU s per simulated s at h = 1 ms (NaN: not on the grid).
  std::int64_t case_index = -1;  ///< The study case (accuracy_cases()) of this fit.
};

/// How far a reference run is from the exact solution: its difference with the same run at
/// half its step (the trapezoidal rule's error at reference_dt is about 4/3 of it).
struct ReferenceCheck {
  std::string case_name;
  double reference_dt = 0.0;
  double position_difference_max_mm = 0.0;
  double orientation_difference_max_mrad = 0.0;
  double cpu_s = 0.0;  ///< CPU time of both reference runs (s).
  /// The study case that reports it (accuracy_cases()): the case's first integrator.
  std::int64_t case_index = -1;
};

/// Everything the study measured.
struct AccuracyResult {
  std::vector<AccuracyRow> rows;
  std::vector<AccuracyFit> fits;
  std::vector<ReferenceCheck> references;
  /// Cases of the default list this build cannot run, "case: reason" (study::missing_parts()).
  std::vector<std::string> skipped;
  std::int64_t cases = 0;  ///< Study cases of the whole study (all shards).
  Shard shard;             ///< The shard this result covers ({0, 1}: all, or a merge).
  /// Wall time of the study (s); of a merge (merge_accuracy_shards()): the sum over the shards.
  double wall_s = 0.0;
};

/// The four case names, in the order they run.
const std::vector<std::string>& accuracy_case_names();

/// The study's cases in the order of the one-process run, for `--list`: one per case and
/// integrator (index = case position × integrators + integrator position), those of
/// `options.shard`. Runs nothing. Throws what run_accuracy_study() throws before it runs.
std::vector<StudyCase> accuracy_cases(const AccuracyOptions& options);

/// Runs the study: the study cases of `options.shard`. Throws InputError for an unknown case, a
/// case named in AccuracyOptions::cases that this build left out (NUMEN_WITH_* options), or a step
/// that does not divide 10 ms, and what load_scene() throws for the scene cases. Cases of the
/// default list that this build left out are skipped and listed in AccuracyResult::skipped.
AccuracyResult run_accuracy_study(const AccuracyOptions& options);

/// Least-squares slope of log(error) against log(dt) over the points with dt ≤ max_dt,
/// not diverged and error ≥ min_error (finite, > 0); NaN when fewer than 3 points remain.
/// `used` (optional) receives the number of points, `dt_min`/`dt_max` their range.
double fit_order(const std::vector<double>& dt, const std::vector<double>& error,
                 const std::vector<bool>& diverged, double max_dt, double min_error,
                 int* used = nullptr, double* dt_min = nullptr, double* dt_max = nullptr);

/// Writes accuracy.csv (rows), accuracy_orders.csv (fits) and accuracy_references.csv
/// into `dir` (created if missing), as one set (write_files_atomically(): a file that cannot be
/// written leaves all three as they were). Throws std::runtime_error naming it.
void write_accuracy_csv(const AccuracyResult& result, const std::string& dir);

/// The shard file of `result` (run with `options`; study_shard.hpp): the options and plan, per
/// study case its rows, fit and (first integrator) reference check, numbers exact. The CPU times
/// (cpu_s_per_sim_s, cpu_at_1ms, ReferenceCheck::cpu_s) are those measured by this shard.
std::string accuracy_shard_document(const AccuracyResult& result, const AccuracyOptions& options);

/// The time steps (s) of AccuracyOptions::steps when it is empty: 10 ms / n for n = 1, 2, 5, 10,
/// …, 1000 (1e-2 … 1e-5 s, 10 steps), or with `quick` up to n = 100 (1e-2 … 1e-4 s, 7 steps).
std::vector<double> accuracy_default_steps(bool quick);

/// The integrators of AccuracyOptions::integrators when it is empty: implicit Euler,
/// symplectic Euler, trapezoidal, TR-BDF2.
std::vector<core::Integrator> accuracy_default_integrators();

/// True when accuracy case `name` ("free-body", "wall", …) is compared with a closed-form
/// solution ("free-body"); the others with a reference run, checked once per case
/// (ReferenceCheck, reported by its first integrator's study case).
bool accuracy_case_has_closed_form(const std::string& name);

/// Reads the N shard files of the accuracy study in `dir` and puts their cases back in the
/// one-process order: write_accuracy_csv() of the result writes what the one-process run writes
/// except the CPU-time columns, which are measurements (they differ between any two runs).
/// Throws InputError for a missing shard, mismatched N or options, a file that is not a complete
/// shard file, or a case without what its plan gives it: one fit, one row per time step, and
/// for a case's first integrator one reference check unless the case has a closed form (key
/// "case K.fits", "case K.rows" or "case K.references").
AccuracyResult merge_accuracy_shards(const std::string& dir);

/// The table of docs/accuracy.md: case, integrator, observed and theoretical order, error
/// and CPU time at 1 ms; then the reference checks. Markdown.
std::string format_accuracy_table(const AccuracyResult& result);

}  // namespace numen::sim
