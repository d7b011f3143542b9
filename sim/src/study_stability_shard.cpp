/// @file study_stability_shard.cpp
/// The shard file of `numen study stability` and the merge of a set of them
/// (study_stability.hpp, study_shard.hpp; format: docs/studies.md "Shard files").

#include <string>
#include <vector>

#include "numen/sim/scene.hpp"
#include "numen/sim/study_stability.hpp"
#include "numen/sim/study_stability_cases.hpp"
#include "numen/version.hpp"
#include "study_shard_json.hpp"

namespace numen::sim {
namespace {

using shard::Json;

/// The members of a row, by the names of the columns of stability_<family>.csv.
template <class Row, class Visit>
void row_fields(Row& r, Visit&& v) {
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

/// The members of a boundary measurement (stability_boundary.csv).
template <class Boundary, class Visit>
void boundary_fields(Boundary& b, Visit&& v) {
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

/// What fixes the plan and every row: the options, the build's left-out cases, numen's version.
Json manifest(const StabilityOptions& o, const StabilityResult& r) {
  Json m = Json::object();
  m["numen"] = NUMEN_VERSION;
  m["quick"] = o.quick;
  m["families"] = o.families.empty() ? stability_family_names() : o.families;
  Json integrators = Json::array();
  for (core::Integrator i : stability::integrators_of(o)) integrators.push_back(to_string(i));
  m["integrators"] = integrators;
  m["grid_steps"] = o.grid_steps;
  m["limits"] = {{"energy_factor", shard::number(o.limits.energy_factor)},
                 {"energy_floor_j", shard::number(o.limits.energy_floor_j)},
                 {"penetration_factor", shard::number(o.limits.penetration_factor)}};
  m["skipped"] = r.skipped;
  m["cases"] = r.cases;
  return m;
}

}  // namespace

std::string stability_shard_document(const StabilityResult& result,
                                     const StabilityOptions& options) {
  shard::ResultsByCase results(result.shard, result.cases, {"rows", "boundaries"});
  for (const StabilityRow& r : result.rows)
    results.add(r.case_index, "rows",
                shard::record_json(r, [](auto& x, auto&& v) { row_fields(x, v); }));
  for (const StabilityBoundary& b : result.boundaries)
    results.add(b.case_index, "boundaries",
                shard::record_json(b, [](auto& x, auto&& v) { boundary_fields(x, v); }));
  return shard::document("stability", result.shard, manifest(options, result), result.wall_s,
                         results.array());
}

StabilityResult merge_stability_shards(const std::string& dir) {
  const shard::ShardSet set = shard::read_shard_set(dir, "stability");
  StabilityResult result;
  result.skipped = set.skipped;
  result.cases = static_cast<std::int64_t>(set.results.size());
  for (std::size_t k = 0; k < set.results.size(); ++k) {
    const std::string& file = set.files[k % set.files.size()];
    const auto index = static_cast<std::int64_t>(k);
    shard::read_list(
        set.results[k], "rows", [](auto& x, auto&& v) { row_fields(x, v); }, index, file,
        result.rows);
    shard::read_list(
        set.results[k], "boundaries", [](auto& x, auto&& v) { boundary_fields(x, v); }, index, file,
        result.boundaries);
  }
  for (double w : set.wall_s) result.wall_s += w;
  return result;
}

}  // namespace numen::sim
