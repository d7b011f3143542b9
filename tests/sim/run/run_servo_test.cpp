// The scripted hand's servo in a run (sim/device/hand_servo.hpp through SceneRunner): a tool that
// sags under gravity on its coupling spring is brought onto its target by a hand that looks at
// it; the summary's servo figures and the warning of a servo that reached its max_offset; no
// allocation in the period. (numen device refuses a servo:
// tests/sim/device/device_process_test.cpp.)

#include <gtest/gtest.h>

#include <string>

#include "alloc_counter.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace {

using numen::core::Vec3;
using numen::test::replace;

/// kMiniScene under gravity (the 0.1 kg tool on its 100 N/m coupling sags 9.8 mm), its path
/// held 1 s at (10, 0, 0) mm after the line; with `servo`, a hand that looks at the tool and
/// wants it on the path's end from the line's end on, `keys` added to its table.
std::string sagging(bool servo, const std::string& keys = "max_offset = 0.02\n") {
  std::string text =
      replace(numen::test::kMiniScene, "gravity = [0.0, 0.0, 0.0]", "gravity = [0.0, 0.0, -9.81]");
  text = replace(text, "duration = 0.25\n", "duration = 1.0\n");
  if (!servo) return text;
  text = replace(text, "duration = 1.0\n", "duration = 1.0\nservo_target = [0.01, 0.0, 0.0]\n");
  return text + "\n[trajectory.servo]\nbody = \"tool\"\n" + keys;
}

/// The tool's position after the whole path (1 500 periods) of `text`'s run, and its summary.
Vec3 run_to_end(const std::string& text, numen::sim::RunSummary* summary = nullptr) {
  numen::test::TempDir dir;
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("s.toml", text));
  numen::sim::SceneRunner runner(scene);
  for (int k = 0; k < 1500; ++k) runner.period();
  if (summary) *summary = runner.summary();
  return runner.data().bodies[0].position;
}

TEST(RunServo, AToolThatSagsIsBroughtOnItsTargetByAHandThatLooks) {
  const Vec3 blind = run_to_end(sagging(false));
  EXPECT_LT(blind.z(), -0.009) << "the tool hangs 9.8 mm under the hand (0.98 N on 100 N/m)";
  numen::sim::RunSummary s;
  const Vec3 sighted = run_to_end(sagging(true), &s);
  EXPECT_NEAR((sighted - Vec3(0.01, 0.0, 0.0)).norm(), 0.0, 5e-5)
      << "on its target after 20 time constants";
  ASSERT_TRUE(s.servos);
  EXPECT_NEAR(s.servo_offset_max_mm, 9.8, 0.5) << "the hand held up by the sag";
  EXPECT_EQ(s.servo_saturated_periods, 0);
  ASSERT_EQ(s.servo_lines.size(), 1u);
  EXPECT_EQ(s.servo_lines[0].rfind("right", 0), std::string::npos);
  EXPECT_NE(s.servo_lines[0].find("watches tool: offset max"), std::string::npos)
      << s.servo_lines[0];
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("max_offset"), std::string::npos) << w;
}

TEST(RunServo, AServoThatReachesItsMaxOffsetIsWarned) {
  numen::sim::RunSummary s;
  const Vec3 held = run_to_end(sagging(true, "max_offset = 0.005\n"), &s);
  EXPECT_NEAR(held.z(), -0.0048, 0.0005) << "raised by 5 mm of its 9.8 mm sag";
  EXPECT_GT(s.servo_saturated_periods, 0);
  bool warned = false;
  for (const std::string& w : s.warnings)
    warned = warned || (w.find("servo reached its max_offset (5.000 mm)") != std::string::npos &&
                        w.find("could not bring tool to its target") != std::string::npos);
  EXPECT_TRUE(warned);
}

TEST(RunServo, PeriodsWithAServoNeverAllocate) {
  numen::test::TempDir dir;
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("s.toml", sagging(true)));
  numen::sim::SceneRunner runner(scene);
  for (int k = 0; k < 100; ++k) runner.period();
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 1000; ++k) runner.period();
  EXPECT_EQ(guard.count(), 0);
}

}  // namespace
