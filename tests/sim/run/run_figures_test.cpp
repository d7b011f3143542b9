// Tests of sim/run_figures: the one table of a run's figures. Names are unique JSON paths,
// every row is described and reads a value of its declared kind, and the docs' summary table
// (docs/outputs.md, "Summary figures") lists every figure.
#include "numen/sim/run/run_figures.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "run_summary_samples.hpp"

namespace {

using numen::sim::FigureKind;
using numen::sim::RunFigure;

TEST(RunFigures, NamesAreUniqueJsonPathsAndEveryRowIsDescribed) {
  std::set<std::string_view> names;
  const numen::sim::RunSummary s = numen::test::full_managed_summary();
  for (const RunFigure& f : numen::sim::run_figures()) {
    EXPECT_TRUE(names.insert(f.name).second) << "duplicate figure " << f.name;
    EXPECT_FALSE(f.description.empty()) << f.name;
    EXPECT_EQ(f.name.find(' '), std::string_view::npos) << f.name;
    EXPECT_NE(f.name.front(), '.') << f.name;
    EXPECT_NE(f.name.back(), '.') << f.name;
    EXPECT_EQ(f.get(s).kind, f.kind) << f.name << ": the accessor reads another kind";
    EXPECT_EQ(numen::sim::find_run_figure(f.name), &f);
  }
  // A name is not both a value and the parent of other values ("loop" vs "loop.periods").
  for (std::string_view n : names)
    for (std::string_view m : names)
      EXPECT_FALSE(m.size() > n.size() && m.substr(0, n.size()) == n && m[n.size()] == '.')
          << n << " is a value and the parent of " << m;
  EXPECT_EQ(numen::sim::find_run_figure("no_such_figure"), nullptr);
}

TEST(RunFigures, AccessorsReadTheSummary) {
  const numen::sim::RunSummary s = numen::test::admittance_summary();
  EXPECT_EQ(numen::sim::find_run_figure("steps")->get(s).count, 500);
  EXPECT_EQ(numen::sim::find_run_figure("rearm_first_period")->get(s).count, 59);
  EXPECT_EQ(numen::sim::find_run_figure("overrun_limit")->get(s).count, 0);
  EXPECT_EQ(numen::sim::find_run_figure("trocar_note")->get(s).text, s.trocar_note);
  EXPECT_EQ(numen::sim::find_run_figure("admittance.setpoints_rate_limited")->get(s).count, 69);
  EXPECT_EQ(numen::sim::find_run_figure("loop.end_to_end_ns.p999")->get(s).count, 400'400);
  EXPECT_DOUBLE_EQ(numen::sim::find_run_figure("real_time_factor")->get(s).real, 2.0);
  EXPECT_DOUBLE_EQ(numen::sim::find_run_figure("admittance.final_hand_force_n")->get(s).real,
                   200.0 * 24.75e-3);
  EXPECT_EQ(numen::sim::find_run_figure("warnings")->get(s).list, &s.warnings);
  // Admittance figures belong in the JSON of admittance runs only.
  const RunFigure& a = *numen::sim::find_run_figure("admittance.k_hand");
  ASSERT_NE(a.present, nullptr);
  EXPECT_TRUE(a.present(s));
  EXPECT_FALSE(a.present(numen::test::full_managed_summary()));
}

TEST(RunFigures, DocsSummaryTableIsTheGeneratedTable) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/docs/outputs.md");
  ASSERT_TRUE(in) << "docs/outputs.md";
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string doc = ss.str();
  const std::string table = numen::sim::format_run_figures_markdown();
  EXPECT_NE(doc.find(table), std::string::npos)
      << "docs/outputs.md does not hold the figure table as `numen figures` prints it:\n"
      << table;
  for (const RunFigure& f : numen::sim::run_figures())  // each row, for a readable failure
    EXPECT_NE(doc.find("| `" + std::string(f.name) + "` | "), std::string::npos)
        << "docs/outputs.md's figure table lacks " << f.name;
}

TEST(RunFigures, MarkdownTableHasOneRowPerFigureAndEscapesBars) {
  const std::string table = numen::sim::format_run_figures_markdown();
  std::size_t rows = 0;
  for (std::size_t i = table.find('\n'); i != std::string::npos; i = table.find('\n', i + 1)) ++rows;
  EXPECT_EQ(rows, numen::sim::run_figures().size() + 2);  // header, rule, one row per figure
  EXPECT_NE(table.find("\\|x_tool − x_target\\|"), std::string::npos) << table;
}

}  // namespace
