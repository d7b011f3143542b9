// Tests of sim/trace: records are built from the state after a step, stored
// without allocation up to the reserved capacity (the rest are counted as
// dropped), and written as CSV with a header and one row per record; an
// unwritable path is an error naming the path.
#include "numen/sim/run/trace.hpp"

#include <gtest/gtest.h>

#include "lattice_scene.hpp"
#include "temp_dir.hpp"
#include <unistd.h>

#include <array>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "csv_lines.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "build_features.hpp"

namespace {

namespace fs = std::filesystem;
using numen::core::Vec3;
using numen::sim::Trace;
using numen::sim::TraceRecord;

using numen::test::csv_column;
using numen::test::read_lines;
using numen::test::split_csv;
using numen::test::TempDir;

TraceRecord record(int i) {
  TraceRecord r;
  r.time_s = 0.001 * (i + 1);
  r.held_body = i % 2;
  r.sample_valid = i != 1;
  r.target.position = Vec3(0.1 * i, 0.2, -0.3);
  r.tool.position = Vec3(0.1 * i, 0.2, -0.25);
  r.contacts = 3 * i;
  r.tool_contacts = i;
  r.tool_penetration_mm = 0.5 + i;
  r.target_penetration_mm = 12.25 + i;
  r.feedback.force = Vec3(1.5, -2.0, 0.25 * i);
  r.num_axes = 3;
  r.axis_torque[0] = 0.1;
  r.axis_torque[1] = -0.2 * i;
  r.axis_torque[2] = 0.3;
  r.step_time_us = 7.5;
  r.solver_iterations = 4 + i;
  r.solver_residual = 2.5e-7 * (i + 1);
  r.node_contacts = 10 + i;
  r.net_penetration_mm = 0.125 * i;
  r.net_tie_stretch_mm = 1.5 + i;
  r.net_strain_max = 0.0625 * i;
  return r;
}

TEST(Trace, WriteCsvHasAHeaderAndOneRowPerRecord) {
  Trace trace;
  trace.reserve(4);
  for (int i = 0; i < 4; ++i) trace.push(record(i));
  TempDir dir;
  const fs::path path = dir / "trace.csv";
  trace.write_csv(path.string());
  const std::vector<std::string> lines = read_lines(path);
  ASSERT_EQ(lines.size(), 5u);
  const std::vector<std::string> header = split_csv(lines[0]);
  EXPECT_EQ(header.front(), "time_s");
  EXPECT_EQ(header.back(), "needle_event");
  EXPECT_EQ(csv_column(header, "grasps_held") + 1, csv_column(header, "thread_tension_n"));
  EXPECT_EQ(csv_column(header, "baumgarte_rhs_max") + 1, csv_column(header, "solver_residual"));
  EXPECT_EQ(csv_column(header, "solver_iterations") + 1, csv_column(header, "joint_drift_mm"));
  // One column per axis torque, as many as the records have.
  EXPECT_EQ(csv_column(header, "axis_torque_0") + 2, csv_column(header, "axis_torque_2"));
  for (const auto& h : header) EXPECT_NE(h, "axis_torque_3");
  for (int i = 0; i < 4; ++i) {
    const std::vector<std::string> row = split_csv(lines[static_cast<std::size_t>(i) + 1]);
    ASSERT_EQ(row.size(), header.size()) << "row " << i;
    const TraceRecord r = record(i);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "time_s")]), r.time_s);
    EXPECT_EQ(std::stoi(row[csv_column(header, "attached_body")]), r.held_body);
    EXPECT_EQ(std::stoi(row[csv_column(header, "sample_valid")]), r.sample_valid ? 1 : 0);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "target_x")]), r.target.position.x());
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "tool_z")]), r.tool.position.z());
    EXPECT_EQ(std::stoi(row[csv_column(header, "contacts")]), r.contacts);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "target_penetration_mm")]),
                     r.target_penetration_mm);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "feedback_fz")]), r.feedback.force.z());
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "axis_torque_1")]), r.axis_torque[1]);
    EXPECT_EQ(std::stoi(row[csv_column(header, "solver_iterations")]), r.solver_iterations);
    // Deformable nets.
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "solver_residual")]), r.solver_residual);
    EXPECT_EQ(std::stoi(row[csv_column(header, "node_contacts")]), r.node_contacts);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "net_penetration_mm")]),
                     r.net_penetration_mm);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "net_tie_stretch_mm")]),
                     r.net_tie_stretch_mm);
    EXPECT_DOUBLE_EQ(std::stod(row[csv_column(header, "net_strain_max")]), r.net_strain_max);
  }
}

TEST(Trace, EmptyTraceWritesOnlyTheHeader) {
  Trace trace;
  TempDir dir;
  trace.write_csv((dir / "empty.csv").string());
  const auto lines = read_lines(dir / "empty.csv");
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind("time_s,", 0), 0u);
}

TEST(Trace, PushBeyondCapacityCountsDropsAndNeverAllocates) {
  Trace trace;
  trace.reserve(3);
  const std::size_t capacity = trace.records().capacity();
  ASSERT_GE(capacity, 3u);
  const TraceRecord r = record(2);
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int i = 0; i < static_cast<int>(capacity) + 7; ++i) trace.push(record(i));
    count = guard.count();
  }
  EXPECT_EQ(count, 0);
  EXPECT_EQ(trace.records().size(), capacity);
  EXPECT_EQ(trace.dropped(), 7u);
  EXPECT_EQ(trace.records().capacity(), capacity);
  // The stored records are the first ones, not overwritten by the dropped ones.
  EXPECT_EQ(trace.records()[2].time_s, r.time_s);
  EXPECT_EQ(trace.records().back().contacts, record(static_cast<int>(capacity) - 1).contacts);

  Trace none;  // nothing reserved: everything is dropped
  none.push(r);
  EXPECT_TRUE(none.records().empty());
  EXPECT_EQ(none.dropped(), 1u);
}

TEST(Trace, UnwritablePathThrowsNamingThePath) {
  Trace trace;
  trace.reserve(1);
  trace.push(record(0));
  TempDir dir;
  const std::string path = (dir / "no_such_dir" / "trace.csv").string();
  try {
    trace.write_csv(path);
    ADD_FAILURE() << "no error writing " << path;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path));
}

TEST(Trace, WriteErrorOfASmallTraceIsReported) {
  // /dev/full opens fine and fails every write with ENOSPC (disk full). A
  // short trace fits in the stream buffer, so the failure only shows when the
  // buffer is flushed: it must still be reported, not lost.
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  Trace trace;
  trace.reserve(2);
  trace.push(record(0));
  trace.push(record(1));
  try {
    trace.write_csv("/dev/full");
    ADD_FAILURE() << "a trace written to a full disk was reported as written";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full"), std::string::npos) << e.what();
  }
}

// A run's --trace path is checked before the run (a long run must not end without its trace),
// and a trace that cannot be written after the run is counted, not thrown: the summary stays,
// the verdict reports the lost records (exit status 5, "lost records").
TEST(Trace, ARunChecksItsPathFirstAndCountsAFailedWrite) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::sim::Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path());
  numen::sim::RunOptions opt;
  opt.duration_s = 0.05;
  TempDir dir;
  opt.trace_path = (dir / "no_such_dir" / "trace.csv").string();
  try {
    (void)numen::sim::run_scene(scene, opt);
    ADD_FAILURE() << "a trace path in a missing directory was accepted";
  } catch (const numen::sim::InputError& e) {
    EXPECT_EQ(e.key(), "--trace");
    EXPECT_NE(std::string(e.what()).find(opt.trace_path), std::string::npos) << e.what();
  }
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  opt.trace_path = "/dev/full";  // opens, every write fails (ENOSPC)
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, opt);
  EXPECT_EQ(s.trace_pushed, s.steps);
  EXPECT_EQ(s.trace_written, 0);
  EXPECT_EQ(s.trace_io_errors, 1);
  EXPECT_EQ(s.exit_status, 5);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings.back().find("/dev/full"), std::string::npos) << s.warnings.back();
  // Written: every record counted as written.
  opt.trace_path = (dir / "trace.csv").string();
  const numen::sim::RunSummary ok = numen::sim::run_scene(scene, opt);
  EXPECT_EQ(ok.trace_written, ok.steps);
  EXPECT_EQ(ok.trace_io_errors, 0);
  EXPECT_EQ(ok.exit_status, 0);
  EXPECT_EQ(read_lines(opt.trace_path).size(), static_cast<std::size_t>(ok.steps) + 1);
}

TEST(Trace, MakeTraceRecordReadsTheStateAfterTheStep) {
  numen::core::Model model;
  model.bodies.resize(2);
  numen::core::Data data;
  data.time = 0.123;
  data.bodies.resize(2);
  data.bodies[1].position = Vec3(1.0, 2.0, 3.0);
  data.bodies[1].orientation = numen::core::Quat(Eigen::AngleAxisd(0.3, Vec3::UnitY()));
  data.target.position = Vec3(1.0, 2.0, 2.9);
  data.num_contacts = 4;
  data.feedback_wrench.force = Vec3(0.5, 0.0, -1.0);
  data.solver_iterations = 6;
  numen::platform::PeriodReport report;
  report.sample_valid = true;
  report.step_ns = 12'500;
  report.feedback.force = Vec3(0.5, -1.0, 2.0);  // what was sent; the core's wrench differs
  const std::array<double, 3> tau{0.1, -0.2, 0.3};

  const TraceRecord r = numen::sim::make_trace_record(data, 1, 2, 0.0015, 0.012, report, tau);
  EXPECT_EQ(r.time_s, 0.123);
  EXPECT_EQ(r.held_body, 1);
  EXPECT_TRUE(r.sample_valid);
  EXPECT_EQ(r.tool.position, data.bodies[1].position);
  EXPECT_TRUE(r.tool.orientation.isApprox(data.bodies[1].orientation));
  EXPECT_EQ(r.target.position, data.target.position);
  EXPECT_EQ(r.contacts, 4);
  EXPECT_EQ(r.tool_contacts, 2);
  EXPECT_DOUBLE_EQ(r.tool_penetration_mm, 1.5);
  EXPECT_DOUBLE_EQ(r.target_penetration_mm, 12.0);
  EXPECT_EQ(r.feedback.force, report.feedback.force);
  EXPECT_EQ(r.num_axes, 3);
  EXPECT_EQ(r.axis_torque[1], -0.2);
  EXPECT_EQ(r.axis_torque[3], 0.0);
  EXPECT_DOUBLE_EQ(r.step_time_us, 12.5);
  EXPECT_EQ(r.solver_iterations, 6);

  // No body held: the tool pose is the zero pose.
  const TraceRecord none = numen::sim::make_trace_record(data, -1, 0, 0.0, 0.0, report, tau);
  EXPECT_EQ(none.held_body, -1);
  EXPECT_EQ(none.tool.position, Vec3::Zero());
}

TEST(Trace, RunSceneWritesOneRowPerStep) {
  NUMEN_REQUIRE_ARTICULATION();
  const numen::sim::Scene scene = numen::sim::load_scene(numen::test::lattice_scene_path());
  TempDir dir;
  numen::sim::RunOptions opt;
  opt.duration_s = 0.25;
  opt.trace_path = (dir / "run.csv").string();
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, opt);
  ASSERT_EQ(s.steps, 250);
  const auto lines = read_lines(dir / "run.csv");
  ASSERT_EQ(lines.size(), 251u);
  const auto header = split_csv(lines[0]);
  // Per-axis columns are named by the scene's axes, the last followed by step_time_us.
  ASSERT_EQ(scene.device.axes.size(), 5u);
  EXPECT_EQ(csv_column(header, "axis_torque_" + scene.device.axes.back().name) + 1,
            csv_column(header, "step_time_us"));
  const auto last = split_csv(lines.back());
  ASSERT_EQ(last.size(), header.size());
  EXPECT_NEAR(std::stod(last[0]), 0.25, 1e-9);

  // An unwritable trace path is reported after the run, naming the path.
  opt.trace_path = (dir / "missing_dir" / "run.csv").string();
  try {
    (void)numen::sim::run_scene(scene, opt);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(opt.trace_path), std::string::npos) << e.what();
  }
}

}  // namespace
