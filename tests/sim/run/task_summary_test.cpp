// Tests of sim/run/task_summary: a bimanual task's figures in the run's summary — the shipped
// peg transfer (sim/scenes/peg_transfer.toml) transfers its objects without a drop, a grip too
// weak to hold an object drops it and the summary says so (docs/grasping.md "Peg transfer",
// docs/outputs.md `task.*`).

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include <nlohmann/json.hpp>

#include "build_features.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "numen/sim/run/task_summary.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

/// The shipped peg transfer run for `duration` s (its DCF paths made absolute), `edit` applied
/// to its text first.
numen::sim::RunSummary run_peg_transfer(double duration, const std::string& from = "", const std::string& to = "") {
  numen::test::TempDir dir;
  std::string text = numen::test::shipped_scene_text("peg_transfer.toml");
  if (!from.empty()) text = numen::test::replace(text, from, to);
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("peg.toml", text));
  numen::sim::RunOptions opt;
  opt.duration_s = duration;
  return numen::sim::run_scene(scene, opt);
}

}  // namespace

TEST(TaskSummary, ThePegTransferPlacesItsFirstObjectsAfterAHandOverWithoutADrop) {
  NUMEN_REQUIRE_ARTICULATION();
  // The first two objects' cycles (the whole scene: docs/grasping.md, "Peg transfer").
  const numen::sim::RunSummary s = run_peg_transfer(10.5);
  for (const std::string& line : s.task.lines) std::printf("[   info   ] %s\n", line.c_str());
  for (const std::string& line : s.grasper_lines) std::printf("[   info   ] %s\n", line.c_str());
  EXPECT_FALSE(s.nan_detected);
  EXPECT_EQ(s.exit_status, 0) << numen::sim::format_summary(s);
  ASSERT_TRUE(s.task.enabled);
  EXPECT_EQ(s.task.objects, 6);
  EXPECT_EQ(s.task.transferred, 2);
  EXPECT_EQ(s.task.placed, 2);
  EXPECT_EQ(s.task.handovers, 2);
  EXPECT_EQ(s.task.drops, 0);
  EXPECT_GT(s.task.time_s, 4.0);
  EXPECT_LT(s.task.time_s, 10.5);
  ASSERT_EQ(s.task.lines.size(), 6u);
  EXPECT_EQ(s.task.lines[0].rfind("object_1: 2 grasps, 1 hand-over, 0 drops; placed on peg_r1 at ", 0), 0u)
      << s.task.lines[0];
  EXPECT_EQ(s.task.lines[5].rfind("object_6: 0 grasps, 0 hand-overs, 0 drops; ends on no peg", 0), 0u)
      << s.task.lines[5];
  // Each grasper on its own device: left gave both hand-overs, right took them (left holds the
  // third object at the end).
  ASSERT_EQ(s.grasper_lines.size(), 2u);
  EXPECT_EQ(s.grasper_lines[0].rfind("left_grasper (device left): 3 started, 2 released, 0 slipped; hand-overs 2 "
                                     "given, 0 taken; feedback force on its hand max ", 0),
            0u)
      << s.grasper_lines[0];
  EXPECT_EQ(s.grasper_lines[1].rfind("right_grasper (device right): 2 started, 2 released, 0 slipped; hand-overs 0 "
                                     "given, 2 taken", 0),
            0u)
      << s.grasper_lines[1];
  // JSON and text carry the same figures.
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j.at("task").at("transferred").get<std::int64_t>(), 2);
  EXPECT_EQ(j.at("task").at("drops").get<std::int64_t>(), 0);
  EXPECT_EQ(j.at("task").at("lines").size(), 6u);
  EXPECT_EQ(j.at("grasp").at("graspers").size(), 2u);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("  task: 2 of 6 objects transferred (2 placed); hand-overs 2, drops 0; time "), std::string::npos)
      << text;
  EXPECT_NE(text.find("  task object: " + s.task.lines[0]), std::string::npos) << text;
  EXPECT_NE(text.find("  grasper " + s.grasper_lines[1]), std::string::npos) << text;
}

TEST(TaskSummary, AGripTooWeakForTheObjectDropsItAndTheSummarySaysSo) {
  NUMEN_REQUIRE_ARTICULATION();
  // The left grip slips past 0.03 N: less than a 4 g object's weight (0.039 N). Lifted, the
  // first object slips out of the left jaws and falls: a drop, nothing transferred.
  const numen::sim::RunSummary s =
      run_peg_transfer(5.0, "name = \"left_grasper\"\n", "name = \"left_grasper\"\nmax_force = 0.03\n");
  for (const std::string& line : s.task.lines) std::printf("[   info   ] %s\n", line.c_str());
  EXPECT_GE(s.grasps_slipped, 1);
  EXPECT_GE(s.task.drops, 1);
  EXPECT_EQ(s.task.transferred, 0);
  EXPECT_EQ(s.task.placed, 0);
  EXPECT_EQ(s.task.time_s, 0.0);
  EXPECT_NE(s.task.lines[0].find("0 hand-overs, 1 drop; ends "), std::string::npos) << s.task.lines[0];
  // The load warned that the grip cannot hold the objects.
  bool warned = false;
  for (const std::string& w : s.warnings) warned = warned || w.find("grasp \"left_grasper\": body \"object_1\" weighs") == 0;
  EXPECT_TRUE(warned);
}

TEST(TaskSummary, AnObjectIsOnAPegWithinReachOfItsAxis) {
  numen::core::Obstacle peg;
  peg.type = numen::core::ShapeType::kCapsule;
  peg.pose.position = numen::core::Vec3(0.05, 0.0, 0.01);  // from (0.05, 0, 0) to (0.05, 0, 0.02)
  peg.half_length = 0.01;
  EXPECT_NEAR(numen::sim::distance_to_capsule_axis(peg, numen::core::Vec3(0.053, 0.004, 0.002)), 0.005, 1e-12);
  EXPECT_NEAR(numen::sim::distance_to_capsule_axis(peg, numen::core::Vec3(0.05, 0.0, 0.05)), 0.03, 1e-12);
  EXPECT_NEAR(numen::sim::distance_to_capsule_axis(peg, numen::core::Vec3(0.05, 0.0, -0.002)), 0.002, 1e-12);
}
