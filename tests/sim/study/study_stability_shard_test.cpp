/// @file study_stability_shard_test.cpp
/// The stability study's shard files and their merge (study_stability_shard.cpp): on a small grid
/// the merged CSV files are byte-identical to the one-process run's for N = 1, 2, 3, 5; a case's
/// rows do not depend on the shard; numbers survive exactly (NaN with its sign, ±∞); a missing
/// shard, mismatched N or options and a damaged file are refused with the file and the key.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/study/study_shard.hpp"
#include "numen/sim/study/study_stability.hpp"
#include "temp_dir.hpp"

namespace numen::sim {
namespace {

using test::read_file;
using test::TempDir;

/// A grid of a fraction of a second: coupling and contact, quick, 20 steps per run, two
/// integrators (2 × 2 × 3 × 6 × 8 + 2 × 2 × 3 × 3 × 7 = 828 cases).
StabilityOptions small_stability_grid() {
  StabilityOptions o;
  o.quick = true;
  o.families = {"coupling", "contact"};
  o.integrators = {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler};
  o.grid_steps = 20;
  return o;
}

/// Runs shard `s` of `o` and writes its file into `dir`.
void run_shard(StabilityOptions o, const Shard& s, const std::filesystem::path& dir) {
  o.shard = s;
  write_file_atomically(dir / shard_file_name("stability", s),
                        stability_shard_document(run_stability_study(o), o));
}

/// Every file of `a` equals the file of the same name in `b` byte for byte, and `b` has no other.
void expect_same_files(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::set<std::string> names_a, names_b;
  for (const auto& e : std::filesystem::directory_iterator(a)) names_a.insert(e.path().filename());
  for (const auto& e : std::filesystem::directory_iterator(b))
    if (e.path().extension() == ".csv") names_b.insert(e.path().filename());
  EXPECT_EQ(names_a, names_b);
  for (const std::string& n : names_a)
    EXPECT_EQ(read_file((a / n).string()), read_file((b / n).string())) << n;
}

TEST(StudyStabilityShard, MergeIsByteIdenticalToTheOneProcessRun) {
  const StabilityOptions o = small_stability_grid();
  TempDir whole;
  const StabilityResult one = run_stability_study(o);
  ASSERT_EQ(one.cases, 828);
  ASSERT_EQ(one.rows.size(), 828u);
  write_stability_csv(one, whole.path().string());
  for (int n : {1, 2, 3, 5}) {
    TempDir shards;
    for (int i = n - 1; i >= 0; --i) run_shard(o, {i, n}, shards.path());  // any order
    const StabilityResult merged = merge_stability_shards(shards.path().string());
    EXPECT_EQ(merged.cases, one.cases);
    write_stability_csv(merged, shards.path().string());
    expect_same_files(whole.path(), shards.path());
    EXPECT_EQ(format_stability_tables(merged), format_stability_tables(one)) << n << " shards";
  }
}

TEST(StudyStabilityShard, ShardsPartitionTheCasesAndRunOnlyTheirs) {
  const StabilityOptions o = small_stability_grid();
  const std::vector<StudyCase> all = stability_cases(o);
  ASSERT_EQ(all.size(), 828u);
  for (std::size_t k = 0; k < all.size(); ++k)
    EXPECT_EQ(all[k].index, static_cast<std::int64_t>(k));
  EXPECT_EQ(all[0].family, "coupling");
  EXPECT_EQ(all[0].name, "coupling-undamped");
  EXPECT_EQ(all[0].parameters, "integrator=implicit-euler h=0.0001 m=0.001 k=10 zeta=0");
  std::vector<int> owner(all.size(), -1);
  for (int i = 0; i < 4; ++i) {
    StabilityOptions s = o;
    s.shard = {i, 4};
    for (const StudyCase& c : stability_cases(s)) {
      EXPECT_EQ(c.index % 4, i);
      EXPECT_EQ(owner[static_cast<std::size_t>(c.index)], -1) << "case " << c.index << " twice";
      owner[static_cast<std::size_t>(c.index)] = i;
      EXPECT_EQ(c.parameters, all[static_cast<std::size_t>(c.index)].parameters);
    }
    const StabilityResult r = run_stability_study(s);
    EXPECT_EQ(r.rows.size(), 207u);
    for (const StabilityRow& row : r.rows) EXPECT_EQ(row.case_index % 4, i);
  }
  for (std::size_t k = 0; k < owner.size(); ++k) EXPECT_NE(owner[k], -1) << "case " << k;
}

/// A hand-made result whose numbers are the awkward ones: NaN of either sign, ±∞, subnormal,
/// 17-digit values; a boundary with its sweep vectors.
StabilityResult awkward_result(const Shard& s) {
  StabilityResult r;
  r.shard = s;
  r.cases = 2;
  r.skipped = {"articulation: needs joints"};
  StabilityRow row;
  row.family = "extreme";
  row.case_name = "bus-nonfinite";
  row.integrator = "trapezoidal";
  row.dt_s = 0.1 + 0.2;  // 0.30000000000000004
  row.mass_kg = std::numeric_limits<double>::quiet_NaN();
  row.stiffness = -std::numeric_limits<double>::quiet_NaN();
  row.parameter = std::numeric_limits<double>::denorm_min();
  row.penetration_bound_m = std::numeric_limits<double>::infinity();
  row.energy_ratio_max = -std::numeric_limits<double>::infinity();
  row.steps = (std::int64_t{1} << 53) + 1;
  row.diverged_step = -1;
  row.note = "commas, \"quotes\" and ünïcode";
  row.case_index = 0;
  StabilityBoundary b;
  b.zeta = 0.85;
  b.omega_dt = {0.05, 0.1};
  b.energy_ratio = {1.0, std::numeric_limits<double>::infinity()};
  b.growth_ratio = {1.0 / 3.0, std::numeric_limits<double>::quiet_NaN()};
  b.verdict_theory_omega_dt = std::numeric_limits<double>::quiet_NaN();
  b.case_index = 1;
  if (s.owns(0)) r.rows.push_back(row);
  if (s.owns(1)) r.boundaries.push_back(b);
  return r;
}

TEST(StudyStabilityShard, NumbersSurviveExactly) {
  TempDir dir;
  StabilityOptions o;
  for (int i = 0; i < 2; ++i)
    write_file_atomically(dir / shard_file_name("stability", {i, 2}),
                          stability_shard_document(awkward_result({i, 2}), o));
  const StabilityResult m = merge_stability_shards(dir.path().string());
  const StabilityResult want = awkward_result({0, 1});
  ASSERT_EQ(m.rows.size(), 1u);
  ASSERT_EQ(m.boundaries.size(), 1u);
  const StabilityRow& r = m.rows[0];
  const StabilityRow& w = want.rows[0];
  EXPECT_EQ(r.dt_s, w.dt_s);
  EXPECT_TRUE(std::isnan(r.mass_kg) && !std::signbit(r.mass_kg));
  EXPECT_TRUE(std::isnan(r.stiffness) && std::signbit(r.stiffness));
  EXPECT_EQ(r.parameter, w.parameter);
  EXPECT_EQ(r.penetration_bound_m, w.penetration_bound_m);
  EXPECT_EQ(r.energy_ratio_max, w.energy_ratio_max);
  EXPECT_EQ(r.steps, w.steps);
  EXPECT_EQ(r.note, w.note);
  EXPECT_EQ(m.boundaries[0].growth_ratio[0], 1.0 / 3.0);
  EXPECT_TRUE(std::isnan(m.boundaries[0].growth_ratio[1]));
  EXPECT_EQ(m.boundaries[0].energy_ratio, want.boundaries[0].energy_ratio);
  EXPECT_EQ(m.skipped, want.skipped);
  TempDir a, b;
  write_stability_csv(want, a.path().string());
  write_stability_csv(m, b.path().string());
  expect_same_files(a.path(), b.path());
}

/// The InputError merge_stability_shards(`dir`) throws.
InputError merge_error(const std::filesystem::path& dir) {
  try {
    (void)merge_stability_shards(dir.string());
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "the merge of " << dir << " succeeded";
  return InputError("", 0, 0, "", "");
}

TEST(StudyStabilityShard, MissingShardsAreListedByIndex) {
  StabilityOptions o = small_stability_grid();
  o.families = {"coupling"};
  TempDir dir;
  run_shard(o, {0, 4}, dir.path());
  run_shard(o, {2, 4}, dir.path());
  const InputError e = merge_error(dir.path());
  EXPECT_EQ(e.file(), dir.path().string());
  EXPECT_NE(e.message().find("missing shards 1, 3 of 4 (stability-shard-1-of-4.json, "
                             "stability-shard-3-of-4.json)"),
            std::string::npos)
      << e.what();
}

TEST(StudyStabilityShard, MismatchedShardCountsAreRefused) {
  StabilityOptions o = small_stability_grid();
  o.families = {"coupling"};
  TempDir dir;
  run_shard(o, {0, 2}, dir.path());
  run_shard(o, {1, 2}, dir.path());
  run_shard(o, {0, 3}, dir.path());
  const InputError e = merge_error(dir.path());
  EXPECT_NE(e.message().find("mismatched shard counts (N = 2: stability-shard-0-of-2.json, "
                             "stability-shard-1-of-2.json; N = 3: stability-shard-0-of-3.json)"),
            std::string::npos)
      << e.what();
}

TEST(StudyStabilityShard, ShardsOfOtherOptionsAreRefused) {
  StabilityOptions o = small_stability_grid();
  o.families = {"coupling"};
  TempDir dir;
  run_shard(o, {0, 2}, dir.path());
  o.grid_steps = 30;
  run_shard(o, {1, 2}, dir.path());
  const InputError e = merge_error(dir.path());
  EXPECT_EQ(e.file(), (dir / "stability-shard-1-of-2.json").string());
  EXPECT_EQ(e.key(), "manifest.grid_steps");
  EXPECT_NE(e.message().find("number 30, but number 20 in"), std::string::npos) << e.what();
}

TEST(StudyStabilityShard, DamagedShardFilesAreNamed) {
  StabilityOptions o = small_stability_grid();
  o.families = {"coupling"};
  TempDir dir;
  run_shard(o, {0, 2}, dir.path());
  run_shard(o, {1, 2}, dir.path());
  const std::string path = (dir / "stability-shard-1-of-2.json").string();
  const std::string text = read_file(path);
  // Cut short (what a non-atomic write killed half-way would leave).
  dir.write("stability-shard-1-of-2.json", text.substr(0, text.size() / 2));
  InputError e = merge_error(dir.path());
  EXPECT_EQ(e.file(), path);
  EXPECT_NE(e.message().find("not a shard file"), std::string::npos) << e.what();
  // A case of shard 0 in the file of shard 1.
  const std::size_t at = text.find("\"case\": 1,");
  ASSERT_NE(at, std::string::npos);
  dir.write("stability-shard-1-of-2.json",
            text.substr(0, at) + "\"case\": 2," + text.substr(at + 10));
  e = merge_error(dir.path());
  EXPECT_EQ(e.file(), path);
  EXPECT_EQ(e.key(), "results[0].case");
  EXPECT_NE(e.message().find("case 2 belongs to shard 0"), std::string::npos) << e.what();
  // A row's number replaced by text.
  const std::size_t dt = text.find("\"dt_s\": ");
  ASSERT_NE(dt, std::string::npos);
  dir.write("stability-shard-1-of-2.json",
            text.substr(0, dt) + "\"dt_s\": \"fast\"" + text.substr(text.find(',', dt)));
  e = merge_error(dir.path());
  EXPECT_EQ(e.key(), "case 1.rows[0].dt_s");
  EXPECT_EQ(e.message(), "not a number: string \"fast\"");
}

}  // namespace
}  // namespace numen::sim
