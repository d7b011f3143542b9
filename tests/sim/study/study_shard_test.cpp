/// @file study_shard_test.cpp
/// Shards of a study (study_shard.hpp): "I/N" and the Slurm array variables with their errors,
/// the assignment of case k to shard k mod N, file names, the atomic write, the directory's study.

#include "numen/sim/study/study_shard.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "child_process.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/study/study_stability.hpp"
#include "temp_dir.hpp"

namespace numen::sim {
namespace {

using test::TempDir;

/// The InputError `f` throws (fails the test if it throws none).
template <class F>
InputError error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError";
  return InputError("", 0, 0, "", "");
}

TEST(StudyShard, ParsesIndexAndCount) {
  const Shard a = parse_shard("0/1");
  EXPECT_EQ(a.index, 0);
  EXPECT_EQ(a.count, 1);
  const Shard b = parse_shard("3/4");
  EXPECT_EQ(b.index, 3);
  EXPECT_EQ(b.count, 4);
  const Shard c = parse_shard("999/1000");
  EXPECT_EQ(c.index, 999);
}

TEST(StudyShard, RefusesMalformedShardsNamingTheOption) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"4/4", "shard index 4 is not below the count 4"},
      {"1/0", "shard count in \"1/0\" is not a whole number from 1"},
      {"-1/4", "shard index in \"-1/4\" is not a whole number"},
      {"+1/4", "shard index in \"+1/4\" is not a whole number"},
      {"a/4", "shard index in \"a/4\" is not a whole number"},
      {"1/4x", "shard count in \"1/4x\" is not a whole number"},
      {" 1/4", "shard index in \" 1/4\" is not a whole number"},
      {"14", "\"14\" has no '/'"},
      {"", "\"\" has no '/'"},
      {"1/2/3", "shard count in \"1/2/3\""},
      {"0/99999999999", "shard count in \"0/99999999999\""},
  };
  for (const auto& [text_, message] : bad) {
    const auto& text = text_;  // clang 14 cannot capture a structured binding (P1091)
    const InputError e = error_of([&] { (void)parse_shard(text, "--shard"); });
    EXPECT_EQ(e.key(), "--shard") << text;
    EXPECT_NE(e.message().find(message), std::string::npos) << text << ": " << e.what();
  }
}

/// A lookup of the given variables only.
std::function<const char*(const char*)> environment(std::map<std::string, std::string> vars) {
  return [vars = std::move(vars)](const char* name) -> const char* {
    const auto it = vars.find(name);
    return it == vars.end() ? nullptr : it->second.c_str();
  };
}

TEST(StudyShard, SlurmArrayVariablesGiveTheShard) {
  EXPECT_FALSE(shard_from_environment(environment({})).has_value());
  const auto s = shard_from_environment(
      environment({{"SLURM_ARRAY_TASK_ID", "2"}, {"SLURM_ARRAY_TASK_COUNT", "4"}}));
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->index, 2);
  EXPECT_EQ(s->count, 4);
}

TEST(StudyShard, MalformedSlurmArrayVariableIsNamed) {
  struct Bad {
    std::map<std::string, std::string> vars;
    std::string key, message;
  };
  const std::vector<Bad> bad = {
      {{{"SLURM_ARRAY_TASK_ID", "1"}},
       "SLURM_ARRAY_TASK_COUNT",
       "not set, but SLURM_ARRAY_TASK_ID"},
      {{{"SLURM_ARRAY_TASK_COUNT", "4"}},
       "SLURM_ARRAY_TASK_ID",
       "not set, but SLURM_ARRAY_TASK_COUNT"},
      {{{"SLURM_ARRAY_TASK_ID", "x"}, {"SLURM_ARRAY_TASK_COUNT", "4"}},
       "SLURM_ARRAY_TASK_ID",
       "\"x\" is not a whole number"},
      {{{"SLURM_ARRAY_TASK_ID", "0"}, {"SLURM_ARRAY_TASK_COUNT", "0"}},
       "SLURM_ARRAY_TASK_COUNT",
       "\"0\" is not a whole number from 1"},
      {{{"SLURM_ARRAY_TASK_ID", "0"}, {"SLURM_ARRAY_TASK_COUNT", "4 "}},
       "SLURM_ARRAY_TASK_COUNT",
       "\"4 \" is not a whole number"},
      // An array numbered from 1 (--array=1-4): the last task is 4 of 4.
      {{{"SLURM_ARRAY_TASK_ID", "4"}, {"SLURM_ARRAY_TASK_COUNT", "4"}},
       "SLURM_ARRAY_TASK_ID",
       "4 is not below SLURM_ARRAY_TASK_COUNT = 4 (number the array from 0: sbatch --array=0-3)"},
  };
  for (const Bad& b : bad) {
    const InputError e = error_of([&] { (void)shard_from_environment(environment(b.vars)); });
    EXPECT_EQ(e.key(), b.key) << e.what();
    EXPECT_NE(e.message().find(b.message), std::string::npos) << e.what();
  }
}

TEST(StudyShard, EveryCaseBelongsToExactlyOneShard) {
  for (int n : {1, 2, 3, 4, 7}) {
    for (std::int64_t k = 0; k < 50; ++k) {
      int owners = 0;
      for (int i = 0; i < n; ++i) {
        const bool owns = Shard{i, n}.owns(k);
        owners += owns ? 1 : 0;
        if (owns) {
          EXPECT_EQ(k % n, i);
        }
      }
      EXPECT_EQ(owners, 1) << "case " << k << " of " << n << " shards";
    }
  }
}

TEST(StudyShard, FileNameAndCaseLine) {
  EXPECT_EQ(shard_file_name("stability", {2, 4}), "stability-shard-2-of-4.json");
  EXPECT_EQ(format_case_line({7, "coupling", "coupling-damped", "integrator=trapezoidal h=0.01"}),
            "7\tcoupling\tcoupling-damped\tintegrator=trapezoidal h=0.01");
}

TEST(StudyShard, AtomicWriteReplacesTheFileAndLeavesNoTemporary) {
  TempDir dir;
  const std::filesystem::path path = dir / "a.json";
  write_file_atomically(path, "first, longer content\n");
  EXPECT_EQ(test::read_file(path.string()), "first, longer content\n");
  write_file_atomically(path, "second\n");
  EXPECT_EQ(test::read_file(path.string()), "second\n");
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    ++files;
    EXPECT_EQ(e.path().filename(), "a.json");
  }
  EXPECT_EQ(files, 1);
  // The mode a plain create gives (0666 less the umask), not mkstemp's 0600.
  const auto perms = std::filesystem::status(path).permissions();
  EXPECT_NE(perms & std::filesystem::perms::owner_read, std::filesystem::perms::none);
  EXPECT_NE(perms & std::filesystem::perms::group_read, std::filesystem::perms::none);
}

TEST(StudyShard, AtomicWriteIntoAMissingDirectoryNamesIt) {
  TempDir dir;
  const std::filesystem::path path = dir / "missing" / "a.json";
  try {
    write_file_atomically(path, "x");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "missing").string()), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));
}

// A set of output files (a study's CSV files) is written whole or not at all: one that cannot
// be written leaves the files before it as they were, and no temporary file. The CSV writers
// wrote file by file, so that a failure left the first files of the set new, the rest old.
TEST(StudyShard, AFileSetIsWrittenWholeOrNotAtAll) {
  TempDir dir;
  dir.write("a.csv", "old\n");
  try {
    write_files_atomically(dir.path(), {{"a.csv", "new\n"}, {"missing/b.csv", "x"}});
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot create a temporary file in " +
                                         (dir / "missing").string() +
                                         ": No such file or directory");
  }
  EXPECT_EQ(test::read_file((dir / "a.csv").string()), "old\n");
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"a.csv"});
  write_files_atomically(dir.path(), {{"a.csv", "new\n"}, {"b.csv", "x"}});
  EXPECT_EQ(test::read_file((dir / "a.csv").string()), "new\n");
  EXPECT_EQ(test::read_file((dir / "b.csv").string()), "x");
}

TEST(StudyShard, DirectoryTellsItsStudy) {
  TempDir dir;
  EXPECT_NE(
      error_of([&] { (void)study_of_shard_dir(dir.path()); }).message().find("no shard files"),
      std::string::npos);
  dir.write("stability-shard-0-of-2.json", "{}");
  dir.write("notes-shard-0-of-2.json", "{}");      // not a study: ignored
  dir.write("stability-shard-2-of-2.json", "{}");  // index not below N: not a shard file name
  EXPECT_EQ(study_of_shard_dir(dir.path()), "stability");
  dir.write("accuracy-shard-0-of-1.json", "{}");
  EXPECT_NE(error_of([&] { (void)study_of_shard_dir(dir.path()); })
                .message()
                .find("several studies (accuracy, stability)"),
            std::string::npos);
  EXPECT_NE(error_of([&] { (void)study_of_shard_dir(dir / "nowhere"); })
                .message()
                .find("not a directory"),
            std::string::npos);
}

/// A stability row as a shard file holds it (compact JSON): a default StabilityRow, through
/// stability_shard_document().
std::string row_text() {
  StabilityResult r;
  r.cases = 1;
  r.rows.resize(1);
  r.rows[0].case_index = 0;
  const auto doc = nlohmann::ordered_json::parse(stability_shard_document(r, StabilityOptions{}));
  return doc["results"][0]["rows"][0].dump();
}

/// The "results" of shard_text(): two cases of one row each.
std::string results_text() {
  return R"([{"case": 0, "rows": [)" + row_text() + R"(], "boundaries": []}, )" +
         R"({"case": 1, "rows": [)" + row_text() + R"(], "boundaries": []}])";
}

/// A one-shard stability file (stability-shard-0-of-1.json) with `replace` done on the text of
/// a valid one of two cases (each with its one row, as the plan gives every case but the
/// boundary family's).
std::string shard_text(const std::string& from = "", const std::string& to = "") {
  std::string t = R"({"format": "numen study shard 1", "study": "stability", "shard": 0, )"
                  R"("shards": 1, "manifest": {"quick": true, "skipped": ["a"], "cases": 2}, )"
                  R"("wall_s": 0.5, "results": )" +
                  results_text() + "}";
  if (!from.empty()) {
    const std::size_t at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
  }
  return t;
}

// Every member of a shard file the merge reads is type-checked: a missing member or one of the
// wrong JSON type is an InputError naming the file and the key, never a json exception.
TEST(StudyShard, MergeNamesTheKeyOfAMemberOfTheWrongType) {
  TempDir dir;
  const std::string path = (dir / "stability-shard-0-of-1.json").string();
  dir.write("stability-shard-0-of-1.json", shard_text());
  const StabilityResult merged = merge_stability_shards(dir.path().string());
  EXPECT_EQ(merged.cases, 2);
  EXPECT_EQ(merged.skipped, std::vector<std::string>{"a"});
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {R"("format": "numen study shard 1")", R"("format": 1)", "format"},
      {R"("shard": 0)", R"("shard": "0")", "shard"},
      {R"("manifest": {"quick": true, "skipped": ["a"], "cases": 2})", R"("manifest": [])",
       "manifest.cases"},
      {R"("cases": 2)", R"("cases": "2")", "manifest.cases"},
      {R"("cases": 2)", R"("cases": -2)", "manifest.cases"},
      {R"("skipped": ["a"])", R"("skipped": 3)", "manifest.skipped"},
      {R"("skipped": ["a"])", R"("skipped": {"a": 1})", "manifest.skipped"},
      {R"("skipped": ["a"])", R"("skipped": [1])", "manifest.skipped[0]"},
      {R"("skipped": ["a"], )", "", "manifest.skipped"},
      {R"("wall_s": 0.5)", R"("wall_s": [0.5])", "wall_s"},
      {results_text(), R"({"case": 0})", "results"},
      {R"({"case": 0, "rows": [)", R"(5, {"x": [)", "results[0].case"},
      {R"({"case": 0,)", R"({"case": -1,)", "results[0].case"},
      {R"({"case": 0,)", R"({"case": "0",)", "results[0].case"},
      {R"({"case": 1, "rows": [)", R"({"case": 1, "rows": {}, "x": [)", "case 1.rows"},
      {R"({"case": 1, "rows": [)", R"({"case": 1, "rows": [7, )", "case 1.rows[0].family"},
      // Every case of the plan is one run: one row (or the boundary family's one boundary).
      {R"({"case": 1, "rows": [)" + row_text() + "]", R"({"case": 1, "rows": [])", "case 1.rows"},
      {R"({"case": 1, "rows": [)", R"({"case": 1, "rows": [)" + row_text() + ", ", "case 1.rows"},
      // A count far above the results: the first missing case is named (nothing of the
      // count's size is allocated).
      {R"("cases": 2)", R"("cases": 18446744073709551615)", "results"},
  };
  for (const auto& [from, to, key] : cases) {
    dir.write("stability-shard-0-of-1.json", shard_text(from, to));
    const InputError e = error_of([&] { (void)merge_stability_shards(dir.path().string()); });
    EXPECT_EQ(e.file(), path) << to << ": " << e.what();
    EXPECT_EQ(e.key(), key) << to << ": " << e.what();
  }
}

// A shard file that is not JSON is refused at the line and column of its syntax error.
TEST(StudyShard, MergeLocatesASyntaxErrorByLineAndColumn) {
  TempDir dir;
  dir.write("stability-shard-0-of-1.json", "{\n  \"format\": nul,\n}\n");
  const InputError e = error_of([&] { (void)merge_stability_shards(dir.path().string()); });
  EXPECT_EQ(e.file(), (dir / "stability-shard-0-of-1.json").string());
  EXPECT_EQ(e.line(), 2) << e.what();
  EXPECT_EQ(e.column(), 16) << e.what();
  EXPECT_NE(e.message().find("not a shard file: not JSON: syntax error"), std::string::npos)
      << e.what();
}

// Arrays and objects nested more than 64 deep are refused while the file is parsed, at the line
// and column of the bracket that opens level 65, whatever member holds them (one the merge
// does not read included); 200 000 deep in a case's entry crashed the merge (SIGSEGV: it
// copies each entry, and nlohmann's copy recurses).
TEST(StudyShard, MergeRefusesJsonNestedTooDeepAtItsPlace) {
  TempDir dir;
  const std::string path = (dir / "stability-shard-0-of-1.json").string();
  const std::string entry = R"({"case": 1, "rows": [)";
  const std::string before = shard_text(entry, "{\"case\": 1,\n  \"extra\": ");
  const std::size_t first = before.find("\"extra\": ") + 9;         // offset of its first '{'
  const int column = static_cast<int>(first - before.rfind('\n'));  // 1-based
  for (const std::size_t depth : {std::size_t{65}, std::size_t{200000}}) {
    std::string deep;
    for (std::size_t i = 0; i < depth; ++i) deep += R"({"a": )";
    deep += "1" + std::string(depth, '}') + R"(, "rows": [)";
    dir.write("stability-shard-0-of-1.json",
              shard_text(entry, "{\"case\": 1,\n  \"extra\": " + deep));
    const InputError e = error_of([&] { (void)merge_stability_shards(dir.path().string()); });
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.line(), 2) << e.what();
    // The entry is level 3 (the file's object, "results", the entry): level 65 opens at the
    // 62nd `{"a": ` (6 bytes each) of the line.
    EXPECT_EQ(e.column(), column + 61 * 6) << e.what();
    EXPECT_EQ(e.key(), "");
    EXPECT_EQ(e.message(), "not a shard file: arrays and objects nested more than 64 deep");
  }
}

// A syntax error quotes the token it stopped in by its first 40 bytes: nlohmann's message
// quoted a string without its closing quote whole (here 100 000 bytes).
TEST(StudyShard, MergeQuotesTheTokenOfASyntaxErrorShort) {
  TempDir dir;
  dir.write("stability-shard-0-of-1.json", "{\"format\": \"" + std::string(100000, 'x'));
  const InputError e = error_of([&] { (void)merge_stability_shards(dir.path().string()); });
  EXPECT_EQ(e.line(), 1);
  EXPECT_EQ(e.column(), 100013);
  EXPECT_EQ(e.message(),
            "not a shard file: not JSON: syntax error while parsing value - invalid string: "
            "missing closing quote; last read: '\"" +
                std::string(39, 'x') + "...'");
  // A token that holds nlohmann's own "'; expected " (a fuzz finding: the text after it was
  // taken for the parser's suffix and quoted whole) is cut as well.
  dir.write("stability-shard-0-of-1.json",
            "{\"format\": \"" + std::string(80, '[') + "'; expected " + std::string(3000, '[') + "\xff\"}");
  const InputError f = error_of([&] { (void)merge_stability_shards(dir.path().string()); });
  EXPECT_LT(f.message().size(), 200u) << f.message();
  EXPECT_EQ(f.message(),
            "not a shard file: not JSON: syntax error while parsing value - invalid string: "
            "ill-formed UTF-8 byte; last read: '\"" +
                std::string(39, '[') + "...'");
}

// A number beyond a double's range is refused where it stands (nlohmann reports it as an
// out_of_range without a place; it must not escape as an exception).
TEST(StudyShard, MergeLocatesANumberBeyondADoubleAtItsPlace) {
  TempDir dir;
  dir.write("stability-shard-0-of-1.json", "{\n  \"wall_s\": 6e6666,\n}\n");
  const InputError e = error_of([&] { (void)merge_stability_shards(dir.path().string()); });
  EXPECT_EQ(e.file(), (dir / "stability-shard-0-of-1.json").string());
  EXPECT_EQ(e.line(), 2) << e.what();
  EXPECT_EQ(e.column(), 13) << e.what();
  EXPECT_NE(e.message().find("number overflow parsing '6e6666'"), std::string::npos) << e.what();
}

}  // namespace
}  // namespace numen::sim
