/// @file run_closed_loop_test.cpp
/// The haptic loop closed in a run (docs/device_plant.md): the shipped default scene's trainer
/// moves under numen's torques and the hand (PlantMotion). It stays stable and passive, the
/// feedback pushes the handle back out of the organ while the god-object stays on its surface;
/// an active plant and coupling makes a limit cycle the run reports; a plant that runs away
/// latches the divergence; the closed loop's periods never allocate.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"
#include "run_scenes.hpp"
#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

namespace run_closed_loop_test {

using numen::sim::ExitStatus;
using numen::sim::RunSummary;
using numen::sim::Scene;
using numen::test::replace;

/// The shipped lattice scene's text, loadable from a temporary directory, with `edits` applied.
std::string default_text() {
  std::string text = numen::test::shipped_scene_text("lattice.toml");
  return replace(text, "\"../data/", "\"" + std::string(NUMEN_SOURCE_DIR) + "/sim/data/");
}

/// `text`'s plant without damping or friction and its feedback coupling at 3000 N/m with no
/// damper: the lint's "not passive" case.
std::string active(std::string text) {
  text = replace(text, "damping = [0.02, 0.02, 1.5, 0.0, 0.0]", "damping = [0.0, 0.0, 0.0, 0.0, 0.0]");
  text = replace(text, "coulomb = [0.01, 0.01, 0.1, 0.0, 0.0]", "coulomb = [0.0, 0.0, 0.0, 0.0, 0.0]");
  text = replace(text, "stiffness = 300.0            # N/m\ndamping = 1.0",
                 "stiffness = 3000.0\ndamping = 0.0");
  text = replace(text, "[device.plant]\n", "[device.plant]\ndelay_periods = 3\n");
  return text;
}

RunSummary run_for(const Scene& scene, double seconds) {
  numen::sim::RunOptions o;
  o.duration_s = seconds;
  return numen::sim::run_scene(scene, o);
}

// The whole shipped recording, closed loop: clean, no limit cycle, the hand 24 mm into the
// organ, the handle held back by the feedback, the god-object on the surface.
TEST(RunClosedLoop, LatticeSceneIsStableAndPushesTheHandleBack) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER("a 30 s run's figures (the closed loop's periods run under the "
                             "sanitizers in RunClosedLoop.PeriodsNeverAllocate)");
  const Scene& scene = numen::test::run_scenes::lattice_scene();
  ASSERT_TRUE(scene.plant.has_value());
  const RunSummary s = run_for(scene, -1.0);
  std::printf("[   info   ] hand %.3f mm, handle %.3f mm, tool %.3f mm, handle force %.3f N, "
              "port energy %.4f J (min %.2e J), separation %.3f mm\n",
              s.hand_penetration_max_mm, s.device_penetration_max_mm, s.tool_penetration_max_mm,
              s.handle_force_max_n, s.device_port_energy_j, s.device_port_energy_min_j,
              s.hand_separation_max_mm);
  EXPECT_EQ(numen::sim::run_verdict(s).status, ExitStatus::kClean);
  EXPECT_EQ(s.device_loop, "closed");
  EXPECT_FALSE(s.limit_cycle_detected);
  EXPECT_GT(s.hand_penetration_max_mm, 20.0) << "the recorded hand goes through the organ";
  EXPECT_LT(s.device_penetration_max_mm, 0.5 * s.hand_penetration_max_mm)
      << "the feedback holds the handle back";
  EXPECT_LT(s.tool_penetration_max_mm, 1.0) << "the god-object stays on the surface";
  EXPECT_GT(s.handle_force_max_n, 1.0);
  EXPECT_GT(s.device_port_energy_j, 0.0);
  EXPECT_GE(s.device_port_energy_min_j, -1e-3 * s.device_port_energy_j);
  EXPECT_EQ(s.device_penetration_max_mm, s.target_penetration_max_mm);
}

// No device damping or friction under a stiff undamped coupling: the handle buzzes. The run
// reports the limit cycle (and warns), the port energy goes negative, the lint warned at load.
TEST(RunClosedLoop, AnActiveLoopIsReportedAsALimitCycle) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const Scene scene = numen::sim::load_scene(dir.write("active.toml", active(default_text())));
  const RunSummary s = run_for(scene, 8.0);
  std::printf("[   info   ] limit cycle %.3f mm at %.2f Hz from %.3f s; port energy min %.4f J\n",
              s.limit_cycle_amplitude_mm, s.limit_cycle_hz, s.limit_cycle_time_s,
              s.device_port_energy_min_j);
  EXPECT_TRUE(s.limit_cycle_detected);
  EXPECT_GT(s.limit_cycle_hz, 5.0);
  EXPECT_GT(s.limit_cycle_amplitude_mm, 0.05);
  EXPECT_LT(s.device_port_energy_min_j, 0.0);
  int limit_cycle_warnings = 0, lint_warnings = 0;
  for (const std::string& w : s.warnings) {
    limit_cycle_warnings += w.find("went into a limit cycle") != std::string::npos;
    lint_warnings += w.find("may not be passive") != std::string::npos;
  }
  EXPECT_EQ(limit_cycle_warnings, 1);
  EXPECT_EQ(lint_warnings, 3);
}

/// The default text with its depth axis at `inertia` kg without damping, and a hand without
/// mass or damper (its spring, held over each sub-step, on almost no mass) of `hand`'s extra
/// keys: a plant the sub-steps cannot hold.
std::string runaway(const std::string& inertia, const std::string& hand = "") {
  std::string text = replace(default_text(), "inertia = [4.0e-3, 4.0e-3, 0.15, 0.0, 0.0]",
                             "inertia = [4.0e-3, 4.0e-3, " + inertia + ", 0.0, 0.0]");
  text = replace(text, "damping = [0.02, 0.02, 1.5, 0.0, 0.0]",
                 "damping = [0.02, 0.02, 0.0, 0.0, 0.0]");
  return replace(text, "[device.feedback]",
                 "[device.hand]\nmass = 0.0\ndamping = 0.0\n" + hand + "\n[device.feedback]");
}

/// The divergence's reason of `s` and its expected text around the value: the axis speed and
/// its runaway speed, 100 x the axis's max_speed (2 m/s: docs/device_plant.md), at the
/// divergence's time.
void expect_axis_speed_reason(const RunSummary& s, const Scene& scene) {
  ASSERT_EQ(scene.device.axes[2].max_speed, 2.0) << "test bug: the text below says 200";
  const double limit = 100.0 * scene.device.axes[2].max_speed;
  EXPECT_EQ(s.divergence.limit, limit);
  EXPECT_GT(s.divergence.value, limit) << "the axis's speed, above its runaway speed";
  const std::vector<std::string> reasons = numen::sim::run_verdict(s).reasons;
  ASSERT_FALSE(reasons.empty());
  const std::string head = "diverged: device plant of device axis 2: ";
  char at[32];
  std::snprintf(at, sizeof at, "%.4f s", s.divergence.time_s);
  const std::string tail = std::string(" above its limit 200 (m/s or rad/s) at ") + at;
  EXPECT_EQ(reasons[0].substr(0, head.size()), head) << reasons[0];
  ASSERT_GE(reasons[0].size(), tail.size());
  EXPECT_EQ(reasons[0].substr(reasons[0].size() - tail.size()), tail) << reasons[0];
}

// A plant the sub-steps cannot hold (the depth axis at 1e-9 kg) runs away when the hand first
// moves it: the run latches the divergence with the cause "device plant", the axis's speed and
// its runaway speed (it gave the sub-step's time against a limit of 0), and exits 7.
TEST(RunClosedLoop, APlantThatRunsAwayLatchesTheDivergence) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const Scene scene = numen::sim::load_scene(dir.write("runaway.toml", runaway("1.0e-9")));
  const RunSummary s = run_for(scene, 2.0);
  EXPECT_TRUE(s.divergence.latched);
  EXPECT_EQ(s.divergence.cause, "device plant");
  EXPECT_EQ(s.divergence.subject, "device axis 2");
  EXPECT_EQ(numen::sim::run_verdict(s).status, ExitStatus::kDiverged);
  expect_axis_speed_reason(s, scene);
}

// The same plant under a stiff hand whose recording moves from its first period on runs away in
// period 1, before the CANopen start-up has made the encoders send: the verdict says the
// divergence stopped the run, not "run longer" (a longer run stops there too).
TEST(RunClosedLoop, APlantThatRunsAwayBeforeTheStartUpIsNotToldToRunLonger) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  std::string text = runaway("1.0e-15", "stiffness = 1.0e9\n");
  text = replace(text, "manipulator = \"slave_right\"\n",
                 "manipulator = \"slave_right\"\nstart_time = 5.0\n");
  const Scene scene = numen::sim::load_scene(dir.write("early.toml", text));
  const RunSummary s = run_for(scene, 2.0);
  EXPECT_EQ(s.divergence.period, 1);
  EXPECT_EQ(s.steps, 2);
  EXPECT_DOUBLE_EQ(s.divergence.time_s, 0.001);
  expect_axis_speed_reason(s, scene);
  const std::vector<std::string> reasons = numen::sim::run_verdict(s).reasons;
  ASSERT_EQ(reasons.size(), 2u);
  EXPECT_EQ(reasons[1],
            "samples rejected: no period had a valid sample: the divergence stopped the run after "
            "2 periods, before the CANopen start-up finished (still in phase 'configure'); the "
            "encoders send once their nodes are operational");
}

// The closed loop's periods (the emulated plant and hand, the hand's penetration, the figures)
// never allocate.
TEST(RunClosedLoop, PeriodsNeverAllocate) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& scene = numen::test::run_scenes::lattice_scene();
  numen::sim::SceneRunner runner(scene);
  for (int k = 0; k < 200; ++k) runner.period();  // start-up, first contacts
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 2000; ++k) runner.period();
  EXPECT_EQ(guard.count(), 0);
}

}  // namespace run_closed_loop_test
