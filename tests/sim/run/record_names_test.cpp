// Tests of sim/record_lists and study_fields: every output writes the names of the one
// declaration it comes from, so the outputs that carry a quantity carry it under one name —
// the summary's JSON and the run figures, the CSV trace and the streamed trace, a study row's
// CSV, shard file and field list (the Python dicts: tests/sim/python/record_names_test.py), the
// state frame and the layout the page decodes it with.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "csv_lines.hpp"
#include "numen/platform/state_frame.hpp"
#include "numen/sim/run/record_lists.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_figures.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/trace_columns.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_fields.hpp"
#include "numen/sim/view/frame_layout_json.hpp"
#include "run_summary_samples.hpp"
#include "temp_dir.hpp"

namespace {

namespace sim = numen::sim;
using numen::test::read_lines;
using numen::test::split_csv;

/// The dotted names of the leaves of a JSON object ("loop.step_ns.p99").
void leaf_names(const nlohmann::json& j, const std::string& prefix, std::set<std::string>& out) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string name = prefix + it.key();
    if (it->is_object())
      leaf_names(*it, name + ".", out);
    else
      out.insert(name);
  }
}

const sim::RecordList& list_of(const std::vector<sim::RecordList>& lists, std::string_view part) {
  for (const sim::RecordList& l : lists)
    if (l.output.find(part) != std::string_view::npos) return l;
  throw std::runtime_error("no record list for " + std::string(part));
}

TEST(RecordNames, FiguresAllListsEveryOutputOnceEach) {
  const std::vector<sim::RecordList> lists = sim::record_lists();
  ASSERT_EQ(lists.size(), 7u);
  for (const sim::RecordList& l : lists) {
    EXPECT_FALSE(l.names.empty()) << l.output;
    const std::set<std::string> unique(l.names.begin(), l.names.end());
    EXPECT_EQ(unique.size(), l.names.size()) << l.output << ": a name twice";
  }
  const std::string all = sim::format_record_lists_markdown();
  EXPECT_EQ(all.find("## Run figures\n\n" + sim::format_run_figures_markdown()), 0u);
  EXPECT_NE(all.find(sim::format_trace_columns_markdown()), std::string::npos);
  for (const sim::RecordList& l : lists)
    for (const std::string& n : l.names) EXPECT_NE(all.find("`" + n + "`"), std::string::npos) << n;
}

TEST(RecordNames, DocsTraceTableIsTheGeneratedTable) {
  std::ifstream in(std::string(NUMEN_SOURCE_DIR) + "/docs/outputs.md");
  ASSERT_TRUE(in) << "docs/outputs.md";
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_NE(ss.str().find(sim::format_trace_columns_markdown()), std::string::npos)
      << "docs/outputs.md does not hold the trace column table as `numen figures --all` prints "
         "it:\n"
      << sim::format_trace_columns_markdown();
}

TEST(RecordNames, JsonSummaryCarriesTheRunFiguresNames) {
  const sim::RunSummary s = numen::test::full_managed_summary();
  std::set<std::string> json;
  leaf_names(nlohmann::json::parse(sim::format_summary_json(s)), "", json);
  // A scene of several devices also has the `devices` array, written apart from the figure
  // table (one object per device; docs/outputs.md "Several devices").
  EXPECT_EQ(json.erase("devices"), s.devices.empty() ? 0u : 1u);
  std::set<std::string> figures;
  for (const sim::RunFigure& f : sim::run_figures())
    if (f.present == nullptr || f.present(s)) figures.emplace(f.name);
  EXPECT_EQ(json, figures);
  const std::vector<sim::RecordList> lists = sim::record_lists();
  const std::vector<std::string>& listed = list_of(lists, "run summary").names;
  for (const std::string& n : figures)
    EXPECT_NE(std::find(listed.begin(), listed.end(), n), listed.end()) << n;
}

// Both traces of one run, written to files: the streamed trace's columns (after the writer's
// period, time_ns, flags) are the CSV's streamed columns under the same names, in the same order.
TEST(RecordNames, StreamedTraceIsTheCsvTracesStreamedColumnsUnderTheSameNames) {
  const sim::Scene scene =
      sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml");
  numen::test::TempDir dir;
  sim::SceneRunner runner(scene, 20);
  runner.stream_trace((dir / "stream.csv").string());
  for (int k = 0; k < 20; ++k) runner.period();
  runner.finish();
  runner.trace().write_csv((dir / "trace.csv").string());
  const std::vector<std::string> stream = split_csv(read_lines(dir / "stream.csv").at(0));
  const std::vector<std::string> csv = split_csv(read_lines(dir / "trace.csv").at(0));
  ASSERT_GT(stream.size(), 3u);
  EXPECT_EQ(std::vector<std::string>(stream.begin(), stream.begin() + 3),
            (std::vector<std::string>{"period", "time_ns", "flags"}));
  std::size_t at = 0;  // the stream's names, in order, among the CSV's
  for (std::size_t i = 3; i < stream.size(); ++i) {
    const auto it = std::find(csv.begin() + static_cast<std::ptrdiff_t>(at), csv.end(), stream[i]);
    ASSERT_NE(it, csv.end()) << stream[i] << " is not a CSV column after " << csv[at];
    at = static_cast<std::size_t>(it - csv.begin());
  }
  // The per-axis columns have the axes' names in both.
  for (const auto& a : scene.device.axes) {
    EXPECT_NE(std::find(csv.begin(), csv.end(), "axis_torque_" + a.name), csv.end()) << a.name;
    EXPECT_NE(std::find(stream.begin(), stream.end(), "axis_torque_" + a.name), stream.end());
  }
  // What `numen figures --all` lists is what the files hold.
  std::vector<std::string> axis = {"<axis>"};
  const std::vector<sim::RecordList> lists = sim::record_lists();
  std::vector<std::string> listed_stream = {"period", "time_ns", "flags"};
  for (const std::string& n : sim::trace_column_names(sim::TraceKind::kStream, axis))
    listed_stream.push_back(n);
  EXPECT_EQ(list_of(lists, "streamed").names, listed_stream);
  EXPECT_EQ(list_of(lists, "`numen run --trace` CSV").names,
            sim::trace_column_names(sim::TraceKind::kCsv, axis, std::vector<std::string>{"<device>"}));
}

// A quantity that is a summary figure has the figure's name in the traces.
TEST(RecordNames, TraceColumnsOfSummaryQuantitiesHaveTheFiguresNames) {
  const std::vector<std::string> none;
  const std::vector<std::string> columns = sim::trace_column_names(sim::TraceKind::kCsv, none);
  const auto column = [&](const std::string& n) {
    return std::find(columns.begin(), columns.end(), n) != columns.end();
  };
  for (const char* figure : {"step_time_us.median", "wakeup_latency_us.median"}) {
    ASSERT_NE(sim::find_run_figure(figure), nullptr) << figure;
    const std::string quantity = std::string(figure).substr(0, std::string(figure).find('.'));
    EXPECT_TRUE(column(quantity)) << quantity;
  }
  ASSERT_NE(sim::find_run_figure("axis_torque_max"), nullptr);
  const auto per_axis = std::find_if(sim::trace_columns().begin(), sim::trace_columns().end(),
                                     [](const sim::TraceColumn& c) { return c.per_axis; });
  ASSERT_NE(per_axis, sim::trace_columns().end());
  EXPECT_EQ(per_axis->name, "axis_torque_");
}

// The state frame's list is its declaration, complete: every header field, then every array,
// in order; the page's layout (the session message's frame_layout) carries the same names.
TEST(RecordNames, StateFrameListIsEveryDeclaredFieldThenEveryArray) {
  std::vector<std::string> declared;
  for (const numen::platform::StateFrameField& f : numen::platform::kStateFrameFields)
    declared.emplace_back(f.name);
  for (const numen::platform::StateFrameArray& a : numen::platform::kStateFrameArrays)
    declared.emplace_back(a.name);
  ASSERT_EQ(declared.size(), 23u + 13u);
  EXPECT_EQ(list_of(sim::record_lists(), "state frame").names, declared);
  const nlohmann::json page = nlohmann::json::parse(sim::state_frame_layout_json());
  std::vector<std::string> sent;
  for (const auto& f : page.at("header")) sent.push_back(f.at("name").get<std::string>());
  for (const auto& a : page.at("arrays")) sent.push_back(a.at("name").get<std::string>());
  EXPECT_EQ(sent, declared);
}

std::vector<std::string> csv_header(const std::filesystem::path& file) {
  return split_csv(read_lines(file).at(0));
}

std::vector<std::string> shard_row_keys(const std::string& document, const char* list) {
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(document);  // keys in order
  std::vector<std::string> keys;
  for (auto it = j.at("results").at(0).at(list).at(0).begin();
       it != j.at("results").at(0).at(list).at(0).end(); ++it)
    keys.push_back(it.key());
  return keys;
}

TEST(StudyFields, StabilityCsvShardAndFieldListCarryTheSameNames) {
  sim::StabilityResult r;
  r.cases = 1;
  sim::StabilityRow row;
  row.family = "coupling";
  row.case_index = 0;
  r.rows = {row};
  numen::test::TempDir dir;
  sim::write_stability_csv(r, dir.path().string());
  const std::vector<std::string> names = sim::stability_row_names();
  EXPECT_EQ(csv_header(dir / "stability_coupling.csv"), names);
  EXPECT_EQ(shard_row_keys(sim::stability_shard_document(r, sim::StabilityOptions{}), "rows"),
            names);
  EXPECT_EQ(list_of(sim::record_lists(), "stability").names, names);
  EXPECT_NE(std::find(names.begin(), names.end(), "stable"), names.end());
}

TEST(StudyFields, AccuracyCsvShardAndFieldListCarryTheSameNames) {
  sim::AccuracyResult r;
  r.cases = 1;
  sim::AccuracyRow row;
  row.case_name = "free-body";
  row.case_index = 0;
  r.rows = {row};
  numen::test::TempDir dir;
  sim::write_accuracy_csv(r, dir.path().string());
  const std::vector<std::string> names = sim::accuracy_row_names();
  EXPECT_EQ(csv_header(dir / "accuracy.csv"), names);
  EXPECT_EQ(shard_row_keys(sim::accuracy_shard_document(r, sim::AccuracyOptions{}), "rows"), names);
  EXPECT_EQ(list_of(sim::record_lists(), "accuracy").names, names);
}

}  // namespace
