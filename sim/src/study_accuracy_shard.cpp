/// @file study_accuracy_shard.cpp
/// The shard file of `numen study accuracy` and the merge of a set of them
/// (study_accuracy.hpp, study_shard.hpp; format: docs/studies.md "Shard files").

#include <string>
#include <vector>

#include "numen/sim/scene.hpp"
#include "numen/sim/study_accuracy.hpp"
#include "numen/version.hpp"
#include "study_shard_json.hpp"

namespace numen::sim {
namespace {

using shard::Json;

/// The members of a run, by the names of the columns of accuracy.csv.
template <class Row, class Visit>
void row_fields(Row& r, Visit&& v) {
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

/// The members of a fit (accuracy_orders.csv).
template <class Fit, class Visit>
void fit_fields(Fit& f, Visit&& v) {
  v("case", f.case_name);
  v("integrator", f.integrator);
  v("observed_order", f.observed_order);
  v("observed_order_rotation", f.observed_order_rotation);
  v("theoretical_order", f.theoretical_order);
  v("points", f.points);
  v("fit_dt_min_s", f.fit_dt_min);
  v("fit_dt_max_s", f.fit_dt_max);
  v("position_error_max_at_1ms_mm", f.error_at_1ms_mm);
  v("cpu_s_per_sim_s_at_1ms", f.cpu_at_1ms);
}

/// The members of a reference check (accuracy_references.csv).
template <class Check, class Visit>
void reference_fields(Check& c, Visit&& v) {
  v("case", c.case_name);
  v("reference_dt_s", c.reference_dt);
  v("position_difference_max_mm", c.position_difference_max_mm);
  v("orientation_difference_max_mrad", c.orientation_difference_max_mrad);
  v("cpu_s", c.cpu_s);
}

/// What fixes the plan and every row: the options, the build's left-out cases, numen's version.
Json manifest(const AccuracyOptions& o, const AccuracyResult& r) {
  Json m = Json::object();
  m["numen"] = NUMEN_VERSION;
  m["quick"] = o.quick;
  m["steps"] = shard::value(o.steps);
  m["cases_asked"] = o.cases;
  Json integrators = Json::array();
  for (core::Integrator i : o.integrators) integrators.push_back(to_string(i));
  m["integrators"] = integrators;
  m["horizon_s"] = shard::number(o.horizon_s);
  m["reference_dt"] = shard::number(o.reference_dt);
  m["fit_max_dt"] = shard::number(o.fit_max_dt);
  m["skipped"] = r.skipped;
  m["cases"] = r.cases;
  return m;
}

}  // namespace

std::string accuracy_shard_document(const AccuracyResult& result, const AccuracyOptions& options) {
  shard::ResultsByCase results(result.shard, result.cases, {"rows", "fits", "references"});
  for (const AccuracyRow& r : result.rows)
    results.add(r.case_index, "rows",
                shard::record_json(r, [](auto& x, auto&& v) { row_fields(x, v); }));
  for (const AccuracyFit& f : result.fits)
    results.add(f.case_index, "fits",
                shard::record_json(f, [](auto& x, auto&& v) { fit_fields(x, v); }));
  for (const ReferenceCheck& c : result.references)
    results.add(c.case_index, "references",
                shard::record_json(c, [](auto& x, auto&& v) { reference_fields(x, v); }));
  return shard::document("accuracy", result.shard, manifest(options, result), result.wall_s,
                         results.array());
}

AccuracyResult merge_accuracy_shards(const std::string& dir) {
  const shard::ShardSet set = shard::read_shard_set(dir, "accuracy");
  AccuracyResult result;
  result.skipped = set.skipped;
  result.cases = static_cast<std::int64_t>(set.results.size());
  for (std::size_t k = 0; k < set.results.size(); ++k) {
    const std::string& file = set.files[k % set.files.size()];
    const auto index = static_cast<std::int64_t>(k);
    shard::read_list(
        set.results[k], "rows", [](auto& x, auto&& v) { row_fields(x, v); }, index, file,
        result.rows);
    shard::read_list(
        set.results[k], "fits", [](auto& x, auto&& v) { fit_fields(x, v); }, index, file,
        result.fits);
    shard::read_list(
        set.results[k], "references", [](auto& x, auto&& v) { reference_fields(x, v); }, index,
        file, result.references);
  }
  for (double w : set.wall_s) result.wall_s += w;
  return result;
}

}  // namespace numen::sim
