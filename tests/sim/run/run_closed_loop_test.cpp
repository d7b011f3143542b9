/// @file run_closed_loop_test.cpp
/// The haptic loop closed in a run (docs/device_plant.md): the shipped default scene's trainer
/// moves under numen's torques and the hand (PlantMotion). It stays stable and passive, the
/// feedback pushes the handle back out of the organ while the god-object stays on its surface;
/// an active plant and coupling makes a limit cycle the run reports; a plant that runs away
/// latches the divergence; the closed loop's periods never allocate.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

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

// A plant the sub-steps cannot hold (the depth axis at 1e-9 kg with no damping, and a hand
// without mass or damper: its spring, held over each sub-step, on almost no mass) runs away: the
// run latches the divergence with the cause "device plant" and exits non-zero.
TEST(RunClosedLoop, APlantThatRunsAwayLatchesTheDivergence) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  std::string text = replace(default_text(), "inertia = [4.0e-3, 4.0e-3, 0.15, 0.0, 0.0]",
                             "inertia = [4.0e-3, 4.0e-3, 1.0e-9, 0.0, 0.0]");
  text = replace(text, "damping = [0.02, 0.02, 1.5, 0.0, 0.0]", "damping = [0.02, 0.02, 0.0, 0.0, 0.0]");
  text = replace(text, "[device.feedback]",
                 "[device.hand]\nmass = 0.0\ndamping = 0.0\n\n[device.feedback]");
  const Scene scene = numen::sim::load_scene(dir.write("runaway.toml", text));
  const RunSummary s = run_for(scene, 2.0);
  EXPECT_TRUE(s.divergence.latched);
  EXPECT_EQ(s.divergence.cause, "device plant");
  EXPECT_EQ(s.divergence.subject, "device axis 2");
  EXPECT_EQ(numen::sim::run_verdict(s).status, ExitStatus::kDiverged);
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
