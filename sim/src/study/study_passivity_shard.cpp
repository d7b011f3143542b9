/// @file study_passivity_shard.cpp
/// The shard file of `numen study passivity` and the merge of a set of them
/// (study_passivity.hpp, study_shard.hpp; format: docs/studies.md "Shard files").

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

}  // namespace

std::string passivity_shard_document(const PassivityResult& result,
                                     const PassivityOptions& options) {
  return shard::shard_document("passivity", result, passivity_manifest(options, result),
                               passivity_lists());
}

PassivityResult merge_passivity_shards(const std::string& dir) {
  return shard::merge_shard_set<PassivityResult>(dir, "passivity", passivity_lists());
}

}  // namespace numen::sim
