/// @file study_shard.cpp
/// Shards of a study: parsing, the Slurm array variables, file names, the atomic write and the
/// checked set of shard files (study_shard.hpp, study_shard_json.hpp).

#include "numen/sim/study/study_shard.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <stdexcept>

#include "numen/sim/input/input_error.hpp"
#include "input/json_input.hpp"
#include "study_shard_json.hpp"

namespace numen::sim {
namespace {

/// A decimal integer in [0, kMaxShards] filling all of `text`, or nullopt.
std::optional<int> whole_decimal(std::string_view text) {
  if (text.empty() || text.size() > 9) return std::nullopt;
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v < 0 || v > kMaxShards)
    return std::nullopt;
  return v;
}

std::string quoted_visible(std::string_view text) {
  return "\"" + InputError::visible(text, true) + "\"";
}

/// "<study>-shard-<I>-of-<N>.json" → (study, shard), study "stability", "accuracy" or
/// "passivity"; nullopt
/// for any other name.
std::optional<std::pair<std::string, Shard>> parse_file_name(const std::string& name) {
  const std::string_view n(name);
  const std::size_t at = n.find("-shard-"), of = n.rfind("-of-");
  if (at == std::string_view::npos || of == std::string_view::npos || of < at || n.size() < 5 ||
      n.substr(n.size() - 5) != ".json")
    return std::nullopt;
  const auto i = whole_decimal(n.substr(at + 7, of - at - 7));
  const auto c = whole_decimal(n.substr(of + 4, n.size() - 5 - of - 4));
  const std::string study(n.substr(0, at));
  if (!i || !c || *c < 1 || *i >= *c ||
      (study != "stability" && study != "accuracy" && study != "passivity"))
    return std::nullopt;
  return std::make_pair(study, Shard{*i, *c});
}

/// The shard files in `dir`: study → N → index → path.
std::map<std::string, std::map<int, std::map<int, std::string>>> shard_files(
    const std::filesystem::path& dir) {
  if (!std::filesystem::is_directory(dir))
    throw InputError(dir.string(), 0, 0, "", "not a directory");
  std::map<std::string, std::map<int, std::map<int, std::string>>> found;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    if (const auto p = parse_file_name(e.path().filename().string()))
      found[p->first][p->second.count][p->second.index] = e.path().string();
  }
  return found;
}

std::string join_indices(const std::vector<int>& v) {
  std::string s;
  for (int i : v) s += (s.empty() ? "" : ", ") + std::to_string(i);
  return s;
}

}  // namespace

Shard parse_shard(std::string_view text, const std::string& key) {
  const std::size_t slash = text.find('/');
  const std::string expected = " (expected I/N: shard I of N, 0 <= I < N, e.g. 0/4)";
  if (slash == std::string_view::npos)
    throw InputError("", 0, 0, key, quoted_visible(text) + " has no '/'" + expected);
  const auto i = whole_decimal(text.substr(0, slash));
  const auto n = whole_decimal(text.substr(slash + 1));
  if (!i)
    throw InputError(
        "", 0, 0, key,
        "shard index in " + quoted_visible(text) + " is not a whole number" + expected);
  if (!n || *n < 1)
    throw InputError("", 0, 0, key,
                     "shard count in " + quoted_visible(text) +
                         " is not a whole number from 1 to " + std::to_string(kMaxShards) +
                         expected);
  if (*i >= *n)
    throw InputError("", 0, 0, key,
                     "shard index " + std::to_string(*i) + " is not below the count " +
                         std::to_string(*n) + expected);
  return Shard{*i, *n};
}

void check_shard(const Shard& s) {
  if (s.count < 1 || s.index < 0 || s.index >= s.count)
    throw InputError("", 0, 0, "shard",
                     std::to_string(s.index) + "/" + std::to_string(s.count) +
                         " is not a shard I/N, 0 <= I < N");
}

std::optional<Shard> shard_from_environment(const std::function<const char*(const char*)>& lookup) {
  constexpr const char* kId = "SLURM_ARRAY_TASK_ID";
  constexpr const char* kCount = "SLURM_ARRAY_TASK_COUNT";
  const char* id = lookup(kId);
  const char* count = lookup(kCount);
  if (id == nullptr && count == nullptr) return std::nullopt;
  if (id == nullptr) throw InputError("", 0, 0, kId, std::string("not set, but ") + kCount + " is");
  if (count == nullptr)
    throw InputError("", 0, 0, kCount, std::string("not set, but ") + kId + " is");
  const auto n = whole_decimal(count);
  if (!n || *n < 1)
    throw InputError(
        "", 0, 0, kCount,
        quoted_visible(count) + " is not a whole number from 1 to " + std::to_string(kMaxShards));
  const auto i = whole_decimal(id);
  if (!i) throw InputError("", 0, 0, kId, quoted_visible(id) + " is not a whole number");
  if (*i >= *n)
    throw InputError("", 0, 0, kId,
                     std::to_string(*i) + " is not below " + kCount + " = " + std::to_string(*n) +
                         " (number the array from 0: sbatch --array=0-" + std::to_string(*n - 1) +
                         ")");
  return Shard{*i, *n};
}

std::string shard_file_name(const std::string& study, const Shard& shard) {
  return study + "-shard-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count) +
         ".json";
}

namespace {

/// Writes `content` into a new temporary file beside `path` (".NAME.XXXXXX", mkstemp), with the
/// mode a plain create would give it, flushed to disk (fsync); returns its path. Throws
/// std::runtime_error naming `path` and the system's reason (the temporary file removed).
std::string write_temporary(const std::filesystem::path& path, std::string_view content) {
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
  std::string tmp = (dir / ("." + path.filename().string() + ".XXXXXX")).string();
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0)
    throw std::runtime_error("cannot create a temporary file in " + dir.string() + ": " +
                             std::strerror(errno));
  const auto fail = [&](const char* what) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw std::runtime_error(std::string("cannot ") + what + " " + path.string() + ": " +
                             std::strerror(err));
  };
  for (std::size_t done = 0; done < content.size();) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail("write");
    done += static_cast<std::size_t>(n);
  }
  // mkstemp makes the file 0600; give it what a plain create would (0666 less the umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) fail("set the mode of");
  if (::fsync(fd) != 0) fail("flush");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write " + path.string() + ": " + std::strerror(err));
  }
  return tmp;
}

/// Renames temporary file `tmp` onto `path`; throws std::runtime_error (`tmp` removed).
void rename_onto(const std::string& tmp, const std::filesystem::path& path) {
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot rename " + tmp + " to " + path.string() + ": " +
                             std::strerror(err));
  }
}

}  // namespace

void write_file_atomically(const std::filesystem::path& path, std::string_view content) {
  rename_onto(write_temporary(path, content), path);
}

void write_files_atomically(const std::filesystem::path& dir, const OutputFiles& files) {
  std::vector<std::string> written;  // the temporary files, in the order of `files`
  try {
    for (const auto& [name, content] : files)
      written.push_back(write_temporary(dir / name, content));
  } catch (...) {
    for (const std::string& tmp : written) ::unlink(tmp.c_str());
    throw;
  }
  for (std::size_t i = 0; i < files.size(); ++i) {
    try {
      rename_onto(written[i], dir / files[i].first);
    } catch (...) {
      for (std::size_t j = i + 1; j < written.size(); ++j) ::unlink(written[j].c_str());
      throw;
    }
  }
}

std::string format_case_line(const StudyCase& c) {
  return std::to_string(c.index) + "\t" + c.family + "\t" + c.name + "\t" + c.parameters;
}

std::string study_of_shard_dir(const std::filesystem::path& dir) {
  const auto found = shard_files(dir);
  if (found.empty())
    throw InputError(dir.string(), 0, 0, "",
                     "no shard files (<study>-shard-<I>-of-<N>.json) in this directory");
  if (found.size() > 1) {
    std::string studies;
    for (const auto& [s, files] : found) studies += (studies.empty() ? "" : ", ") + s;
    throw InputError(dir.string(), 0, 0, "",
                     "shard files of several studies (" + studies + "): merge one per directory");
  }
  return found.begin()->first;
}

namespace shard {

Json number(double v) {
  if (std::isfinite(v)) return v;
  if (std::isnan(v)) return std::signbit(v) ? "-nan" : "nan";
  return v > 0 ? "inf" : "-inf";
}

double to_double(const Json& j, const std::string& file, const std::string& key) {
  if (j.is_number()) return j.get<double>();
  if (j.is_string()) {
    const std::string& s = j.get_ref<const std::string&>();
    if (s == "nan" || s == "-nan" || s == "inf" || s == "-inf")
      return std::strtod(s.c_str(), nullptr);
  }
  throw InputError(file, 0, 0, key, "not a number: " + json_input::shown(j));
}

const Json& member(const Json& j, const char* key, const std::string& file,
                   const std::string& where) {
  if (!j.is_object() || !j.contains(key))
    throw InputError(file, 0, 0, where + key, "missing (not a shard file of this numen?)");
  return j.at(key);
}

Json value(const std::vector<double>& v) {
  Json a = Json::array();
  for (double x : v) a.push_back(number(x));
  return a;
}

void read(const Json& j, double& out, const std::string& file, const std::string& key) {
  out = to_double(j, file, key);
}

void read(const Json& j, std::int64_t& out, const std::string& file, const std::string& key) {
  if (!j.is_number_integer())
    throw InputError(file, 0, 0, key, "not an integer: " + json_input::shown(j));
  if (j.is_number_unsigned() && j.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX))
    throw InputError(file, 0, 0, key, "out of range: " + json_input::shown(j));
  out = j.get<std::int64_t>();
}

void read(const Json& j, int& out, const std::string& file, const std::string& key) {
  std::int64_t v = 0;
  read(j, v, file, key);
  if (v < INT_MIN || v > INT_MAX)
    throw InputError(file, 0, 0, key, "out of range: " + json_input::shown(j));
  out = static_cast<int>(v);
}

void read(const Json& j, bool& out, const std::string& file, const std::string& key) {
  if (!j.is_boolean())
    throw InputError(file, 0, 0, key, "not true or false: " + json_input::shown(j));
  out = j.get<bool>();
}

void read(const Json& j, std::string& out, const std::string& file, const std::string& key) {
  if (!j.is_string()) throw InputError(file, 0, 0, key, "not a string: " + json_input::shown(j));
  out = j.get<std::string>();
}

void read(const Json& j, std::vector<double>& out, const std::string& file,
          const std::string& key) {
  if (!j.is_array()) throw InputError(file, 0, 0, key, "not an array: " + json_input::shown(j));
  out.clear();
  for (std::size_t i = 0; i < j.size(); ++i)
    out.push_back(to_double(j[i], file, key + "[" + std::to_string(i) + "]"));
}

ResultsByCase::ResultsByCase(const Shard& shard, std::int64_t cases,
                             std::initializer_list<const char*> lists)
    : shard_(shard) {
  for (std::int64_t k = shard.index; k < cases; k += shard.count) {
    Json e = Json::object();
    e["case"] = k;
    for (const char* l : lists) e[l] = Json::array();
    by_case_.emplace(k, std::move(e));
  }
}

void ResultsByCase::add(std::int64_t k, const char* list, Json item) {
  const auto it = by_case_.find(k);
  if (it == by_case_.end())
    throw std::logic_error("a result of case " + std::to_string(k) + ", not of shard " +
                           std::to_string(shard_.index) + "/" + std::to_string(shard_.count));
  it->second[list].push_back(std::move(item));
}

Json ResultsByCase::array() const {
  Json a = Json::array();
  for (const auto& [k, e] : by_case_) a.push_back(e);
  return a;
}

std::string document(const std::string& study, const Shard& s, const Json& manifest, double wall_s,
                     const Json& results) {
  Json doc = Json::object();
  doc["format"] = kFormat;
  doc["study"] = study;
  doc["shard"] = s.index;
  doc["shards"] = s.count;
  doc["manifest"] = manifest;
  doc["wall_s"] = number(wall_s);
  doc["results"] = results;
  return doc.dump(1) + "\n";
}

void expect_records(const std::string& file, std::int64_t case_index, const char* list,
                    std::size_t got, std::size_t want, const std::string& why) {
  if (got == want) return;
  throw InputError(file, 0, 0, "case " + std::to_string(case_index) + "." + list,
                   std::to_string(got) + " in the file, but the study's plan gives the case " +
                       std::to_string(want) + (why.empty() ? "" : " (" + why + ")") +
                       ": the shard that ran it did not write it whole");
}

ShardSet read_shard_set(const std::filesystem::path& dir, const std::string& study) {
  const auto found = shard_files(dir);
  const auto it = found.find(study);
  if (it == found.end())
    throw InputError(dir.string(), 0, 0, "",
                     "no " + study + " shard files (" + study + "-shard-<I>-of-<N>.json)");
  const auto& by_count = it->second;
  if (by_count.size() > 1) {
    std::string what;
    for (const auto& [n, files] : by_count) {
      what += (what.empty() ? "" : "; ") + std::string("N = ") + std::to_string(n) + ": ";
      std::string names;
      for (const auto& [i, path] : files)
        names += (names.empty() ? "" : ", ") + std::filesystem::path(path).filename().string();
      what += names;
    }
    throw InputError(dir.string(), 0, 0, "", "mismatched shard counts (" + what + ")");
  }
  ShardSet set;
  set.count = by_count.begin()->first;
  const auto& files = by_count.begin()->second;
  std::vector<int> missing;
  for (int i = 0; i < set.count; ++i)
    if (files.find(i) == files.end()) missing.push_back(i);
  if (!missing.empty()) {
    std::string names;
    for (int i : missing)
      names += (names.empty() ? "" : ", ") + shard_file_name(study, {i, set.count});
    throw InputError(dir.string(), 0, 0, "",
                     "missing shard" + std::string(missing.size() > 1 ? "s " : " ") +
                         join_indices(missing) + " of " + std::to_string(set.count) + " (" + names +
                         ")");
  }
  // The results by case index, below `cases` (manifest.cases): a map, not a vector of
  // `cases` entries, so that a damaged count cannot make the merge allocate it.
  std::map<std::size_t, Json> by_case;
  std::size_t cases = 0;
  for (const auto& file : files) {
    // Named variables, not a structured binding: the lambda below captures `path`, which
    // clang 14 (the fuzz and ASan builds) refuses for a binding (P1091, clang 16).
    const int index = file.first;
    const std::string& path = file.second;
    std::ifstream in(path, std::ios::binary);
    const std::string text(std::istreambuf_iterator<char>(in), {});
    if (!in && !in.eof())
      throw InputError(path, 0, 0, "", std::string("cannot read: ") + std::strerror(errno));
    json_input::SyntaxError syntax;
    const Json doc = json_input::parse<Json>(text, syntax);
    if (doc.is_discarded()) {
      const auto [line, column] = json_input::line_column(text, syntax.byte);
      throw InputError(path, line, column, "",
                       std::string("not a shard file: ") + (syntax.too_deep ? "" : "not JSON: ") +
                           syntax.reason);
    }
    const auto expect = [&](const char* key, const Json& want) {
      const Json& got = member(doc, key, path, "");
      if (got != want)
        throw InputError(path, 0, 0, key,
                         json_input::shown(got) + ", expected " + json_input::shown(want));
    };
    expect("format", kFormat);
    expect("study", study);
    expect("shard", index);
    expect("shards", set.count);
    const Json& manifest = member(doc, "manifest", path, "");
    if (set.files.empty()) {
      set.manifest = manifest;
      const Json& count = member(manifest, "cases", path, "manifest.");
      if (!count.is_number_unsigned())
        throw InputError(path, 0, 0, "manifest.cases", "not a count: " + json_input::shown(count));
      cases = count.get<std::size_t>();
    } else if (manifest != set.manifest) {
      std::string key;  // the first option that differs
      for (const auto& [k, v] : set.manifest.items())
        if (key.empty() && (!manifest.contains(k) || manifest.at(k) != v)) key = k;
      for (const auto& [k, v] : manifest.items())
        if (key.empty() && !set.manifest.contains(k)) key = k;
      const auto shown = [&](const Json& m) {
        return m.contains(key) ? json_input::shown(m.at(key)) : std::string("absent");
      };
      // The key is the file's: quoted_visible by its first bytes, as the values are.
      const std::string named = key.size() > json_input::kShownBytes
                                    ? key.substr(0, json_input::kShownBytes) + "..."
                                    : key;
      throw InputError(path, 0, 0, "manifest." + named,
                       shown(manifest) + ", but " + shown(set.manifest) + " in " +
                           set.files.front() +
                           ": the shards ran with different options, grid or build");
    }
    set.files.push_back(path);
    set.wall_s.push_back(to_double(member(doc, "wall_s", path, ""), path, "wall_s"));
    const Json& results = member(doc, "results", path, "");
    if (!results.is_array()) throw InputError(path, 0, 0, "results", "not an array");
    for (std::size_t r = 0; r < results.size(); ++r) {
      const std::string where = "results[" + std::to_string(r) + "].";
      const Json& k = member(results[r], "case", path, where);
      if (!k.is_number_unsigned() || k.get<std::size_t>() >= cases)
        throw InputError(path, 0, 0, where + "case",
                         json_input::shown(k) + " is not a case index below " +
                             std::to_string(cases));
      const std::size_t c = k.get<std::size_t>();
      if (static_cast<int>(c % static_cast<std::size_t>(set.count)) != index)
        throw InputError(path, 0, 0, where + "case",
                         "case " + std::to_string(c) + " belongs to shard " +
                             std::to_string(c % static_cast<std::size_t>(set.count)));
      if (!by_case.emplace(c, results[r]).second)
        throw InputError(path, 0, 0, where + "case", "case " + std::to_string(c) + " twice");
    }
  }
  const Json& skipped = member(set.manifest, "skipped", set.files.front(), "manifest.");
  if (!skipped.is_array())
    throw InputError(set.files.front(), 0, 0, "manifest.skipped",
                     "not an array of case names: " + json_input::shown(skipped));
  for (std::size_t i = 0; i < skipped.size(); ++i) {
    if (!skipped[i].is_string())
      throw InputError(set.files.front(), 0, 0, "manifest.skipped[" + std::to_string(i) + "]",
                       "not text: " + json_input::shown(skipped[i]));
    set.skipped.push_back(skipped[i].get<std::string>());
  }
  // Every case below `cases` is present: the first absent one is named (the loop stops there,
  // after at most as many cases as the files hold).
  for (std::size_t c = 0; c < cases; ++c) {
    const auto it = by_case.find(c);
    if (it == by_case.end())
      throw InputError(set.files[c % static_cast<std::size_t>(set.count)], 0, 0, "results",
                       "case " + std::to_string(c) + " is missing");
    set.results.push_back(std::move(it->second));
  }
  return set;
}

}  // namespace shard
}  // namespace numen::sim
