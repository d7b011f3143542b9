#pragma once
/// @file study_shard_json.hpp
/// The shard file of a study (study_shard.hpp, docs/studies.md "Shard files"): one JSON object
///   {"format": "numen study shard 1", "study": "stability", "shard": I, "shards": N,
///    "manifest": {…, "cases": M}, "wall_s": …, "results": [{"case": k, …}, …]}
/// with "manifest" the options and plan of the study (the same in every shard of a set) and one
/// result per case of the shard. Numbers are written so that they read back to the same double:
/// finite ones as JSON numbers (17 significant digits), NaN and ±∞ as "nan", "-nan", "inf",
/// "-inf". Internal to numen::sim (study_*_shard.cpp).

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/study/study_shard.hpp"

namespace numen::sim::shard {

using Json = nlohmann::ordered_json;

/// Value of "format".
inline constexpr const char* kFormat = "numen study shard 1";

/// `v` as JSON: a number when finite, else "nan", "-nan" (sign bit set), "inf", "-inf".
Json number(double v);

/// Reads what number() wrote. Throws InputError(file, 0, 0, key, …) if `j` is neither.
double to_double(const Json& j, const std::string& file, const std::string& key);

/// The member `key` of object `j`; throws InputError(file, 0, 0, where + key, "missing") if absent.
const Json& member(const Json& j, const char* key, const std::string& file,
                   const std::string& where);

/// A field of a result as JSON: numbers through number(), integers, booleans, strings, arrays
/// of numbers.
inline Json value(double v) { return number(v); }
inline Json value(std::int64_t v) { return v; }
inline Json value(int v) { return v; }
inline Json value(bool v) { return v; }
inline Json value(const std::string& v) { return v; }
Json value(const std::vector<double>& v);

/// Reads what value() wrote into `out`. Throws InputError(file, 0, 0, key, …) for another type.
void read(const Json& j, double& out, const std::string& file, const std::string& key);
void read(const Json& j, std::int64_t& out, const std::string& file, const std::string& key);
void read(const Json& j, int& out, const std::string& file, const std::string& key);
void read(const Json& j, bool& out, const std::string& file, const std::string& key);
void read(const Json& j, std::string& out, const std::string& file, const std::string& key);
void read(const Json& j, std::vector<double>& out, const std::string& file, const std::string& key);

/// A record (`fields(record, visit)` calls visit(key, member) for each of its members) as a
/// JSON object, and back; `where` prefixes the keys in error messages ("results[3].rows[0].").
template <class Record, class Fields>
Json record_json(const Record& r, Fields&& fields) {
  Json j = Json::object();
  fields(r, [&j](const char* key, const auto& v) { j[key] = value(v); });
  return j;
}
template <class Record, class Fields>
Record record_from(const Json& j, Fields&& fields, const std::string& file,
                   const std::string& where) {
  Record r;
  fields(r, [&](const char* key, auto& v) {
    read(member(j, key, file, where), v, file, where + key);
  });
  return r;
}

/// The "results" of a shard file being built: one entry per case of `shard` (cases k ≡ I mod N
/// below `cases`), {"case": k, <list>: [], …} for each name in `lists`.
class ResultsByCase {
 public:
  ResultsByCase(const Shard& shard, std::int64_t cases, std::initializer_list<const char*> lists);
  /// Appends `item` to list `list` of case `k`; std::logic_error if k is not a case of the shard.
  void add(std::int64_t k, const char* list, Json item);
  /// The entries by case index.
  Json array() const;

 private:
  Shard shard_;
  std::map<std::int64_t, Json> by_case_;
};

/// Appends the records of list `list` of a case's result `entry` to `out`, read with `fields`
/// and given `case_index`; a member's key in an error reads "case K.<list>[i].<member>".
template <class Record, class Fields>
void read_list(const Json& entry, const char* list, Fields&& fields, std::int64_t case_index,
               const std::string& file, std::vector<Record>& out) {
  const std::string where = "case " + std::to_string(case_index) + "." + list;
  const Json& items = member(entry, list, file, "case " + std::to_string(case_index) + ".");
  if (!items.is_array()) throw InputError(file, 0, 0, where, "not an array");
  for (std::size_t i = 0; i < items.size(); ++i) {
    Record r = record_from<Record>(items[i], fields, file, where + "[" + std::to_string(i) + "].");
    r.case_index = case_index;
    out.push_back(std::move(r));
  }
}

/// Throws InputError(file, 0, 0, "case K.<list>", …) unless case `case_index` has `want`
/// records of list `list` (`got`): the plan of every study gives each case a known number of
/// records, and a shard file that lists a case with fewer or more is not merged. `why` (may be
/// empty) says what makes up `want`, e.g. "13 grid points and 6 bisection probes".
void expect_records(const std::string& file, std::int64_t case_index, const char* list,
                    std::size_t got, std::size_t want, const std::string& why);

/// The text of a shard file (pretty-printed JSON, one result per line is not required).
std::string document(const std::string& study, const Shard& shard, const Json& manifest,
                     double wall_s, const Json& results);

/// One list of records of a study's result: its name in a case's entry, the result's member
/// that holds it (records with a case_index) and its field list (study_fields.hpp).
template <class Result, class Record, class Fields>
struct RecordList {
  const char* name;
  std::vector<Record> Result::*records;
  Fields fields;
};
template <class Result, class Record, class Fields>
RecordList<Result, Record, Fields> record_list(const char* name,
                                               std::vector<Record> Result::*records,
                                               Fields fields) {
  return {name, records, fields};
}

/// A complete, consistent set of shard files, read back.
struct ShardSet {
  int count = 0;                     ///< N.
  Json manifest;                     ///< The manifest all N share.
  std::vector<Json> results;         ///< Every case's result, by case index 0 … cases − 1.
  std::vector<std::string> files;    ///< Path of shard 0 … N − 1.
  std::vector<double> wall_s;        ///< Wall time of shard 0 … N − 1 (s).
  std::vector<std::string> skipped;  ///< The manifest's "skipped": cases this build left out.
};

/// Reads the shard files of `study` in `dir` and checks them: one N for all (else InputError
/// "mismatched shard counts" listing the files per N), all N present (else InputError listing the
/// missing indices and file names), each a shard file of this study and index, the same manifest
/// (else InputError naming the file and the first differing option), every case k in the shard
/// k mod N exactly once and the cases 0 … M − 1 complete. Every error is an InputError naming
/// the file and the line and column of a syntax error, or the key of a member missing or of
/// the wrong JSON type or value; no json exception escapes. Allocates in proportion to the
/// files' size (never to a count they state).
ShardSet read_shard_set(const std::filesystem::path& dir, const std::string& study);

/// The shard file of `result` (a study's result: shard, cases, wall_s and the lists), each
/// record of the RecordLists in `lists` (a tuple) under its case.
template <class Result, class... Lists>
std::string shard_document(const std::string& study, const Result& result, const Json& manifest,
                           const std::tuple<Lists...>& lists) {
  return std::apply(
      [&](const Lists&... list) {
        ResultsByCase results(result.shard, result.cases, {list.name...});
        const auto add = [&](const auto& l) {
          for (const auto& r : result.*(l.records))
            results.add(r.case_index, l.name, record_json(r, l.fields));
        };
        (add(list), ...);
        return document(study, result.shard, manifest, result.wall_s, results.array());
      },
      lists);
}

/// Reads the shard set of `study` in `dir` (read_shard_set()) into one result: the skipped
/// cases, the case count, every case's records of the RecordLists in `lists` (a tuple) in case
/// order, and the summed wall time. Each case's records are checked by `check_case(one, k, file,
/// manifest)` before they join the result: `one` a Result holding case k's records only, `file`
/// the shard file that holds them; it throws InputError (expect_records(), or a value the
/// study's merge refuses) naming the file and the member.
template <class Result, class CheckCase, class... Lists>
Result merge_shard_set(const std::string& dir, const std::string& study,
                       const std::tuple<Lists...>& lists, CheckCase&& check_case) {
  const ShardSet set = read_shard_set(dir, study);
  Result result;
  result.skipped = set.skipped;
  result.cases = static_cast<std::int64_t>(set.results.size());
  for (std::size_t k = 0; k < set.results.size(); ++k) {
    const std::string& file = set.files[k % set.files.size()];
    const auto index = static_cast<std::int64_t>(k);
    Result one;
    std::apply(
        [&](const Lists&... list) {
          (read_list(set.results[k], list.name, list.fields, index, file, one.*(list.records)),
           ...);
        },
        lists);
    check_case(one, index, file, set.manifest);
    std::apply(
        [&](const Lists&... list) {
          ((result.*(list.records))
               .insert((result.*(list.records)).end(),
                       std::make_move_iterator((one.*(list.records)).begin()),
                       std::make_move_iterator((one.*(list.records)).end())),
           ...);
        },
        lists);
  }
  for (double w : set.wall_s) result.wall_s += w;
  return result;
}

}  // namespace numen::sim::shard
