// Tests of sim/run/grasp_summary: the grasps of a run in its summary (docs/grasping.md,
// docs/outputs.md `grasp.*`).

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "build_features.hpp"
#include "csv_lines.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/sim/run/grasp_summary.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/view/view_recording.hpp"
#include "numen/sim/view/view_series.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

TEST(GraspSummary, AnEventReadsAsTimeWhatWhoAndWhat) {
  numen::core::Model m;
  m.bodies.resize(2);
  m.bodies[1].name = "block";
  m.nets.resize(1);
  m.nets[0].name = "organ";
  m.threads.resize(2);
  m.threads[0].name = "suture";
  numen::core::GraspModel g;
  g.name = "grasper";
  using numen::core::GraspEvent;
  EXPECT_EQ(numen::sim::format_grasp_event(m, g, {6.9614, GraspEvent::kGrasp, -1, 0, 7, 0.0}),
            "6.961 s grasp grasper: organ (7 nodes)");
  EXPECT_EQ(numen::sim::format_grasp_event(m, g, {8.611, GraspEvent::kSlip, -1, 0, 4, 5.0049}),
            "8.611 s slip grasper: organ (4 nodes, pull 5.005 N)");
  EXPECT_EQ(numen::sim::format_grasp_event(m, g, {1.0, GraspEvent::kRelease, 1, -1, 10, 0.25}),
            "1.000 s release grasper: block (10 grip springs, pull 0.250 N)");
  // A thread (docs/thread.md, "The thread in the jaws"): named, or by index without a name.
  EXPECT_EQ(numen::sim::format_grasp_event(m, g, {2.5, GraspEvent::kGrasp, -1, -1, 3, 0.0, 0}),
            "2.500 s grasp grasper: thread suture (3 nodes)");
  EXPECT_EQ(numen::sim::format_grasp_event(m, g, {2.75, GraspEvent::kSlip, -1, -1, 2, 0.5123, 1}),
            "2.750 s slip grasper: thread 1 (2 nodes, pull 0.512 N)");
}

// The default scene's recording with a grasper on its jaws: the recorded suturing motion closes
// the jaws on the organ (docs/grasping.md, "On the shipped recording"); the summary counts and
// lists each grasp, release and slip in JSON and text.
TEST(GraspSummary, TheDefaultRecordingGraspsTheOrgansTissueAndTheSummaryListsIt) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  std::string text = numen::test::shipped_scene_text_anywhere("default.toml");
  text += "\n[[grasp]]\nname = \"grasper\"\njaws = [\"jaw_1\", \"jaw_2\"]\n";
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("grasp.toml", text));
  numen::sim::RunOptions opt;
  opt.duration_s = 9.0;
  opt.trace_path = (dir / "trace.csv").string();
  opt.record_view_path = (dir / "run.nmv").string();
  const numen::sim::RunSummary s = numen::sim::run_scene(scene, opt);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_TRUE(s.grasping);
  EXPECT_GE(s.grasps_started, 1);
  ASSERT_EQ(static_cast<std::int64_t>(s.grasp_events.size()),
            s.grasps_started + s.grasps_released + s.grasps_slipped);
  EXPECT_NE(s.grasp_events[0].find(" grasp grasper: organ ("), std::string::npos) << s.grasp_events[0];
  for (const std::string& e : s.grasp_events) std::printf("[   info   ] %s\n", e.c_str());
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j["grasp"]["started"].get<std::int64_t>(), s.grasps_started);
  EXPECT_EQ(j["grasp"]["events"].size(), s.grasp_events.size());
  const std::string summary = numen::sim::format_summary(s);
  EXPECT_NE(summary.find("grasps: " + std::to_string(s.grasps_started) + " started"), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("grasp event: " + s.grasp_events[0]), std::string::npos) << summary;
  // The trace's grasps_held column goes 0 → 1 at each grasp and back at each release or slip.
  std::ifstream in(opt.trace_path);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const std::vector<std::string> header = numen::test::split_csv(line);
  const auto held_column = std::find(header.begin(), header.end(), "grasps_held");
  ASSERT_NE(held_column, header.end());
  const auto held_at = static_cast<std::size_t>(held_column - header.begin());
  int changes_up = 0, changes_down = 0, last = 0;
  while (std::getline(in, line)) {
    const std::vector<std::string> row = numen::test::split_csv(line);
    ASSERT_EQ(row.size(), header.size());
    const int held = std::stoi(row[held_at]);
    changes_up += held > last ? 1 : 0;
    changes_down += held < last ? 1 : 0;
    last = held;
  }
  EXPECT_EQ(changes_up, s.grasps_started);
  EXPECT_EQ(changes_down, s.grasps_released + s.grasps_slipped);
  // The view recording's frames (60 Hz) carry the grasper: its replay series lists the same
  // events, each at the first frame after it (docs/viewer.md, "Plots over the whole recording").
  const numen::sim::ViewRecordingReader reader(opt.record_view_path);
  numen::sim::ViewRecordingSource source(reader);
  const nlohmann::json series = nlohmann::json::parse(numen::sim::view_replay_series(source));
  ASSERT_EQ(series["grasp_event_count"].get<std::size_t>(), s.grasp_events.size()) << series["grasp_events"];
  for (std::size_t i = 0; i < s.grasp_events.size(); ++i) {
    const nlohmann::json& e = series["grasp_events"][i];
    const double t = std::stod(s.grasp_events[i]);  // "6.968 s grasp grasper: organ (5 nodes)"
    EXPECT_NE(s.grasp_events[i].find(" " + e["event"].get<std::string>() + " grasper: organ"), std::string::npos)
        << s.grasp_events[i] << " against " << e;
    EXPECT_GE(e["t"].get<double>(), t - 1e-3) << e;
    EXPECT_LE(e["t"].get<double>(), t + 1.0 / 60.0 + 2e-3) << e;
    EXPECT_EQ(e["grasper"], 0);
    EXPECT_EQ(e["net"], 0) << e;  // the organ's tissue
  }
}

TEST(GraspSummary, ASceneWithoutAGrasperWritesNoGraspFigures) {
  numen::sim::RunSummary s;
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_FALSE(j.contains("grasp"));
}
