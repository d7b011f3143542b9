#pragma once
/// @file study_passivity.hpp
/// `numen study passivity`: the Z-width of a 1-DOF impedance device (issue 35; docs/passivity.md).
/// A probe puts a device axis (AxisPlant: inertia, viscous damping b, Coulomb friction f_c,
/// delay) under a controller at period T that reads an encoder of resolution Δ (nearest count),
/// estimates the velocity by the backward difference and commands a force held over the period,
/// and lets a hand press into the rendered wall and release it. The energy the hand puts into
/// the device port, E(t) = ∫ F_hand v dt, decides passivity; the largest passive stiffness
/// K_max of each configuration is found by bisection on log K and set against the analytic
/// bounds (Colgate & Schenkel 1997, Abbott & Okamura 2005, Colgate & Schenkel's condition
/// with a transport delay). Study code: allocates and throws; not real-time.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "numen/sim/study/study_shard.hpp"

namespace numen::sim {

/// The device and controller of one probe point (SI units).
struct PassivityPoint {
  double period_s = 1e-3;       ///< Control period T (s), > 0.
  double device_damping = 1.0;  ///< Device viscous damping b (N·s/m), >= 0.
  double coulomb = 0.0;         ///< Device Coulomb friction f_c (N), >= 0.
  double resolution = 0.0;      ///< Encoder resolution Δ (m), >= 0 (0: no quantisation).
  int delay_periods = 0;        ///< Transport delay of the command (whole periods), 0 … 64.
  /// "wall" (direct virtual wall) or "god-object" (1-DOF god-object behind a virtual coupling).
  std::string coupling = "wall";
  double stiffness = 1e3;  ///< K (N/m): the wall's stiffness, or the coupling's (god-object).
  double damping = 0.0;    ///< B (N·s/m): the wall's damping, or the coupling's.
  /// Penalty stiffness k_w (N/m) of the god-object's obstacle; unused by "wall".
  double obstacle_stiffness = 1e6;
  /// The controller's force goes through hal::PassivityController (Hannaford & Ryu's observer
  /// and damper on the port, the backward difference as its rate; docs/passivity.md
  /// "Passivity controller") before it is held over the period.
  bool passivity_controller = false;
  /// The controller's energy limit E_max (J, > 0; +inf: the paper's observer), see
  /// hal::PassivitySettings::energy_limit.
  double passivity_energy_limit_j = std::numeric_limits<double>::infinity();
  /// The controller's velocity estimate v̂ from the encoder readings
  /// (docs/target_velocity.md): "difference" (the bare backward difference, the
  /// theory's), "filter" (hal::RateEstimator at kPassivityFilterCutoffHz, the device's
  /// default cutoff) or "foaw" (hal::FoawEstimator, 32 intervals, a band of half a count).
  /// The passivity controller's own rate stays the backward difference, as on the device.
  std::string velocity_estimator = "difference";
};

/// Cutoff of the "filter" estimator in the probe (Hz): the device's default velocity_cutoff.
inline constexpr double kPassivityFilterCutoffHz = 50.0;

/// What the probe of one point measured (the four hand motions: docs/passivity.md "Probe").
struct PassivityProbe {
  bool passive = true;          ///< min E(t) >= −ε in the press, dither and resonance runs.
  double energy_min_j = 0.0;    ///< min over those runs and time of E(t) (J).
  double energy_peak_j = 0.0;   ///< max over those runs and time of |E(t)| (J).
  std::string worst_run;        ///< The run of the lowest E/ε: "press", "dither" or "resonance".
  bool contact_passive = true;  ///< min E(t) >= −ε in the contact run.
  double contact_energy_min_j = 0.0;  ///< min over time of E(t) in the contact run (J).
  /// A sustained or growing oscillation in the contact run (docs/passivity.md "Decision rule").
  bool limit_cycle = false;
  /// Half peak-to-peak of the position (m; the largest |x| reached if it diverged); 0: none.
  double limit_cycle_amplitude_m = 0.0;
  double limit_cycle_hz = 0.0;  ///< Its frequency (Hz); 0: none.
};

/// The device's inertia in every probe (kg).
inline constexpr double kPassivityDeviceMass = 0.1;
/// The god-object's mass (kg).
inline constexpr double kPassivityGodObjectMass = 0.02;
/// ε of the decision rule, relative to the run's peak |E(t)|.
inline constexpr double kPassivityEpsilonRelative = 1e-6;

/// Runs the hand motions of docs/passivity.md "Probe" on `point`. Throws std::invalid_argument
/// naming a bad setting.
PassivityProbe probe_passivity(const PassivityPoint& point);

/// The analytic bounds of a point (N/m; 0 when no positive K is passive, infinity when none
/// applies): Colgate & Schenkel 2(b − |B|)/T; Abbott & Okamura max(2(b − |B|)/T, 2 f_c/Δ)
/// (infinity for Δ = 0 with f_c > 0); the delay bound: Colgate & Schenkel's frequency condition
/// with H(z) = z^{−d}(K + B(1 − z^{−1})/T), min over ωT ∈ [0, π] (= b/(T/2 + dT) for B = 0).
double colgate_bound(const PassivityPoint& p);
double abbott_okamura_bound(const PassivityPoint& p);
double delay_bound(const PassivityPoint& p);
/// The θ = ωT (rad per period, in [0, π]) at which delay_bound()'s condition binds.
double delay_bound_frequency(const PassivityPoint& p);
/// The dither run's own bound (derived in docs/passivity.md, Δ > 0; infinity for Δ = 0):
/// 2 f_c/Δ + 4 a b/(T Δ) − B/T with the dither's amplitude a = Δ/100 (0 if negative).
double dither_bound(const PassivityPoint& p);

/// What to run.
struct PassivityOptions {
  bool quick = false;  ///< The coarse sweep (docs/passivity.md): well under a minute.
  /// Relative width of the final bisection bracket: stop when K_hi / K_lo <= 1 + tolerance.
  double tolerance = 5e-3;
  /// The cases to run (docs/studies.md); {0, 1}: all.
  Shard shard;
  /// Called after every case with cases done and total; may be empty.
  std::function<void(double done, double total, const std::string& label)> progress;
};

/// One probed point: one line of passivity.csv.
struct PassivityRow {
  double period_s = 0.0;
  double device_damping = 0.0;
  double coulomb = 0.0;
  double resolution = 0.0;
  int delay_periods = 0;
  std::string coupling;
  double stiffness = 0.0;
  double damping = 0.0;
  double obstacle_stiffness = 0.0;  ///< NaN for "wall".
  bool passivity_controller = false;  ///< PassivityPoint::passivity_controller.
  double passivity_energy_limit_j = 0.0;  ///< PassivityPoint::passivity_energy_limit_j.
  std::string velocity_estimator;         ///< PassivityPoint::velocity_estimator.
  bool passive = false;
  double energy_min_j = 0.0;
  double energy_peak_j = 0.0;
  std::string worst_run;
  bool contact_passive = false;
  double contact_energy_min_j = 0.0;
  bool limit_cycle = false;
  double limit_cycle_amplitude_m = 0.0;
  double limit_cycle_hz = 0.0;
  double colgate_bound = 0.0;
  double abbott_okamura_bound = 0.0;
  double delay_bound = 0.0;
  double dither_bound = 0.0;
  std::string kind;              ///< "grid" or "bisection".
  std::int64_t case_index = -1;  ///< The study case of the row (not a column).
};

/// One configuration's measured boundary: one line of passivity_boundary.csv.
struct PassivityBoundary {
  double period_s = 0.0;
  double device_damping = 0.0;
  double coulomb = 0.0;
  double resolution = 0.0;
  int delay_periods = 0;
  std::string coupling;
  double damping = 0.0;
  double obstacle_stiffness = 0.0;
  bool passivity_controller = false;  ///< PassivityPoint::passivity_controller.
  double passivity_energy_limit_j = 0.0;  ///< PassivityPoint::passivity_energy_limit_j.
  std::string velocity_estimator;         ///< PassivityPoint::velocity_estimator.
  /// Geometric mean of the final bracket (N/m); 0: not passive at the bracket's low end,
  /// infinity: passive at its high end.
  double k_max = 0.0;
  double k_passive = 0.0;      ///< Largest K found passive (N/m).
  double k_not_passive = 0.0;  ///< Smallest K found not passive (N/m).
  double colgate_bound = 0.0;
  double abbott_okamura_bound = 0.0;
  double delay_bound = 0.0;
  double dither_bound = 0.0;
  double ratio_colgate = 0.0;  ///< k_max / colgate_bound (the others alike).
  double ratio_abbott_okamura = 0.0;
  double ratio_delay = 0.0;
  double ratio_dither = 0.0;
  std::int64_t evaluations = 0;  ///< Probes of the bisection.
  std::int64_t case_index = -1;
};

/// Everything the study measured.
struct PassivityResult {
  std::vector<PassivityRow> rows;
  std::vector<PassivityBoundary> boundaries;
  std::vector<std::string> skipped;  ///< Always empty (the shard machinery's field).
  std::int64_t cases = 0;
  Shard shard;
  double wall_s = 0.0;
};

/// The stiffnesses K (N/m) of the grid every configuration is probed at before its bisection
/// (rows of kind "grid"): 10^1 … 10^7 in steps of a decade (`quick`: 7 points) or of half a
/// decade (13 points).
std::vector<double> passivity_grid(bool quick);

/// The boundary of one configuration (`point` without its stiffness): K_max by bisection on
/// log K from a bracket around the smallest positive finite analytic bound (1000 N/m if none),
/// widened ×4 up to 8 times each way, until K_hi/K_lo <= 1 + tolerance. Each probe's row is
/// appended to `rows` (kind "bisection", case_index −1) when it is not null. Throws
/// std::invalid_argument for a tolerance outside (0, 1) and what probe_passivity() throws.
PassivityBoundary find_passivity_boundary(const PassivityPoint& point, double tolerance,
                                          std::vector<PassivityRow>* rows = nullptr);

/// The study's cases (one per configuration) in the order of the one-process run, those of
/// `options.shard`. Runs nothing.
std::vector<StudyCase> passivity_cases(const PassivityOptions& options);

/// Runs the cases of `options.shard`: per case the grid of K and the bisection.
PassivityResult run_passivity_study(const PassivityOptions& options);

/// Writes passivity.csv (rows) and passivity_boundary.csv (boundaries) into `dir` (created if
/// missing), as one set (write_files_atomically(): a file that cannot be written leaves both as
/// they were). Throws std::runtime_error naming it.
void write_passivity_csv(const PassivityResult& result, const std::string& dir);

/// The text summary: per configuration K_max against the bounds. Markdown.
std::string format_passivity_table(const PassivityResult& result);

/// Failures of a result (empty: none), one message each: an energy or a K_max that is NaN; a
/// direct wall without quantisation and friction whose K_max is not within 10 % of
/// delay_bound(); a quantised direct wall without damping and delay whose K_max is not within
/// 10 % of 2 f_c/Δ.
std::vector<std::string> passivity_failures(const PassivityResult& result);

/// The shard file of `result` (study_shard.hpp).
std::string passivity_shard_document(const PassivityResult& result,
                                     const PassivityOptions& options);

/// Reads the N shard files of the passivity study in `dir` (study_shard.hpp). Each case must
/// hold what its plan gives it: one boundary, and one row per point of passivity_grid() and per
/// probe of its bisection (PassivityBoundary::evaluations); and no NaN where
/// passivity_failures() would find one (a row's energy_min_j or contact_energy_min_j, the
/// boundary's k_max): InputError naming the file and the member ("case 7.rows[3].energy_min_j"),
/// so that nothing is written from such a set.
PassivityResult merge_passivity_shards(const std::string& dir);

}  // namespace numen::sim
