/// @file study_stability_shard.cpp
/// The shard file of `numen study stability` and the merge of a set of them
/// (study_stability.hpp, study_shard.hpp; format: docs/studies.md "Shard files").

#include <string>
#include <tuple>
#include <vector>

#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "numen/sim/study/study_stability.hpp"
#include "numen/sim/study/study_stability_cases.hpp"
#include "numen/version.hpp"
#include "study_shard_json.hpp"

namespace numen::sim {
namespace {

using shard::Json;

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

/// The lists of a stability result in a shard file.
auto stability_lists() {
  return std::make_tuple(
      shard::record_list("rows", &StabilityResult::rows,
                         [](auto& x, auto&& v) { stability_row_fields(x, v); }),
      shard::record_list("boundaries", &StabilityResult::boundaries,
                         [](auto& x, auto&& v) { stability_boundary_fields(x, v); }));
}

/// What the plan gives case `k`: every case is one run, which gives one row, or for the
/// boundary family one boundary.
void check_stability_case(const StabilityResult& one, std::int64_t k, const std::string& file,
                          const Json&) {
  const char* why = "one run: its row, or the boundary family's boundary";
  if (one.boundaries.empty())
    shard::expect_records(file, k, "rows", one.rows.size(), 1, why);
  else if (one.rows.empty())
    shard::expect_records(file, k, "boundaries", one.boundaries.size(), 1, why);
  else
    shard::expect_records(file, k, "rows", one.rows.size(), 0, "a boundary case has no row");
}

}  // namespace

std::string stability_shard_document(const StabilityResult& result,
                                     const StabilityOptions& options) {
  return shard::shard_document("stability", result, manifest(options, result), stability_lists());
}

StabilityResult merge_stability_shards(const std::string& dir) {
  return shard::merge_shard_set<StabilityResult>(dir, "stability", stability_lists(),
                                                 check_stability_case);
}

}  // namespace numen::sim
