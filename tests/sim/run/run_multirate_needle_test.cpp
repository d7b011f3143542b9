// Tests of the suturing scene's needle in the device loop of a multirate run (issue 69;
// docs/multirate-suturing.md, "A needle in the device loop"): its first pass at 10 kHz with the scene
// loop at 1 kHz, against the single-rate run at 10 kHz, without its thread; and with it, the
// thread in the scene loop (docs/multirate-suturing.md, "A thread in the scene loop").

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>
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

/// The shipped suturing scene (its DCF paths made absolute), without its [[thread]] unless
/// `thread`, at dt = 0.1 ms (the bus's latency 20 µs and compute phase 50 µs, so that a SYNC
/// round trip fits), and, when `multirate`, the scene loop at 1 ms with a 2 mm margin.
std::string suturing_at_ten_kilohertz(bool multirate, bool thread = false) {
  std::istringstream in(numen::test::shipped_scene_text("suturing.toml"));
  std::string out, line;
  bool skip = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '[') skip = !thread && line.rfind("[[thread]]", 0) == 0;
    if (skip) continue;
    if (line == "dt = 0.001") line = "dt = 0.0001";
    if (line == "latency = 0.0001") line = "latency = 0.00002\ncompute_phase = 0.00005";
    out += line + "\n";
  }
  if (multirate) out += "\n[multirate]\nscene_dt = 0.001\nmargin = 0.002\n";
  return out;
}

RunSummary run_first_pass(const numen::test::TempDir& dir, bool multirate) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(dir.write(multirate ? "mr.toml" : "sr.toml", suturing_at_ten_kilohertz(multirate)));
  numen::sim::RunOptions options;
  options.duration_s = 3.2;  // the first pass: in at 1.39 s, out at 2.72 s
  return numen::sim::run_scene(scene, options);
}

}  // namespace

// The right driver holds the needle in its jaws (the grasp in the device step, the needle carried
// there) and drives it through the pad, looking at it (its servo, on the run's view): the device
// loop finds the puncture on its tip's planes at the threshold, the scene loop makes it, and the
// needle goes round on its ties and comes out, as in the single-rate run: the contacts asked
// within 10 % of the threshold, the entry and the exit within 1 mm of their marks and within
// 0.3 mm of single-rate's (at rest, on the pad), each hand's largest force within 5 %. No tunnel;
// a clean run.
TEST(RunMultirateNeedle, TheSuturingScenesFirstPassAsTheSingleRateRun) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER("two runs of 32 000 periods compare figures, which is not what a "
                             "sanitizer checks (MultirateNeedle.* runs the same core path)");
  numen::test::TempDir dir;
  const RunSummary single = run_first_pass(dir, false);
  const RunSummary multi = run_first_pass(dir, true);
  for (const std::string& line : multi.needle_lines) std::printf("[   info   ] multirate: %s\n", line.c_str());
  for (const std::string& line : single.needle_lines) std::printf("[   info   ] single-rate: %s\n", line.c_str());
  const numen::sim::RunVerdict v = numen::sim::run_verdict(multi);
  EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
  EXPECT_EQ(multi.multirate.scene_steps, 3200);
  ASSERT_EQ(single.needle_runs.size(), 1u);
  ASSERT_EQ(multi.needle_runs.size(), 1u);
  const numen::sim::NeedleRunFigures& s = single.needle_runs[0];
  const numen::sim::NeedleRunFigures& m = multi.needle_runs[0];
  ASSERT_GE(s.num_passes, 1u);
  ASSERT_GE(m.num_passes, 1u);
  EXPECT_EQ(multi.needle_passes, 1) << "through";
  EXPECT_EQ(m.tunnels, 0);
  EXPECT_GE(m.puncture_contact_force_n, m.puncture_force_n);
  EXPECT_LT(m.puncture_contact_force_n, 1.1 * m.puncture_force_n) << "N: within 10 % of the threshold";
  const auto distance_mm = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return 1e3 * std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  };
  ASSERT_GE(m.entry_marks.size(), 1u);
  ASSERT_GE(m.exit_marks.size(), 1u);
  EXPECT_LT(distance_mm(m.passes[0].entry, m.entry_marks[0]), 1.0) << "the issue's 1 mm";
  EXPECT_LT(distance_mm(m.passes[0].exit, m.exit_marks[0]), 1.0) << "the issue's 1 mm";
  EXPECT_LT(distance_mm(m.passes[0].entry, s.passes[0].entry), 0.3);
  EXPECT_LT(distance_mm(m.passes[0].exit, s.passes[0].exit), 0.3);
  EXPECT_NEAR(m.passes[0].entry_s, s.passes[0].entry_s, 0.005);
  EXPECT_NEAR(m.passes[0].exit_s, s.passes[0].exit_s, 0.02);
  ASSERT_EQ(multi.devices.size(), 2u);
  ASSERT_EQ(single.devices.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    std::printf("[   info   ] device %zu: feedback force max %.4f N multirate, %.4f N single-rate\n", i,
                multi.devices[i].feedback_force_max_n, single.devices[i].feedback_force_max_n);
    EXPECT_NEAR(multi.devices[i].feedback_force_max_n, single.devices[i].feedback_force_max_n,
                0.05 * single.devices[i].feedback_force_max_n)
        << "device " << i;
  }
}

// The shipped scene with its thread, multirate: the thread lives in the scene loop, tied to the
// needle the device loop carries in the jaws, and follows it through the first pass — once the
// left driver has drawn the needle's tail out, the thread takes the entry and the exit over as
// eyelets (as single-rate: docs/suturing.md). The run's view carries the scene loop's thread: the
// summary reads its tension; no break, a clean run, the pass within 1 mm of its marks. (The whole
// scene and its perturbed runs: docs/multirate-suturing.md, "A thread in the scene loop".)
TEST(RunMultirateNeedle, TheThreadFollowsTheNeedleThroughTheFirstPassInTheSceneLoop) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER("a run of 70 000 periods checks task figures, which is not what a sanitizer "
                             "checks (MultirateNeedle.* runs the same core path)");
  numen::test::TempDir dir;
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("mr_thread.toml", suturing_at_ten_kilohertz(true, true)));
  ASSERT_EQ(scene.model.threads.size(), 1u);
  numen::sim::RunOptions options;
  options.duration_s = 7.0;  // the first pass: the tail out of the entry at 4.96 s, of the exit by 7 s
  const RunSummary multi = numen::sim::run_scene(scene, options);
  std::printf("[   info   ] thread: tension max %.4f N at %.3f s, puncture points taken over %lld, "
              "unconverged steps %lld, breaks %lld\n",
              multi.thread_tension_max_n, multi.thread_tension_max_s, static_cast<long long>(multi.thread_eyelets_taken),
              static_cast<long long>(multi.thread_newton_not_converged_steps), static_cast<long long>(multi.thread_breaks));
  const numen::sim::RunVerdict v = numen::sim::run_verdict(multi);
  EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
  EXPECT_EQ(multi.needle_passes, 1) << "through";
  EXPECT_EQ(multi.thread_eyelets_taken, 2) << "the entry and the exit taken over";
  EXPECT_EQ(multi.thread_eyelets_dropped, 0);
  EXPECT_EQ(multi.thread_breaks, 0);
  EXPECT_GT(multi.thread_tension_max_n, 0.0) << "the view carries the scene loop's thread";
  EXPECT_LT(multi.thread_tension_max_n, 2.0) << "N";
  ASSERT_EQ(multi.needle_runs.size(), 1u);
  const numen::sim::NeedleRunFigures& m = multi.needle_runs[0];
  ASSERT_GE(m.num_passes, 1u);
  const auto distance_mm = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
    return 1e3 * std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  };
  EXPECT_LT(distance_mm(m.passes[0].entry, m.entry_marks[0]), 1.0) << "the issue's 1 mm";
  EXPECT_LT(distance_mm(m.passes[0].exit, m.exit_marks[0]), 1.0) << "the issue's 1 mm";
}

// Zero allocations with the needle in the device loop and the thread in the scene loop: the
// shipped scene with its thread, multirate, through its first pass (70 000 device periods, 7 000
// scene periods: the grasp, the puncture, the hand-over, the tail drawn out of the entry and the
// exit, the thread's pull handed over every sample).
TEST(RunMultirateNeedle, PeriodWithTheNeedleAndTheThreadNeverAllocates) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_SKIP_UNDER_SANITIZER("70 000 periods of the suturing scene are minutes under a sanitizer "
                             "(MultirateNeedle.TheThreadsPullReachesTheHandAsTheSingleRateStep counts the core's)");
  numen::test::TempDir dir;
  const numen::sim::Scene scene = numen::sim::load_scene(dir.write("mr_thread.toml", suturing_at_ten_kilohertz(true, true)));
  constexpr int kPeriods = 70000;
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
  EXPECT_EQ(s.needle_passes, 1) << "the pass was not exercised";
  EXPECT_EQ(s.thread_eyelets_taken, 2) << "the thread was not drawn through the pass";
  EXPECT_FALSE(s.nan_detected);
}
