/// @file study_command_test.cpp
/// `numen study … --shard/--list` and `numen study merge` run as child processes
/// (sim/app/study_command.cpp, docs/studies.md): the Slurm array variables, a shard whose file
/// exists is skipped, refused values are "input rejected" (2) naming the option or variable, an
/// incomplete set is refused by index, and the merged CSV equals the one-process run's.

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "temp_dir.hpp"

namespace {

using numen::test::ChildResult;
using numen::test::read_file;
using numen::test::run_child;
using numen::test::TempDir;

const std::string kNumenCli = NUMEN_CLI;

/// `numen args…` with the Slurm array variables set to `id`/`count` ("" : unset).
ChildResult numen(const std::vector<std::string>& args, const TempDir& dir,
                  const std::string& id = "", const std::string& count = "") {
  std::vector<std::string> argv = {"/usr/bin/env", "-u", "SLURM_ARRAY_TASK_ID", "-u",
                                   "SLURM_ARRAY_TASK_COUNT"};
  if (!id.empty()) argv.push_back("SLURM_ARRAY_TASK_ID=" + id);
  if (!count.empty()) argv.push_back("SLURM_ARRAY_TASK_COUNT=" + count);
  argv.push_back(kNumenCli);
  argv.insert(argv.end(), args.begin(), args.end());
  return run_child(argv, dir.path().string(), 120);
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

TEST(StudyCommand, ListOfASlurmArrayTaskHasItsCasesOnly) {
  TempDir dir;
  const std::vector<std::string> args = {"study",    "stability", "--quick",
                                         "--family", "coupling",  "--list"};
  const ChildResult all = numen(args, dir);
  ASSERT_EQ(all.status, 0) << all.err;
  const std::vector<std::string> every = lines(all.out);
  // 2 ζ × integrators × 3 h × 6 m × 8 k (3 integrators or more)
  ASSERT_GE(every.size(), 864u);
  ASSERT_EQ(every.size() % 288, 0u);
  EXPECT_EQ(every[0],
            "0\tcoupling\tcoupling-undamped\tintegrator=implicit-euler h=0.0001 m=0.001 "
            "k=10 zeta=0");
  const ChildResult task = numen(args, dir, "1", "4");
  ASSERT_EQ(task.status, 0) << task.err;
  std::vector<std::string> want;
  for (std::size_t k = 1; k < every.size(); k += 4) want.push_back(every[k]);
  EXPECT_EQ(lines(task.out), want);
  // --shard wins over the variables.
  std::vector<std::string> with_option = args;
  with_option.insert(with_option.end(), {"--shard", "1/4"});
  EXPECT_EQ(numen(with_option, dir, "3", "4").out, task.out);
}

TEST(StudyCommand, RefusedShardsAreInputRejectedNamingTheOptionOrVariable) {
  TempDir dir;
  const ChildResult option =
      numen({"study", "stability", "--quick", "--list", "--shard", "2/2"}, dir);
  EXPECT_EQ(option.status, 2) << option.out;
  EXPECT_NE(option.err.find("--shard: shard index 2 is not below the count 2"), std::string::npos)
      << option.err;
  const ChildResult from_one = numen({"study", "accuracy", "--quick", "--list"}, dir, "4", "4");
  EXPECT_EQ(from_one.status, 2) << from_one.out;
  EXPECT_NE(from_one.err.find("SLURM_ARRAY_TASK_ID: 4 is not below SLURM_ARRAY_TASK_COUNT = 4"),
            std::string::npos)
      << from_one.err;
  const ChildResult half = numen({"study", "stability", "--quick", "--list"}, dir, "", "4");
  EXPECT_EQ(half.status, 2);
  EXPECT_NE(half.err.find("SLURM_ARRAY_TASK_ID: not set, but SLURM_ARRAY_TASK_COUNT is"),
            std::string::npos)
      << half.err;
}

TEST(StudyCommand, ShardWhoseFileExistsIsSkipped) {
  TempDir dir;
  const std::filesystem::path out = dir / "out";
  std::filesystem::create_directories(out);
  const std::string file = (out / "stability-shard-0-of-2.json").string();
  dir.write("out/stability-shard-0-of-2.json", "kept");
  const ChildResult r =
      numen({"study", "stability", "--quick", "--shard", "0/2", "--out", out.string()}, dir);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out, "shard 0/2: " + file + " exists, skipped\n");
  EXPECT_EQ(read_file(file), "kept");
}

TEST(StudyCommand, MergeRefusesAnIncompleteSetThenEqualsTheOneProcessRun) {
  TempDir dir;
  const std::string shards = (dir / "shards").string(), whole = (dir / "whole").string();
  const std::vector<std::string> study = {"study", "stability", "--quick", "--family", "contact"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = study;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  const ChildResult first = numen(with({"--out", shards}), dir, "2", "3");
  ASSERT_EQ(first.status, 0) << first.err;
  EXPECT_NE(first.out.find("shard 2/3: "), std::string::npos) << first.out;
  const ChildResult incomplete = numen({"study", "merge", shards}, dir);
  EXPECT_EQ(incomplete.status, 2) << incomplete.out;
  EXPECT_NE(incomplete.err.find("missing shards 0, 1 of 3 (stability-shard-0-of-3.json, "
                                "stability-shard-1-of-3.json)"),
            std::string::npos)
      << incomplete.err;
  for (const char* s : {"0/3", "1/3"}) {
    const ChildResult r = numen(with({"--shard", s, "--out", shards}), dir);
    ASSERT_EQ(r.status, 0) << r.err;
  }
  const ChildResult merged = numen({"study", "merge", shards}, dir);
  ASSERT_EQ(merged.status, 0) << merged.err;
  const ChildResult one = numen(with({"--out", whole}), dir);
  ASSERT_EQ(one.status, 0) << one.err;
  const std::string csv = "/stability_contact.csv";
  EXPECT_FALSE(read_file(whole + csv).empty());
  EXPECT_EQ(read_file(shards + csv), read_file(whole + csv));
  // The same tables on stdout (the one-process run adds its run count and time).
  EXPECT_EQ(merged.out.substr(0, merged.out.rfind("merged ")),
            one.out.substr(0, one.out.rfind('\n', one.out.size() - 2) + 1));
}

}  // namespace
