/// @file study_accuracy_shard_test.cpp
/// The accuracy study's shard files and their merge (study_accuracy_shard.cpp): on a small grid
/// the merged CSV files equal the one-process run's except the CPU-time columns (measurements);
/// a study case is one case and integrator; each case's reference check is reported once.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/study/study_accuracy.hpp"
#include "numen/sim/study/study_shard.hpp"
#include "temp_dir.hpp"

namespace numen::sim {
namespace {

using test::read_file;
using test::TempDir;

/// Free body (closed form) and wall (reference run and its check), 3 steps, 50 ms: 6 study
/// cases (2 cases × 3 integrators), a fraction of a second.
AccuracyOptions small_accuracy_grid() {
  AccuracyOptions o;
  o.cases = {"free-body", "wall"};
  o.steps = {1e-2, 5e-3, 2e-3};
  o.horizon_s = 0.05;
  o.reference_dt = 1e-4;
  o.integrators = {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler,
                   core::Integrator::kTrapezoidal};  // fixed: the study's default list may grow
  return o;
}

/// `csv` without the columns whose header names a CPU time ("cpu…").
std::string without_cpu_columns(const std::string& csv) {
  std::istringstream in(csv);
  std::string line, out;
  std::vector<bool> keep;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string c; std::getline(row, c, ',');) cells.push_back(c);
    if (keep.empty())
      for (const std::string& c : cells) keep.push_back(c.rfind("cpu", 0) != 0);
    for (std::size_t i = 0; i < cells.size(); ++i)
      if (i >= keep.size() || keep[i]) out += cells[i] + ",";
    out += "\n";
  }
  return out;
}

TEST(StudyAccuracyShard, MergeEqualsTheOneProcessRunExceptCpuTimes) {
  const AccuracyOptions o = small_accuracy_grid();
  const AccuracyResult one = run_accuracy_study(o);
  ASSERT_EQ(one.cases, 6);
  ASSERT_EQ(one.fits.size(), 6u);
  ASSERT_EQ(one.references.size(), 1u);  // the wall's; the free body has a closed form
  TempDir whole, shards;
  write_accuracy_csv(one, whole.path().string());
  for (int i = 0; i < 4; ++i) {  // 4 shards of 6 study cases: shards 0, 1 run two each
    AccuracyOptions s = o;
    s.shard = {i, 4};
    const AccuracyResult r = run_accuracy_study(s);
    EXPECT_EQ(r.fits.size(), i < 2 ? 2u : 1u);
    for (const AccuracyFit& f : r.fits) EXPECT_EQ(f.case_index % 4, i);
    // The wall's check belongs to its first integrator, study case 3: shard 3 only.
    EXPECT_EQ(r.references.size(), i == 3 ? 1u : 0u) << "shard " << i;
    write_file_atomically(shards / shard_file_name("accuracy", s.shard),
                          accuracy_shard_document(r, s));
  }
  const AccuracyResult merged = merge_accuracy_shards(shards.path().string());
  write_accuracy_csv(merged, shards.path().string());
  for (const char* name : {"accuracy.csv", "accuracy_orders.csv", "accuracy_references.csv"}) {
    const std::string a = read_file((whole / name).string());
    const std::string b = read_file((shards / name).string());
    EXPECT_EQ(without_cpu_columns(a), without_cpu_columns(b)) << name;
    EXPECT_EQ(std::count(a.begin(), a.end(), '\n'), std::count(b.begin(), b.end(), '\n'));
  }
  ASSERT_EQ(merged.rows.size(), one.rows.size());
  for (std::size_t i = 0; i < one.rows.size(); ++i) {
    EXPECT_EQ(merged.rows[i].position_error_max_mm, one.rows[i].position_error_max_mm);
    EXPECT_EQ(merged.rows[i].orientation_error_rms_mrad, one.rows[i].orientation_error_rms_mrad);
  }
}

// A case is merged only with the records its plan gives it: one fit, a row per step, and
// for a case's first integrator its reference check unless the case has a closed form (study
// cases 0-2: free body, 3-5: wall, 3 integrators). Any other count was merged.
TEST(StudyAccuracyShard, MergeRefusesACaseWithoutTheRecordsItsPlanGivesIt) {
  const AccuracyOptions o = small_accuracy_grid();
  const AccuracyResult whole = run_accuracy_study(o);
  TempDir dir;
  const std::string file = (dir / "accuracy-shard-0-of-1.json").string();
  const auto merge_error = [&](const std::function<void(AccuracyResult&)>& edit) {
    AccuracyResult r = whole;
    edit(r);
    write_file_atomically(file, accuracy_shard_document(r, o));
    try {
      (void)merge_accuracy_shards(dir.path().string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string tail = ": the shard that ran it did not write it whole";
  EXPECT_EQ(merge_error([](AccuracyResult&) {}), "");
  EXPECT_EQ(merge_error([](AccuracyResult& r) {
              r.rows.erase(std::find_if(r.rows.begin(), r.rows.end(),
                                        [](const AccuracyRow& x) { return x.case_index == 4; }));
            }),
            file +
                ": case 4.rows: 2 in the file, but the study's plan gives the case 3 (one per "
                "time step of the grid)" +
                tail);
  EXPECT_EQ(merge_error([](AccuracyResult& r) {
              r.fits.erase(r.fits.begin() + 2);  // study case 2's
            }),
            file +
                ": case 2.fits: 0 in the file, but the study's plan gives the case 1 (one per "
                "case and integrator)" +
                tail);
  EXPECT_EQ(merge_error([](AccuracyResult& r) { r.references.clear(); }),
            file +
                ": case 3.references: 0 in the file, but the study's plan gives the case 1 "
                "(the reference check of wall, by its first integrator)" +
                tail);
  EXPECT_EQ(merge_error([](AccuracyResult& r) {
              r.references.push_back(r.references.front());
              r.references.back().case_index = 0;  // the free body's first integrator
            }),
            file +
                ": case 0.references: 1 in the file, but the study's plan gives the case 0 "
                "(free-body has a closed form, no reference run)" +
                tail);
}

TEST(StudyAccuracyShard, ListHasOneCasePerCaseAndIntegrator) {
  AccuracyOptions o = small_accuracy_grid();
  const std::vector<StudyCase> all = accuracy_cases(o);
  ASSERT_EQ(all.size(), 6u);
  EXPECT_EQ(all[4].family, "wall");
  EXPECT_EQ(all[4].name, "symplectic-euler");
  EXPECT_EQ(all[4].parameters, "integrator=symplectic-euler steps=3 dt=0.01..0.002");
  o.shard = {1, 2};
  const std::vector<StudyCase> odd = accuracy_cases(o);
  ASSERT_EQ(odd.size(), 3u);
  EXPECT_EQ(odd[0].index, 1);
  EXPECT_EQ(odd[2].index, 5);
}

}  // namespace
}  // namespace numen::sim
