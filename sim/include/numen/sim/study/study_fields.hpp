#pragma once
/// @file study_fields.hpp
/// The one field list of each study record: `fields(record, visit)` calls
/// visit(name, member) for each member, in column order. The stability row's list writes
/// stability_<family>.csv, the shard files' rows and numen.study_stability's dicts; the
/// accuracy row's list writes accuracy.csv, the shard files' rows and numen.study_accuracy's
/// dicts (StudyFields.*). A member has one name in all of them.
/// Members are std::string, double, std::int64_t, int, bool or std::vector<double>.

#include <string>
#include <vector>

#include "numen/sim/study/study_accuracy.hpp"
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

/// The names `fields` visits, in order (e.g. field_names<StabilityRow>(stability_row_fields)).
template <class Record, class Fields>
std::vector<std::string> field_names(Fields&& fields) {
  Record r;
  std::vector<std::string> names;
  fields(r, [&names](const char* name, const auto&) { names.emplace_back(name); });
  return names;
}

/// The names of stability_row_fields(), in order.
inline std::vector<std::string> stability_row_names() {
  return field_names<StabilityRow>([](auto& r, auto&& v) { stability_row_fields(r, v); });
}

/// The names of accuracy_row_fields(), in order.
inline std::vector<std::string> accuracy_row_names() {
  return field_names<AccuracyRow>([](auto& r, auto&& v) { accuracy_row_fields(r, v); });
}

}  // namespace numen::sim
