// Tests of sim/run: the summary's figures (issue 17): a tool spawned inside an obstacle is a
// start-up reported apart, free-space tracking counts only free steps, and the JSON carries
// every figure of the text summary.
#include "numen/sim/run/run.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <atomic>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "child_process.hpp"
#include "run_scenes.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/input/jigsaws.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "build_features.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "sanitizer.hpp"

namespace {

using namespace numen::test::run_scenes;

// ---------------------------------------------------------------- summary figures (issue 17)

/// numen::test::kMiniScene (a ball held by a pose tracker over a floor at z = -0.1 m) with the
/// scripted trajectory `path` (the lines after source = "scripted").
std::string ball_over_floor(const std::string& path) {
  const std::string& mini = numen::test::kMiniScene;
  return mini.substr(0, mini.find("[trajectory]")) + "[trajectory]\nsource = \"scripted\"\n" + path;
}

TEST(RunSummaryFigures, AToolSpawnedInsideAnObstacleIsAStartUpReportedApartWithAWarning) {
  numen::test::TempDir dir;
  // The hand starts 15 mm inside the floor (ball bottom at -0.115 m) and rises out of it.
  const Scene scene = numen::sim::load_scene(dir.write("inside.toml", ball_over_floor(R"(
start = { position = [0.0, 0.0, -0.105] }
[[trajectory.segment]]
type = "line"
to = [0.0, 0.0, 0.0]
duration = 0.5
[[trajectory.segment]]
type = "hold"
duration = 0.2
)")));
  const RunSummary s = numen::sim::run_scene(scene, {});
  print_summary("start inside", s, 0.0);
  std::printf("[   info   ] start-up %lld steps from %.2f mm\n",
              static_cast<long long>(s.startup_steps), s.startup_tool_penetration_mm);
  EXPECT_NEAR(s.startup_tool_penetration_mm, 15.0, 0.5);
  EXPECT_GT(s.startup_steps, 0);
  EXPECT_LT(s.startup_steps, 200);  // pushed out within 0.2 s
  // After the start-up the god-object rests on the floor while the hand rises through it.
  EXPECT_LT(s.tool_penetration_max_mm, 1.0);
  EXPECT_GT(s.target_penetration_max_mm, 14.0);  // the hand's own depth is unchanged
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || (w.find("the tool started inside obstacle 'floor', 15.") != std::string::npos &&
                        w.find("start-up") != std::string::npos);
  EXPECT_TRUE(warned) << "a warning names the obstacle and the depth";
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("after a start-up of " + std::to_string(s.startup_steps) + " steps"),
            std::string::npos)
      << text;
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j.at("startup_steps").get<std::int64_t>(), s.startup_steps);
  EXPECT_EQ(j.at("startup_tool_penetration_mm").get<double>(), s.startup_tool_penetration_mm);
  EXPECT_EQ(j.at("tool_penetration_max_mm").get<double>(), s.tool_penetration_max_mm);
  EXPECT_EQ(j.at("warnings").size(), s.warnings.size());

  // Starting free: no start-up, no warning.
  const Scene free_scene = numen::sim::load_scene(dir.write("free.toml", ball_over_floor(R"(
start = { position = [0.0, 0.0, 0.0] }
[[trajectory.segment]]
type = "hold"
duration = 0.05
)")));
  const RunSummary f = numen::sim::run_scene(free_scene, {});
  EXPECT_EQ(f.startup_steps, 0);
  EXPECT_EQ(f.startup_tool_penetration_mm, 0.0);
  // The ball's pose tracker has no feedback (the load's note); nothing else.
  EXPECT_TRUE(std::all_of(f.warnings.begin(), f.warnings.end(), [](const std::string& w) {
    return w.rfind("no feedback: non-haptic device", 0) == 0;
  })) << f.warnings.front();
  EXPECT_EQ(numen::sim::format_summary(f).find("after a start-up"), std::string::npos);
}

TEST(RunSummaryFigures, FreeSpaceTrackingCountsOnlyStepsWhereNeitherToolNorHandTouches) {
  numen::test::TempDir dir;
  // The hand holds still in free space, then plunges 15 mm into the floor at 2.5 m/s: the
  // god-object, lagging on its spring, touches nothing for some steps while the hand is
  // already inside.
  const Scene scene = numen::sim::load_scene(dir.write("plunge.toml", ball_over_floor(R"(
start = { position = [0.0, 0.0, -0.08] }
[[trajectory.segment]]
type = "hold"
duration = 0.2
[[trajectory.segment]]
type = "line"
to = [0.0, 0.0, -0.105]
duration = 0.01
[[trajectory.segment]]
type = "hold"
duration = 0.29
)")));
  SceneRunner runner(scene, static_cast<std::size_t>(periods_for(scene, 0.5)));
  std::int64_t tool_free_hand_inside = 0;
  double error_hand_inside_mm = 0.0;  // the largest |x_tool - x_target| of those steps
  for (std::int64_t k = 0; k < periods_for(scene, 0.5); ++k) {
    runner.period();
    const TraceRecord& r = runner.trace().records().back();
    if (r.tool_contacts == 0 && r.target_penetration_mm > 0.0) {
      ++tool_free_hand_inside;
      error_hand_inside_mm =
          std::max(error_hand_inside_mm, (r.tool.position - r.target.position).norm() * 1e3);
    }
  }
  const RunSummary s = runner.summary();
  print_summary("plunge into the floor", s, 0.0);
  std::printf("[   info   ] steps with the tool free and the hand inside: %lld, error up to %.2f mm\n",
              static_cast<long long>(tool_free_hand_inside), error_hand_inside_mm);
  ASSERT_GT(error_hand_inside_mm, 12.0) << "test bug: the scenario has no such step";
  EXPECT_EQ(s.rejected_samples, 0);
  // In free space the hand holds, then moves 10 mm (ball bottom from 10 mm above the floor to
  // the floor): the error cannot exceed those 10 mm. The steps after, tool still free and hand
  // inside, are not free space.
  EXPECT_LT(s.tracking_error_free_max_mm, 10.0);
  EXPECT_LE(s.free_steps, periods_for(scene, 0.2) + 5);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("tracking error in free space (tool and hand out of contact)"),
            std::string::npos)
      << text;
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  EXPECT_EQ(j.at("tracking_error_free_max_mm").get<double>(), s.tracking_error_free_max_mm);
  EXPECT_EQ(j.at("free_steps").get<std::int64_t>(), s.free_steps);
}

TEST(RunSummaryFigures, JsonCarriesEveryFigureOfTheTextSummary) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::sim::RunOptions opt;
  opt.duration_s = 0.02;
  const RunSummary s = numen::sim::run_scene(lattice_scene(), opt);
  const nlohmann::json j = nlohmann::json::parse(numen::sim::format_summary_json(s));
  // Figures of the text summary that the JSON used to leave out.
  EXPECT_EQ(j.at("trocar_note").get<std::string>(), s.trocar_note);
  EXPECT_EQ(j.at("overrun_limit").get<std::uint32_t>(), s.overrun_limit);
  EXPECT_EQ(j.at("rearm_requests").get<std::int64_t>(), s.rearm_requests);
  EXPECT_EQ(j.at("rearms_accepted").get<std::int64_t>(), s.rearms_accepted);
  EXPECT_EQ(j.at("rearm_first_period").get<std::int64_t>(), s.rearm_first_period);
  for (const char* key : {"startup_steps", "startup_tool_penetration_mm", "free_steps",
                          "tracking_error_free_rms_mm", "tracking_error_free_max_mm"})
    EXPECT_TRUE(j.contains(key)) << key;
}

}  // namespace
