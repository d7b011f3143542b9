#pragma once
/// @file study_fields.hpp
/// The one field list of each study record: `fields(record, visit)` calls
/// visit(name, member) for each member, in column order. The stability row's list writes
/// stability_<family>.csv, the shard files' rows and numen.study_stability's dicts; the
/// accuracy row's list writes accuracy.csv, the shard files' rows and numen.study_accuracy's
/// dicts (StudyFields.*); the passivity lists write passivity.csv, passivity_boundary.csv and
/// the shard files' records. A member has one name in all of them.
/// Members are std::string, double, std::int64_t, int, bool or std::vector<double>.

#include <ostream>
#include <string>
#include <vector>

#include "numen/sim/study/study_accuracy.hpp"
#include "numen/sim/study/study_passivity.hpp"
#include "numen/sim/study/study_stability.hpp"

namespace numen::sim {

/// The members of a stability run (StabilityRow), by the names of the columns of
/// stability_<family>.csv (docs/stability.md, "CSV files").
template <class Row, class Visit>
void stability_row_fields(Row& r, Visit&& v) {
  v("family", r.family);
  v("case", r.case_name);
  v("integrator", r.integrator);
  v("dt_s", r.dt_s);
  v("mass_kg", r.mass_kg);
  v("stiffness", r.stiffness);
  v("parameter_name", r.parameter_name);
  v("parameter", r.parameter);
  v("omega_dt", r.omega_dt);
  v("steps", r.steps);
  v("stable", r.stable);
  v("diverged_step", r.diverged_step);
  v("reason", r.reason);
  v("energy_ref_j", r.energy_ref_j);
  v("energy_ratio_max", r.energy_ratio_max);
  v("penetration_max_m", r.penetration_max_m);
  v("penetration_bound_m", r.penetration_bound_m);
  v("drift_max_m", r.drift_max_m);
  v("nonfinite_steps", r.nonfinite_steps);
  v("note", r.note);
}

/// The members of a boundary measurement (StabilityBoundary) in a shard file.
template <class Boundary, class Visit>
void stability_boundary_fields(Boundary& b, Visit&& v) {
  v("zeta", b.zeta);
  v("theory_omega_dt", b.theory_omega_dt);
  v("measured_growth_omega_dt", b.measured_growth_omega_dt);
  v("measured_verdict_omega_dt", b.measured_verdict_omega_dt);
  v("verdict_theory_omega_dt", b.verdict_theory_omega_dt);
  v("steps", b.steps);
  v("omega_dt", b.omega_dt);
  v("energy_ratio", b.energy_ratio);
  v("growth_ratio", b.growth_ratio);
}

/// The members of an accuracy run (AccuracyRow), by the names of the columns of accuracy.csv.
template <class Row, class Visit>
void accuracy_row_fields(Row& r, Visit&& v) {
  v("case", r.case_name);
  v("integrator", r.integrator);
  v("dt_s", r.dt_s);
  v("steps", r.steps);
  v("horizon_s", r.horizon_s);
  v("position_error_max_mm", r.position_error_max_mm);
  v("position_error_rms_mm", r.position_error_rms_mm);
  v("orientation_error_max_mrad", r.orientation_error_max_mrad);
  v("orientation_error_rms_mrad", r.orientation_error_rms_mrad);
  v("cpu_s_per_sim_s", r.cpu_s_per_sim_s);
  v("diverged", r.diverged);
  v("nonfinite_steps", r.nonfinite_steps);
  v("reference", r.reference);
}

/// The members of a probed point (PassivityRow), by the names of the columns of passivity.csv
/// (docs/passivity.md, "CSV files").
template <class Row, class Visit>
void passivity_row_fields(Row& r, Visit&& v) {
  v("period_s", r.period_s);
  v("device_damping", r.device_damping);
  v("coulomb", r.coulomb);
  v("resolution", r.resolution);
  v("delay_periods", r.delay_periods);
  v("coupling", r.coupling);
  v("stiffness", r.stiffness);
  v("damping", r.damping);
  v("passive", r.passive);
  v("energy_min_j", r.energy_min_j);
  v("energy_peak_j", r.energy_peak_j);
  v("worst_run", r.worst_run);
  v("obstacle_stiffness", r.obstacle_stiffness);
  v("contact_passive", r.contact_passive);
  v("contact_energy_min_j", r.contact_energy_min_j);
  v("limit_cycle", r.limit_cycle);
  v("limit_cycle_amplitude_m", r.limit_cycle_amplitude_m);
  v("limit_cycle_hz", r.limit_cycle_hz);
  v("colgate_bound", r.colgate_bound);
  v("abbott_okamura_bound", r.abbott_okamura_bound);
  v("delay_bound", r.delay_bound);
  v("dither_bound", r.dither_bound);
  v("kind", r.kind);
  v("passivity_controller", r.passivity_controller);
  v("passivity_energy_limit_j", r.passivity_energy_limit_j);
  v("velocity_estimator", r.velocity_estimator);
}

/// The members of a measured boundary (PassivityBoundary), by the names of the columns of
/// passivity_boundary.csv.
template <class Boundary, class Visit>
void passivity_boundary_fields(Boundary& b, Visit&& v) {
  v("period_s", b.period_s);
  v("device_damping", b.device_damping);
  v("coulomb", b.coulomb);
  v("resolution", b.resolution);
  v("delay_periods", b.delay_periods);
  v("coupling", b.coupling);
  v("damping", b.damping);
  v("obstacle_stiffness", b.obstacle_stiffness);
  v("k_max", b.k_max);
  v("k_passive", b.k_passive);
  v("k_not_passive", b.k_not_passive);
  v("colgate_bound", b.colgate_bound);
  v("abbott_okamura_bound", b.abbott_okamura_bound);
  v("delay_bound", b.delay_bound);
  v("dither_bound", b.dither_bound);
  v("ratio_colgate", b.ratio_colgate);
  v("ratio_abbott_okamura", b.ratio_abbott_okamura);
  v("ratio_delay", b.ratio_delay);
  v("ratio_dither", b.ratio_dither);
  v("evaluations", b.evaluations);
  v("passivity_controller", b.passivity_controller);
  v("passivity_energy_limit_j", b.passivity_energy_limit_j);
  v("velocity_estimator", b.velocity_estimator);
}

/// The names `fields` visits, in order (e.g. field_names<StabilityRow>(stability_row_fields)).
template <class Record, class Fields>
std::vector<std::string> field_names(Fields&& fields) {
  Record r;
  std::vector<std::string> names;
  fields(r, [&names](const char* name, const auto&) { names.emplace_back(name); });
  return names;
}

/// Writes `records` as CSV to `out`: a header of the names `fields` visits, then one line per
/// record with its members in the same order (bools 1/0, numbers as `out` formats them).
template <class Record, class Fields>
void write_fields_csv(std::ostream& out, const std::vector<Record>& records, Fields&& fields) {
  bool first = true;
  const Record names{};
  fields(names, [&](const char* name, const auto&) {
    out << (first ? "" : ",") << name;
    first = false;
  });
  out << '\n';
  for (const Record& r : records) {
    first = true;
    fields(r, [&](const char*, const auto& v) {
      out << (first ? "" : ",") << v;
      first = false;
    });
    out << '\n';
  }
}

/// The names of stability_row_fields(), in order.
inline std::vector<std::string> stability_row_names() {
  return field_names<StabilityRow>([](auto& r, auto&& v) { stability_row_fields(r, v); });
}

/// The names of accuracy_row_fields(), in order.
inline std::vector<std::string> accuracy_row_names() {
  return field_names<AccuracyRow>([](auto& r, auto&& v) { accuracy_row_fields(r, v); });
}

/// The names of passivity_row_fields(), in order.
inline std::vector<std::string> passivity_row_names() {
  return field_names<PassivityRow>([](auto& r, auto&& v) { passivity_row_fields(r, v); });
}

}  // namespace numen::sim
