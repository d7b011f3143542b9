/// @file study_accuracy_shard.cpp
/// The shard file of `numen study accuracy` and the merge of a set of them
/// (study_accuracy.hpp, study_shard.hpp; format: docs/studies.md "Shard files").

#include <string>
#include <tuple>
#include <vector>

#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_accuracy.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "numen/version.hpp"
#include "study_shard_json.hpp"

namespace numen::sim {
namespace {

using shard::Json;

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

/// The lists of an accuracy result in a shard file.
auto accuracy_lists() {
  return std::make_tuple(shard::record_list("rows", &AccuracyResult::rows,
                                            [](auto& x, auto&& v) { accuracy_row_fields(x, v); }),
                         shard::record_list("fits", &AccuracyResult::fits,
                                            [](auto& x, auto&& v) { fit_fields(x, v); }),
                         shard::record_list("references", &AccuracyResult::references,
                                            [](auto& x, auto&& v) { reference_fields(x, v); }));
}

/// What the plan gives case `k` (merge_accuracy_shards()): one fit, one row per time step, and
/// for the first integrator of a case without a closed form one reference check.
void check_accuracy_case(const AccuracyResult& one, std::int64_t k, const std::string& file,
                         const Json& manifest) {
  bool quick = false;
  std::vector<double> steps;
  shard::read(shard::member(manifest, "quick", file, "manifest."), quick, file, "manifest.quick");
  shard::read(shard::member(manifest, "steps", file, "manifest."), steps, file, "manifest.steps");
  const Json& integrators = shard::member(manifest, "integrators", file, "manifest.");
  if (!integrators.is_array())
    throw InputError(file, 0, 0, "manifest.integrators", "not an array of integrator names");
  const std::size_t n_steps = steps.empty() ? accuracy_default_steps(quick).size() : steps.size();
  const std::size_t n_integrators =
      integrators.empty() ? accuracy_default_integrators().size() : integrators.size();
  shard::expect_records(file, k, "fits", one.fits.size(), 1, "one per case and integrator");
  shard::expect_records(file, k, "rows", one.rows.size(), n_steps, "one per time step of the grid");
  const std::string& name = one.fits.front().case_name;
  const bool first = static_cast<std::size_t>(k) % n_integrators == 0;
  const bool reference = first && !accuracy_case_has_closed_form(name);
  shard::expect_records(file, k, "references", one.references.size(), reference ? 1 : 0,
                        reference ? "the reference check of " + name + ", by its first integrator"
                        : first   ? name + " has a closed form, no reference run"
                                  : "reported by the case's first integrator only");
}

}  // namespace

std::string accuracy_shard_document(const AccuracyResult& result, const AccuracyOptions& options) {
  return shard::shard_document("accuracy", result, manifest(options, result), accuracy_lists());
}

AccuracyResult merge_accuracy_shards(const std::string& dir) {
  return shard::merge_shard_set<AccuracyResult>(dir, "accuracy", accuracy_lists(),
                                                check_accuracy_case);
}

}  // namespace numen::sim
