// Tests of sim/trace_columns: both traces' headers and rows come from one column table, so
// every column of the table is in the header and each row holds the table's values in the
// header's order — for the in-memory CSV of a simulated run and for the streamed trace of a
// real-bus run (the table's streamed columns, under the same names), whose period stays
// allocation-free.
#include "numen/sim/run/trace_columns.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "csv_lines.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using numen::sim::TraceRecord;

using numen::test::read_lines;
using numen::test::split_csv;

/// A record whose every field has its own value, exact in 9 significant digits.
TraceRecord distinct_record() {
  TraceRecord r;
  double v = 0.0;
  const auto next = [&v] { return v += 0.125; };
  r.time_s = next();
  r.held_body = 2;
  r.frames_read = 7;
  r.sample_valid = true;
  r.torque_commanded = true;
  r.lifecycle = 8;
  r.target.position = {next(), next(), next()};
  r.target.orientation = numen::core::Quat(next(), next(), next(), next());
  r.tool.position = {next(), next(), next()};
  r.tool.orientation = numen::core::Quat(next(), next(), next(), next());
  r.contacts = 3;
  r.tool_contacts = 4;
  r.tool_penetration_mm = next();
  r.target_penetration_mm = next();
  r.feedback.force = {next(), next(), next()};
  r.feedback.torque = {next(), next(), next()};
  r.num_axes = 3;
  for (int a = 0; a < 3; ++a) r.axis_torque[static_cast<std::size_t>(a)] = -next();
  r.step_time_us = next();
  r.end_to_end_us = next();
  r.wakeup_latency_us = next();
  r.solver_iterations = 5;
  r.joint_drift_mm = next();
  r.joint_angle_drift_mrad = next();
  r.joint_reaction_max_n = next();
  r.baumgarte_rhs_max = next();
  r.node_contacts = 6;
  r.net_penetration_mm = next();
  r.net_tie_stretch_mm = next();
  r.net_strain_max = next();
  r.solver_residual = next();
  r.grasps_held = 9;
  r.thread_tension_n = next();
  r.thread_stretch = next();
  r.thread_contacts = 10;
  r.thread_newton_iterations = 11;
  r.thread_unconverged = 12;
  r.needle_tip_force_n = next();
  r.needle_points = 13;
  r.needle_event = 14;
  r.num_extra_devices = 1;  // one device beside device 0: its columns "…@1" (no names given)
  r.devices[0].sample_valid = true;
  const auto single = [&next] { return static_cast<float>(next()); };  // 0.125 steps: exact in a float
  r.devices[0].target = {single(), single(), single()};
  r.devices[0].tool = {single(), single(), single()};
  r.devices[0].feedback_force = {single(), single(), single()};
  return r;
}

TEST(TraceColumns, CsvHeaderIsTheTableAndRowsHoldItsValuesInOrder) {
  numen::sim::Trace trace;
  trace.reserve(1);
  const TraceRecord r = distinct_record();
  trace.push(r);
  numen::test::TempDir dir;
  trace.write_csv((dir / "t.csv").string());
  const std::vector<std::string> lines = read_lines(dir / "t.csv");
  ASSERT_EQ(lines.size(), 2u);
  const std::vector<std::string> axes = {"0", "1", "2"};
  const std::vector<std::string> devices = {"1"};
  const std::vector<std::string> names =
      numen::sim::trace_column_names(numen::sim::TraceKind::kCsv, axes, devices);
  EXPECT_EQ(split_csv(lines[0]), names);
  // Every column of the table is in the header (per-axis ones once per axis, per-device ones
  // once per other device).
  for (const auto& c : numen::sim::trace_columns()) {
    const std::string first = std::string(c.name) + (c.per_axis ? "0" : c.per_device ? "1" : "");
    EXPECT_NE(std::find(names.begin(), names.end(), first), names.end()) << c.name;
  }
  std::vector<double> values(names.size());
  ASSERT_EQ(numen::sim::trace_column_values(numen::sim::TraceKind::kCsv, r, 3, std::span(values), 1),
            names.size());
  const std::vector<std::string> row = split_csv(lines[1]);
  ASSERT_EQ(row.size(), names.size());
  for (std::size_t c = 0; c < names.size(); ++c)
    EXPECT_EQ(std::stod(row[c]), values[c]) << names[c];
  // Values are distinct, so a column written under another's name would be caught.
  EXPECT_EQ(std::stod(row[static_cast<std::size_t>(
                std::find(names.begin(), names.end(), "axis_torque_2") - names.begin())]),
            r.axis_torque[2]);
  EXPECT_EQ(std::stod(row[static_cast<std::size_t>(
                std::find(names.begin(), names.end(), "solver_residual") - names.begin())]),
            r.solver_residual);
  EXPECT_EQ(std::stod(row[static_cast<std::size_t>(
                std::find(names.begin(), names.end(), "tool_y@1") - names.begin())]),
            static_cast<double>(r.devices[0].tool[1]));
}

TEST(TraceColumns, ValuesStopWhereTheOutputEnds) {
  const TraceRecord r = distinct_record();
  std::array<double, 4> out{};
  EXPECT_EQ(
      numen::sim::trace_column_values(numen::sim::TraceKind::kCsv, r, 3, std::span(out)), 4u);
  EXPECT_EQ(out[0], r.time_s);
  EXPECT_EQ(out[3], r.sample_valid ? 1.0 : 0.0);
}

TEST(TraceColumns, StreamedTraceHeaderIsTheTableAndRowsHoldItsValuesWithoutAllocating) {
  const numen::sim::Scene scene = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) +
                                                         "/sim/scenes/construction.toml");
  numen::test::TempDir dir;
  const fs::path path = dir / "stream.csv";
  numen::sim::SceneRunner runner(scene, 200);
  runner.stream_trace(path.string());
  std::int64_t allocations = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 200; ++k) runner.period();
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0) << "heap allocations in 200 streamed periods";
  runner.finish();
  std::vector<std::string> axis_names;
  for (const auto& a : scene.device.axes) axis_names.push_back(a.name);
  std::vector<std::string> header = {"period", "time_ns", "flags"};
  for (const std::string& n :
       numen::sim::trace_column_names(numen::sim::TraceKind::kStream, axis_names))
    header.push_back(n);
  const std::vector<std::string> lines = read_lines(path);
  ASSERT_EQ(lines.size(), 201u);
  EXPECT_EQ(split_csv(lines[0]), header);
  // The last row: the values of the last period's record, in the header's order.
  std::vector<double> values(header.size() - 3);
  const TraceRecord& last = runner.trace().records().back();
  ASSERT_EQ(numen::sim::trace_column_values(numen::sim::TraceKind::kStream, last,
                                            static_cast<int>(axis_names.size()),
                                            std::span(values)),
            values.size());
  EXPECT_EQ(last.frames_read, runner.last_report().frames_read);
  EXPECT_EQ(last.step_time_us, static_cast<double>(runner.last_report().step_ns) * 1e-3);
  const std::vector<std::string> row = split_csv(lines.back());
  ASSERT_EQ(row.size(), header.size());
  EXPECT_EQ(row[0], "199");
  for (std::size_t c = 0; c < values.size(); ++c)
    EXPECT_EQ(std::stod(row[c + 3]), values[c]) << header[c + 3];
}

}  // namespace

// A scene of several devices (kTwoDeviceScene): device 0's columns keep their names, each other
// device's follow them named "<column>@<device>" (docs/outputs.md, "Trace columns"), with its
// body's target and pose — right_tool ends at its path's end, (0, 0.06, 0).
TEST(TraceColumns, EachOtherDeviceHasItsColumnsNamedAfterIt) {
  numen::test::TempDir dir;
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("two.toml", numen::test::kTwoDeviceScene));
  numen::sim::SceneRunner runner(scene, 800);
  for (int k = 0; k < 750; ++k) runner.period();
  runner.finish();
  runner.trace().write_csv((dir / "trace.csv").string());
  const std::vector<std::string> lines = numen::test::read_lines(dir / "trace.csv");
  const std::vector<std::string> header = numen::test::split_csv(lines.at(0));
  const auto column = [&header](const std::string& name) {
    const auto at = std::find(header.begin(), header.end(), name);
    EXPECT_NE(at, header.end()) << name;
    return static_cast<std::size_t>(at - header.begin());
  };
  for (const char* name : {"target_x", "tool_x", "feedback_fx", "sample_valid@right", "target_x@right",
                           "target_y@right", "target_z@right", "tool_x@right", "tool_y@right", "tool_z@right",
                           "feedback_fx@right", "feedback_fy@right", "feedback_fz@right"})
    column(name);
  EXPECT_EQ(std::count_if(header.begin(), header.end(), [](const std::string& n) { return n.find('@') != std::string::npos; }),
            10);
  const std::vector<std::string> last = numen::test::split_csv(lines.back());
  ASSERT_EQ(last.size(), header.size());
  EXPECT_NEAR(std::stod(last[column("tool_y@right")]), 0.06, 2e-3);
  EXPECT_NEAR(std::stod(last[column("target_y@right")]), 0.06, 1e-4);
  EXPECT_NEAR(std::stod(last[column("tool_x")]), 0.01, 2e-3);  // device 0's "left_tool"
  EXPECT_EQ(last[column("sample_valid@right")], "1");
  // On the way the right tool lags its target (its own columns, not device 0's).
  double largest = 0.0;
  for (std::size_t k = 1; k < lines.size(); ++k) {
    const std::vector<std::string> row = numen::test::split_csv(lines[k]);
    largest = std::max(largest, std::abs(std::stod(row[column("target_y@right")]) - std::stod(row[column("tool_y@right")])));
  }
  EXPECT_GT(largest, 1e-5);
  EXPECT_LT(largest, 2e-3);
  // A scene of one device has no such column.
  const numen::sim::Scene one = numen::sim::load_scene(dir.write("mini.toml", numen::test::kMiniScene));
  numen::sim::SceneRunner single(one, 10);
  for (int k = 0; k < 10; ++k) single.period();
  single.finish();
  single.trace().write_csv((dir / "one.csv").string());
  EXPECT_EQ(numen::test::read_lines(dir / "one.csv").at(0).find('@'), std::string::npos);
}
