// Tests of grasping in the device loop of a multirate run (issue 69; docs/multirate-suturing.md,
// "Grasping in the device loop"): the shipped peg transfer with the scene loop at 100 Hz, its
// graspers and the six objects in the device loop (core::MultirateSettings::carried), against
// the single-rate run; and its periods without a heap allocation.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

using numen::sim::RunSummary;
using numen::sim::Scene;

/// The shipped peg transfer (its DCF paths made absolute), with the scene loop every
/// `scene_dt` s and a margin of `margin` m when scene_dt > 0 (single-rate otherwise).
Scene peg_transfer(const numen::test::TempDir& dir, double scene_dt, double margin) {
  std::string text = numen::test::shipped_scene_text("peg_transfer.toml");
  if (scene_dt > 0.0) {
    char table[128];
    std::snprintf(table, sizeof table, "\n[multirate]\nscene_dt = %.17g\nmargin = %.17g\n",
                  scene_dt, margin);
    text += table;
  }
  return numen::sim::load_scene(dir.write(scene_dt > 0.0 ? "peg_multirate.toml" : "peg.toml", text));
}

}  // namespace

// The whole peg transfer with its two graspers in the device loop and the scene loop at 100 Hz
// (ten device periods a scene period): the jaws grasp, hand over and release in the device step,
// the objects ride in the device loop (planes of the board and the pegs from the scene samples).
// All six objects go over, as single-rate: each grasp and release at the same time as there, and
// each device's largest feedback force within 5 % of single-rate's (every dynamic body is in the
// device loop and the obstacles are still; the planes of the pegs' round sides are their tangent
// planes at the samples). The scene loop does not detect the god-object's mutual contacts
// (detail::finalize_scene_loop_model()): no contact overflow with the objects' spheres grown by
// the 10 mm margin.
TEST(RunMultirateGrasp, PegTransferHandsOverAllSixObjectsInTheDeviceLoop) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER("two whole runs compare figures, which is not what a sanitizer checks "
                             "(RunMultirateGrasp.PeriodNeverAllocates runs the same path)");
  numen::test::TempDir dir;
  numen::sim::RunOptions opt;
  const RunSummary single = numen::sim::run_scene(peg_transfer(dir, 0.0, 0.0), opt);
  const Scene scene = peg_transfer(dir, 0.01, 0.01);
  ASSERT_TRUE(scene.multirate.has_value());
  EXPECT_EQ(scene.multirate->carried.size(), 6u) << "the six objects";
  const RunSummary multi = numen::sim::run_scene(scene, opt);
  for (const std::string& line : multi.task.lines) std::printf("[   info   ] %s\n", line.c_str());
  for (const std::string& line : multi.grasper_lines) std::printf("[   info   ] %s\n", line.c_str());
  const numen::sim::RunVerdict v = numen::sim::run_verdict(multi);
  EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
  EXPECT_EQ(multi.contact_overflow, 0);
  EXPECT_EQ(multi.multirate.planes_dropped, 0);
  EXPECT_EQ(multi.multirate.scene_steps, std::llround(scene.duration_s / 0.01));
  ASSERT_TRUE(multi.task.enabled);
  EXPECT_EQ(multi.task.transferred, 6);
  EXPECT_EQ(multi.task.placed, 6);
  EXPECT_EQ(multi.task.handovers, 6);
  EXPECT_EQ(multi.task.drops, 0);
  EXPECT_EQ(single.task.transferred, 6);
  // The same events at the same times (the log's text carries the time to the millisecond).
  EXPECT_EQ(multi.grasp_events, single.grasp_events);
  EXPECT_EQ(multi.grasp_events.size(), 24u);
  ASSERT_EQ(multi.devices.size(), 2u);
  ASSERT_EQ(single.devices.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    std::printf("[   info   ] device %zu: feedback force max %.4f N multirate, %.4f N single-rate\n", i,
                multi.devices[i].feedback_force_max_n, single.devices[i].feedback_force_max_n);
    EXPECT_GT(single.devices[i].feedback_force_max_n, 0.5) << "device " << i << " carries the objects";
    EXPECT_NEAR(multi.devices[i].feedback_force_max_n, single.devices[i].feedback_force_max_n,
                0.05 * single.devices[i].feedback_force_max_n)
        << "device " << i;
  }
}

// Zero allocations with grasping in the device loop: the peg transfer's first 4 s in multirate
// (4 000 device periods, 400 scene periods: the left grasper's grasp at 1.43 s, the hand-over to
// the right one at 3.13 s and the left's release at 3.67 s).
TEST(RunMultirateGrasp, PeriodNeverAllocates) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const Scene scene = peg_transfer(dir, 0.01, 0.01);
  constexpr int kPeriods = 4000;
  numen::sim::SceneRunner runner(scene, static_cast<std::size_t>(kPeriods));
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < kPeriods; ++k) runner.period();
    count = guard.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations in " << kPeriods << " multirate periods";
  runner.finish();
  const RunSummary s = runner.summary();
  EXPECT_EQ(s.multirate.scene_steps, kPeriods / 10);
  EXPECT_EQ(s.grasp_events.size(), 3u) << "the left's grasp, the right's grasp, the left's release";
  EXPECT_FALSE(s.nan_detected);
}
