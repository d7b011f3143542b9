// Tests of sim/study_accuracy (`numen study accuracy`) on tiny grids: the closed-form case
// converges at the theoretical order of each integrator, every case runs and compares, the
// CSV files have the documented columns (docs/accuracy.md), the order fit and the input checks.
#include "numen/sim/study/study_accuracy.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "build_features.hpp"
#include "numen/sim/input/input_error.hpp"
#include "temp_dir.hpp"

namespace {

using numen::sim::AccuracyOptions;
using numen::sim::AccuracyResult;

std::vector<std::string> read_csv_lines(const std::string& path) {
  std::ifstream f(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(f, l);) lines.push_back(l);
  return lines;
}

std::size_t count_fields(const std::string& line) {
  return static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) + 1;
}

/// The closed-form case on 2 ms … 0.1 ms over 0.5 s (runs in well under a second).
const AccuracyResult& free_body_result() {
  static const AccuracyResult r = [] {
    AccuracyOptions o;
    o.cases = {"free-body"};
    o.steps = {2e-3, 1e-3, 5e-4, 2e-4, 1e-4};
    o.horizon_s = 0.5;
    o.fit_max_dt = 2e-3;
    return numen::sim::run_accuracy_study(o);
  }();
  return r;
}

}  // namespace

TEST(StudyAccuracy, FreeBodyErrorsAreFiniteAndDecreaseWithTheStep) {
  const AccuracyResult& r = free_body_result();
  ASSERT_EQ(r.rows.size(), 20u);  // 4 integrators × 5 steps
  EXPECT_TRUE(r.references.empty()) << "closed form: no reference run";
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    const auto& row = r.rows[i];
    SCOPED_TRACE(row.integrator + " dt " + std::to_string(row.dt_s));
    EXPECT_EQ(row.reference, "closed-form");
    EXPECT_FALSE(row.diverged);
    EXPECT_TRUE(std::isfinite(row.position_error_max_mm) && row.position_error_max_mm > 0.0);
    EXPECT_TRUE(std::isfinite(row.orientation_error_max_mrad) &&
                row.orientation_error_max_mrad > 0.0);
    EXPECT_LE(row.position_error_rms_mm, row.position_error_max_mm);
    EXPECT_GT(row.cpu_s_per_sim_s, 0.0);
    EXPECT_EQ(row.steps, std::llround(0.5 / row.dt_s));
    if (i % 5 != 0) {  // rows of one integrator, steps decreasing
      EXPECT_LT(row.position_error_max_mm, r.rows[i - 1].position_error_max_mm);
      EXPECT_LT(row.orientation_error_max_mrad, r.rows[i - 1].orientation_error_max_mrad);
    }
  }
}

TEST(StudyAccuracy, FreeBodyObservedOrderIsTheTheoreticalOne) {
  const AccuracyResult& r = free_body_result();
  ASSERT_EQ(r.fits.size(), 4u);
  for (const auto& f : r.fits) {
    SCOPED_TRACE(f.integrator);
    EXPECT_EQ(f.theoretical_order,
              f.integrator == "trapezoidal" || f.integrator == "tr-bdf2" ? 2.0 : 1.0);
    EXPECT_EQ(f.points, 5);
    EXPECT_NEAR(f.observed_order, f.theoretical_order, 0.3);
    EXPECT_NEAR(f.observed_order_rotation, f.theoretical_order, 0.3);
    EXPECT_TRUE(std::isfinite(f.error_at_1ms_mm));
  }
  // What the second order buys at 1 ms on this oscillator: at least 100× smaller errors.
  EXPECT_LT(r.fits[2].error_at_1ms_mm * 100.0, r.fits[0].error_at_1ms_mm);
  EXPECT_EQ(r.fits[3].integrator, "tr-bdf2");
  EXPECT_LT(r.fits[3].error_at_1ms_mm * 100.0, r.fits[0].error_at_1ms_mm);
}

TEST(StudyAccuracy, CsvFilesHaveTheDocumentedColumns) {
  numen::test::TempDir dir;
  const std::string out = (dir.path() / "acc").string();
  numen::sim::write_accuracy_csv(free_body_result(), out);
  const auto rows = read_csv_lines(out + "/accuracy.csv");
  ASSERT_EQ(rows.size(), 21u);
  EXPECT_EQ(rows[0],
            "case,integrator,dt_s,steps,horizon_s,position_error_max_mm,position_error_rms_mm,"
            "orientation_error_max_mrad,orientation_error_rms_mrad,cpu_s_per_sim_s,diverged,"
            "nonfinite_steps,reference");
  for (const auto& l : rows) EXPECT_EQ(count_fields(l), 13u) << l;
  EXPECT_EQ(rows[1].rfind("free-body,implicit-euler,0.002,250,0.5,", 0), 0u) << rows[1];
  const auto orders = read_csv_lines(out + "/accuracy_orders.csv");
  ASSERT_EQ(orders.size(), 5u);
  EXPECT_EQ(orders[0],
            "case,integrator,observed_order,observed_order_rotation,theoretical_order,points,"
            "fit_dt_min_s,fit_dt_max_s,position_error_max_at_1ms_mm,cpu_s_per_sim_s_at_1ms");
  for (const auto& l : orders) EXPECT_EQ(count_fields(l), 10u) << l;
  const auto refs = read_csv_lines(out + "/accuracy_references.csv");
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_EQ(refs[0],
            "case,reference_dt_s,half_dt_s,position_difference_max_mm,"
            "orientation_difference_max_mrad,cpu_s");
}

TEST(StudyAccuracy, EveryCaseRunsAndIsComparedWithItsReference) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  AccuracyOptions o;
  o.steps = {1e-2, 5e-3};
  o.horizon_s = 0.02;
  o.reference_dt = 1e-3;
  double last_done = -1.0, last_total = 0.0;
  int calls = 0;
  o.progress = [&](double done, double total, const std::string&) {
    EXPECT_GT(done, last_done);
    last_done = done;
    last_total = total;
    ++calls;
  };
  const AccuracyResult r = numen::sim::run_accuracy_study(o);
  EXPECT_EQ(r.rows.size(), 5u * 4u * 2u);  // cases × integrators × steps
  EXPECT_EQ(calls, 5 * 4 * 2 + 4 * 2);  // runs + two reference runs per non-closed case
  EXPECT_NEAR(last_done, last_total, 1e-9 * last_total);
  ASSERT_EQ(r.references.size(), 4u);
  std::set<std::string> cases;
  for (const auto& ref : r.references) {
    EXPECT_EQ(ref.reference_dt, 1e-3);
    EXPECT_TRUE(std::isfinite(ref.position_difference_max_mm)) << ref.case_name;
  }
  for (const auto& row : r.rows) {
    cases.insert(row.case_name);
    SCOPED_TRACE(row.case_name + " " + row.integrator);
    EXPECT_EQ(row.horizon_s, 0.02);
    if (!row.diverged) {
      EXPECT_TRUE(std::isfinite(row.position_error_max_mm));
    }
    if (row.case_name != "free-body") {
      EXPECT_EQ(row.reference, "trapezoidal dt=1e-03");
    }
  }
  EXPECT_EQ(cases.size(), 5u);
}

TEST(StudyAccuracy, CasesThisBuildLeftOutAreSkippedAndNamed) {
  const bool lean = !numen::core::kWithArticulation || !numen::core::kWithDeformable;
  AccuracyOptions o;
  o.steps = {1e-2};
  o.horizon_s = 0.02;
  o.reference_dt = 1e-3;
  o.integrators = {numen::core::Integrator::kLinearlyImplicitEuler};
  const AccuracyResult r = numen::sim::run_accuracy_study(o);
  std::set<std::string> ran;
  for (const auto& row : r.rows) ran.insert(row.case_name);
  EXPECT_EQ(ran.size() + r.skipped.size(), numen::sim::accuracy_case_names().size());
  EXPECT_EQ(ran.count("articulated"), numen::core::kWithArticulation ? 1u : 0u);
  EXPECT_EQ(ran.count("deformable"), numen::core::kWithDeformable ? 1u : 0u);
  EXPECT_EQ(r.skipped.empty(), !lean);
  for (const std::string& s : r.skipped) {
    EXPECT_NE(s.find("this build has NUMEN_WITH_"), std::string::npos) << s;
    EXPECT_NE(numen::sim::format_accuracy_table(r).find("skipped: " + s), std::string::npos);
  }
  if (!numen::core::kWithArticulation) {  // named explicitly: an error, not a silent skip
    o.cases = {"articulated"};
    EXPECT_THROW(numen::sim::run_accuracy_study(o), numen::sim::InputError);
  }
}

TEST(StudyAccuracy, FitOrderIsTheLeastSquaresSlopeOverTheSelectedPoints) {
  const std::vector<double> dt = {1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4};
  std::vector<double> e;
  for (double h : dt) e.push_back(3.0 * h * h);
  std::vector<bool> div(dt.size(), false);
  e[0] = 1e9;  // above max_dt: ignored
  e[1] = std::numeric_limits<double>::quiet_NaN();
  div[2] = true;  // diverged: ignored
  e[6] = 1e-12;   // below the floor: ignored
  int used = 0;
  double lo = 0.0, hi = 0.0;
  EXPECT_NEAR(numen::sim::fit_order(dt, e, div, 5e-3, 1e-10, &used, &lo, &hi), 2.0, 1e-12);
  EXPECT_EQ(used, 3);
  EXPECT_EQ(lo, 2e-4);
  EXPECT_EQ(hi, 1e-3);
  EXPECT_TRUE(std::isnan(numen::sim::fit_order(dt, e, div, 5e-4, 1e-10)));  // 2 points left
}

TEST(StudyAccuracy, BadCaseAndStepAreInputErrors) {
  AccuracyOptions o;
  o.cases = {"pendulum"};
  EXPECT_THROW((void)numen::sim::run_accuracy_study(o), numen::sim::InputError);
  AccuracyOptions s;
  s.cases = {"free-body"};
  s.steps = {3e-3};  // does not divide 10 ms
  try {
    (void)numen::sim::run_accuracy_study(s);
    ADD_FAILURE() << "no error";
  } catch (const numen::sim::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("divide"), std::string::npos) << e.what();
  }
}

TEST(StudyAccuracy, TableListsEveryFit) {
  const std::string t = numen::sim::format_accuracy_table(free_body_result());
  for (const char* s : {"| free-body | implicit-euler |", "| free-body | symplectic-euler |",
                        "| free-body | trapezoidal |", "| free-body | tr-bdf2 |", "theoretical"})
    EXPECT_NE(t.find(s), std::string::npos) << s << "\n" << t;
}
