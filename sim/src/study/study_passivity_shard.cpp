/// @file study_passivity_shard.cpp
/// The shard file of `numen study passivity` and the merge of a set of them
/// (study_passivity.hpp, study_shard.hpp; format: docs/studies.md "Shard files").

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>

#include "numen/sim/study/study_fields.hpp"
#include "numen/sim/study/study_passivity.hpp"
#include "numen/version.hpp"
#include "study_shard_json.hpp"

namespace numen::sim {
namespace {

using shard::Json;

/// What fixes the plan and every row: the options and numen's version.
Json passivity_manifest(const PassivityOptions& o, const PassivityResult& r) {
  Json m = Json::object();
  m["numen"] = NUMEN_VERSION;
  m["quick"] = o.quick;
  m["tolerance"] = shard::number(o.tolerance);
  m["skipped"] = r.skipped;
  m["cases"] = r.cases;
  return m;
}

/// The lists of a passivity result in a shard file.
auto passivity_lists() {
  return std::make_tuple(
      shard::record_list("rows", &PassivityResult::rows,
                         [](auto& x, auto&& v) { passivity_row_fields(x, v); }),
      shard::record_list("boundaries", &PassivityResult::boundaries,
                         [](auto& x, auto&& v) { passivity_boundary_fields(x, v); }));
}

/// Throws InputError(file, 0, 0, "case K.<list>[i].<member>", …) if `v` is NaN.
void refuse_nan(double v, const std::string& file, std::int64_t k, const std::string& member,
                const std::string& what) {
  if (!std::isnan(v)) return;
  throw InputError(file, 0, 0, "case " + std::to_string(k) + "." + member,
                   "NaN (" + what + "): the shard's probe failed; rerun that shard");
}

/// What the plan gives case `k` (study_passivity.hpp, merge_passivity_shards()), and no NaN
/// that passivity_failures() would report.
void check_passivity_case(const PassivityResult& one, std::int64_t k, const std::string& file,
                          const Json& manifest) {
  bool quick = false;
  shard::read(shard::member(manifest, "quick", file, "manifest."), quick, file, "manifest.quick");
  shard::expect_records(file, k, "boundaries", one.boundaries.size(), 1, "one per configuration");
  const PassivityBoundary& b = one.boundaries.front();
  const std::size_t grid = passivity_grid(quick).size();
  if (b.evaluations < 0)
    throw InputError(file, 0, 0, "case " + std::to_string(k) + ".boundaries[0].evaluations",
                     std::to_string(b.evaluations) + ", not a count of probes");
  const auto probes = static_cast<std::size_t>(b.evaluations);
  shard::expect_records(
      file, k, "rows", one.rows.size(), grid + probes,
      std::to_string(grid) + " grid points and " + std::to_string(probes) + " bisection probes");
  for (std::size_t i = 0; i < one.rows.size(); ++i) {
    const PassivityRow& r = one.rows[i];
    const std::string row = "rows[" + std::to_string(i) + "].";
    char at[64];
    std::snprintf(at, sizeof at, "the energy at K = %g N/m", r.stiffness);
    refuse_nan(r.energy_min_j, file, k, row + "energy_min_j", at);
    refuse_nan(r.contact_energy_min_j, file, k, row + "contact_energy_min_j", at);
  }
  refuse_nan(b.k_max, file, k, "boundaries[0].k_max", "the boundary K_max");
}

}  // namespace

std::string passivity_shard_document(const PassivityResult& result,
                                     const PassivityOptions& options) {
  return shard::shard_document("passivity", result, passivity_manifest(options, result),
                               passivity_lists());
}

PassivityResult merge_passivity_shards(const std::string& dir) {
  return shard::merge_shard_set<PassivityResult>(dir, "passivity", passivity_lists(),
                                                 check_passivity_case);
}

}  // namespace numen::sim
