// Tests of the multirate run (scene [multirate], SceneRunner with core::MultirateGodObject):
// the construction scene — a held block carried through a tower, released, another picked up
// (tool switching) —, the default scene — an articulated haptic instrument —, the deformable and
// endobag scenes — nets on the god-object — and the admittance scene — a god-object driven by a
// measured force (AdmittanceRunner) — run with the device loop at 1 kHz and the scene loop
// slower: close to the single-rate run, clean, deterministic, allocation-free; paced runs with
// the scene loop on its own thread.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "lattice_scene.hpp"
#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/sim/run/admittance_run.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/run/run_verdict.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

using numen::sim::RunSummary;
using numen::sim::Scene;
using numen::sim::SceneRunner;

/// The shipped scene sim/scenes/`name` at step `dt` (s; its own is 1 ms), with [multirate]
/// scene_dt, margin (m) when scene_dt > 0, and the text `edits` (from, to) made.
Scene shipped_scene(numen::test::TempDir& dir, const char* name, double dt, double scene_dt, double margin,
                    const std::vector<std::pair<std::string, std::string>>& edits = {}) {
  char table[128] = "";
  if (scene_dt > 0.0)
    std::snprintf(table, sizeof table, "\n[multirate]\nscene_dt = %.17g\nmargin = %.17g\n", scene_dt, margin);
  char step[64];
  std::snprintf(step, sizeof step, "dt = %.17g\n", dt);
  std::string text = numen::test::shipped_scene_text(name) + table;
  if (text.find("\"../data/") != std::string::npos)
    text = numen::test::replace(text, "\"../data/", std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/");
  text = numen::test::replace(text, "dt = 0.001\n", step);
  for (const auto& [from, to] : edits) text = numen::test::replace(text, from, to);
  return numen::sim::load_scene(dir.write(std::string("multirate_") + name, text));
}

/// The shipped construction scene with [multirate] scene_dt, margin (m).
Scene construction_multirate(numen::test::TempDir& dir, double scene_dt, double margin) {
  return shipped_scene(dir, "construction.toml", 0.001, scene_dt, margin);
}

const Scene& construction_single() {
  static const Scene s =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml");
  return s;
}

RunSummary run_whole(const Scene& scene) {
  SceneRunner runner(scene);
  const auto periods = std::llround(scene.duration_s / scene.model.dt);
  for (std::int64_t k = 0; k < periods; ++k) runner.period();
  runner.finish();
  return runner.summary();
}

void print_rate_run(const char* name, const RunSummary& s) {
  std::printf("%-22s tool %.3f mm, any body %.3f mm, tracking rms %.3f mm, fastest block %.3f m/s, "
              "scene steps %lld, planes max %lld\n",
              name, s.tool_penetration_max_mm, s.any_penetration_max_mm, s.tracking_error_free_rms_mm,
              s.free_body_speed_max_mps, static_cast<long long>(s.multirate.scene_steps),
              static_cast<long long>(s.multirate.planes_max));
}

}  // namespace

// The whole 9 s: the tower knocked over, the release, the second block picked up. At a rate ratio
// of 1 without a margin the device loop's planes are the scene's own contacts each period; what
// differs from the single-rate step is that the blocks the tool touches answer the device loop
// through their linearised carriers (explicit exchange) instead of in one implicit solve with
// the tool, and the scene step renders the tool's contacts on them with the tool imposed. At 2 and
// 10 the scene loop runs at 500 and 100 Hz: the tool still stays within a few millimetres of the
// surfaces, no block is thrown faster than in the single-rate run at the scene loop's own period
// (the blocks' dynamics run there), and every period is clean.
TEST(RunMultirate, ConstructionSceneAtRateRatiosOneTwoAndTen) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "four runs of the 9 s scene compare figures, which is not what a sanitizer checks; they take "
      "54 s under ASan+UBSan (RunMultirate.PeriodNeverAllocates runs the same path there)");
  numen::test::TempDir dir;
  const RunSummary single = run_whole(construction_single());
  const RunSummary r1 = run_whole(construction_multirate(dir, 0.001, 0.0));
  const RunSummary r2 = run_whole(construction_multirate(dir, 0.002, 0.01));
  const RunSummary r10 = run_whole(construction_multirate(dir, 0.01, 0.01));
  print_rate_run("single-rate 1 kHz", single);
  print_rate_run("multirate 1 kHz/1 kHz", r1);
  print_rate_run("multirate 1 kHz/500 Hz", r2);
  print_rate_run("multirate 1 kHz/100 Hz", r10);
  for (const RunSummary* s : {&r1, &r2, &r10}) {
    EXPECT_TRUE(s->multirate.enabled);
    EXPECT_EQ(s->nonfinite_steps, 0);
    const numen::sim::RunVerdict v = numen::sim::run_verdict(*s);
    EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
    EXPECT_EQ(s->multirate.switches, 2) << "released, then loose_1 picked up";
    EXPECT_EQ(s->multirate.planes_dropped, 0);
    EXPECT_GT(s->multirate.planes_max, 0);
    EXPECT_EQ(s->multirate.stale_models, 0);
    EXPECT_EQ(s->multirate.scene_steps, s->steps / s->multirate.ratio);
    EXPECT_LT(s->free_body_speed_max_mps, 1.1 * single.free_body_speed_max_mps) << "m/s";
    EXPECT_NEAR(s->tracking_error_free_rms_mm, single.tracking_error_free_rms_mm,
                0.05 * single.tracking_error_free_rms_mm);
  }
  EXPECT_NEAR(r1.tool_penetration_max_mm, single.tool_penetration_max_mm, 0.15 * single.tool_penetration_max_mm);
  EXPECT_LT(r2.tool_penetration_max_mm, 1.5 * single.tool_penetration_max_mm);
  EXPECT_LT(r10.tool_penetration_max_mm, 4.0) << "mm: the god-object stays near the surfaces";
}

TEST(RunMultirate, TwoRunnersAreBitIdentical) {
  numen::test::TempDir dir;
  const Scene scene = construction_multirate(dir, 0.01, 0.01);
  SceneRunner a(scene), b(scene);
  for (int k = 0; k < 3000; ++k) {  // through the tower (1.2–2.4 s)
    a.period();
    b.period();
  }
  for (std::size_t i = 0; i < a.data().bodies.size(); ++i) {
    EXPECT_EQ(std::memcmp(a.data().bodies[i].position.data(), b.data().bodies[i].position.data(),
                          3 * sizeof(double)), 0) << "body " << i;
    EXPECT_EQ(std::memcmp(a.data().bodies[i].linear_velocity.data(),
                          b.data().bodies[i].linear_velocity.data(), 3 * sizeof(double)), 0) << "body " << i;
  }
  EXPECT_GT(a.summary().contacts_max, 0);
}

// The view's counts since reset (core::Data: contact_clamped_steps, contact_overflow_steps,
// net_crossed_steps, nonfinite_steps) are the current scene-loop model's; a tool switch makes
// another model current, whose Data takes the counts on (MultirateGodObject::select()): none
// goes down over the construction scene's two switches, and the stiff contacts' count is not
// zero there, so a reset would show.
TEST(RunMultirate, CountsSinceResetCarryOverAToolSwitch) {
  numen::test::TempDir dir;
  SceneRunner runner(construction_multirate(dir, 0.01, 0.01));
  std::int64_t clamped = 0, overflow = 0, crossed = 0, nonfinite = 0;
  for (int k = 0; k < 9000; ++k) {
    runner.period();
    const numen::core::Data& d = runner.data();
    ASSERT_GE(d.contact_clamped_steps, clamped) << "period " << k;
    ASSERT_GE(d.contact_overflow_steps, overflow) << "period " << k;
    ASSERT_GE(d.net_crossed_steps, crossed) << "period " << k;
    ASSERT_GE(d.nonfinite_steps, nonfinite) << "period " << k;
    clamped = d.contact_clamped_steps;
    overflow = d.contact_overflow_steps;
    crossed = d.net_crossed_steps;
    nonfinite = d.nonfinite_steps;
  }
  runner.finish();
  EXPECT_EQ(runner.summary().multirate.switches, 2);
  EXPECT_GT(clamped, 0) << "no count to carry: the test would not see a reset";
}

namespace {

/// `periods` periods of `scene` under the allocation counter; the summary after.
RunSummary run_without_allocation(const Scene& scene, const char* name, int periods = 10'000) {
  SceneRunner runner(scene, static_cast<std::size_t>(periods));
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < periods; ++k) runner.period();
    count = guard.count();
  }
  EXPECT_EQ(count, 0) << name << ": heap allocations in " << periods << " multirate periods";
  runner.finish();
  const RunSummary s = runner.summary();
  EXPECT_GT(s.contacts_max + s.node_contacts_max, 0) << name;
  EXPECT_FALSE(s.nan_detected) << name;
  return s;
}

}  // namespace

// 10 000 periods (10 s at 1 kHz, past the end of the trajectory): the tower, the release, the
// switch to the second block, 1 000 scene steps — no heap allocation in either loop.
TEST(RunMultirate, PeriodNeverAllocates) {
  numen::test::TempDir dir;
  const RunSummary s = run_without_allocation(construction_multirate(dir, 0.01, 0.01), "construction");
  EXPECT_EQ(s.multirate.scene_steps, 1000);
  EXPECT_EQ(s.multirate.switches, 2);
}

// A paced run (--realtime) steps the scene loop on its own thread at scene_dt: 1 s of the
// construction scene at 1 kHz / 100 Hz takes about 100 scene steps there, and the device loop
// rarely waits a whole scene period for a model (a shared machine delays some).
TEST(RunMultirate, APacedRunStepsTheSceneOnItsOwnThread) {
  numen::test::TempDir dir;
  const Scene scene = construction_multirate(dir, 0.01, 0.01);
  numen::sim::RunOptions options;
  options.realtime = true;
  options.duration_s = 1.0;
  options.overrun_limit = 0;  // a shared machine: count overruns, do not latch
  const RunSummary s = numen::sim::run_scene(scene, options);
  std::printf("paced: %lld scene steps, %lld stale of %lld, %lld scene overruns, scene step median "
              "%.1f us, loop overruns %lld\n",
              static_cast<long long>(s.multirate.scene_steps), static_cast<long long>(s.multirate.stale_models),
              static_cast<long long>(s.steps), static_cast<long long>(s.multirate.scene_overruns),
              s.multirate.scene_step_us.median, static_cast<long long>(s.realtime_overruns));
  EXPECT_TRUE(s.multirate.scene_thread);
  EXPECT_GE(s.multirate.scene_steps, 80);
  // The scene thread keeps its 10 ms in wall time: a loaded machine's overruns stretch the
  // 1 000 periods past 1 s (1.25 s under ASan beside a build: 125 scene steps).
  EXPECT_LE(s.multirate.scene_steps, std::llround(s.wall_time_s / 0.01) + 10) << s.wall_time_s;
  EXPECT_EQ(s.nonfinite_steps, 0);
  EXPECT_FALSE(s.nan_detected);
  EXPECT_LT(s.multirate.stale_models, s.steps / 2);
  EXPECT_GT(s.multirate.scene_step_us.median, 0.0);
}

namespace {

/// The shipped lattice scene with [multirate] scene_dt, margin (m).
Scene default_multirate(numen::test::TempDir& dir, double scene_dt, double margin) {
  return shipped_scene(dir, "lattice.toml", 0.001, scene_dt, margin);
}

/// `scene` in replay (without its [device.plant]): runs that compare the god-object's numerics
/// give it the same hand (in closed loop the device answers each run's own forces).
Scene replayed(Scene scene) {
  scene.plant.reset();
  return scene;
}

}  // namespace

// The target (the tool where the hand is) is detected anew on a copy of the scene; in a multirate
// run with a device period under 1 ms only every round(1 ms / dt) periods, held in between
// (docs/outputs.md): the lattice scene in replay at a 10 kHz device loop and a 1 kHz scene loop,
// its first 4.2 s (the hand reaches the organs at about 3.7 s). Every block of ten periods from a
// multiple of ten holds one value; at a 1 kHz device loop every period is measured. No period
// allocates.
TEST(RunMultirate, TheTargetIsMeasuredAtMostAtOneKilohertz) {
  NUMEN_REQUIRE_ARTICULATION();  // the lattice scene's instrument
  numen::test::TempDir dir;
  const std::vector<std::pair<std::string, std::string>> bus = {
      {"latency = 0.0001", "compute_phase = 0.00005\nlatency = 0.00001"}};
  const auto target_depths = [&](double dt, double seconds) {
    const Scene scene = replayed(shipped_scene(dir, "lattice.toml", dt, 1e-3, 0.002, bus));
    const auto periods = static_cast<std::size_t>(std::llround(seconds / dt));
    SceneRunner runner(scene, periods);
    {
      // The periods that measure the target and those that hold it.
      numen::test::AllocationGuard guard;
      for (std::size_t k = 0; k < periods; ++k) runner.period();
      EXPECT_EQ(guard.count(), 0) << "heap allocations at dt = " << dt;
    }
    std::vector<double> depths;
    for (const numen::sim::TraceRecord& r : runner.trace().records())
      depths.push_back(r.target_penetration_mm);
    return depths;
  };
  const std::vector<double> fast = target_depths(1e-4, 4.2);
  ASSERT_EQ(fast.size(), 42000u);
  int held_wrong = 0, blocks_in_contact = 0, changes = 0;
  for (std::size_t k = 0; k < fast.size(); ++k) {
    if (k % 10 != 0) {
      held_wrong += fast[k] != fast[k - k % 10] ? 1 : 0;
      continue;
    }
    blocks_in_contact += fast[k] > 0.0 ? 1 : 0;
    changes += k > 0 && fast[k] != fast[k - 10] ? 1 : 0;
  }
  std::printf("10 kHz / 1 kHz: %d blocks of ten periods with the target in contact, %d changes\n",
              blocks_in_contact, changes);
  EXPECT_EQ(held_wrong, 0) << "a period between two measurements changed the target's depth";
  EXPECT_GT(blocks_in_contact, 100);
  EXPECT_GT(changes, 100) << "the target measured anew every tenth period";
  const std::vector<double> slow = target_depths(1e-3, 4.2);
  int steps = 0;
  for (std::size_t k = 1; k < slow.size(); ++k) steps += slow[k] != slow[k - 1] ? 1 : 0;
  EXPECT_GT(steps, 100) << "at 1 kHz the target is measured every period";
}

// The default scene (a haptic trocar instrument on a recorded JIGSAWS trial, 30 s): its
// god-object is the whole articulated instrument (sleeve, tube, jaws; pivot, insertion and the
// prescribed jaws) in the device loop, the tissue and organs in the scene loop. At scene rates of
// 1 kHz, 200 Hz and 100 Hz the instrument stays as far out of the organs as the single-rate one,
// tracks the hand as closely in free space, and the drives get the same largest force.
TEST(RunMultirate, LatticeSceneArticulatedGodObjectAtRateRatiosOneFiveAndTen) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "four runs of the 30 s scene compare figures, which is not what a sanitizer checks; they "
      "take 140 s under ASan+UBSan (RunMultirate.LatticeScenePeriodNeverAllocates runs the same "
      "path there)");
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const Scene single_scene = replayed(numen::sim::load_scene(numen::test::lattice_scene_path()));
  const RunSummary single = run_whole(single_scene);
  std::printf("%-22s tool %.3f mm, tracking rms %.4f mm, force max %.3f N, joint drift %.4f mm\n",
              "single-rate 1 kHz", single.tool_penetration_max_mm, single.tracking_error_free_rms_mm,
              single.feedback_force_max_n, single.joint_drift_max_mm);
  for (const double scene_dt : {0.001, 0.005, 0.01}) {
    const RunSummary s = run_whole(replayed(default_multirate(dir, scene_dt, 0.005)));
    std::printf("multirate scene %.0f Hz   tool %.3f mm, tracking rms %.4f mm, force max %.3f N, joint drift %.4f mm\n",
                1.0 / scene_dt, s.tool_penetration_max_mm, s.tracking_error_free_rms_mm,
                s.feedback_force_max_n, s.joint_drift_max_mm);
    const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
    EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
    EXPECT_EQ(s.num_joints, 4);
    EXPECT_LE(s.tool_penetration_max_mm, 1.1 * single.tool_penetration_max_mm) << scene_dt;
    EXPECT_NEAR(s.tracking_error_free_rms_mm, single.tracking_error_free_rms_mm,
                0.05 * single.tracking_error_free_rms_mm + 1e-3) << scene_dt;
    EXPECT_NEAR(s.feedback_force_max_n, single.feedback_force_max_n, 0.05 * single.feedback_force_max_n) << scene_dt;
    EXPECT_LT(s.joint_drift_max_mm, 0.05) << "mm: the joints hold in the device loop";
    EXPECT_EQ(s.free_steps, single.free_steps);
  }
}

TEST(RunMultirate, LatticeScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  run_without_allocation(default_multirate(dir, 0.01, 0.005), "lattice");
}

namespace {

/// The shipped deformable scene (a soft probe, a net on a hidden rigid core, swept into a post).
Scene deformable_scene(numen::test::TempDir& dir, double dt, double scene_dt, double margin) {
  return shipped_scene(dir, "deformable.toml", dt, scene_dt, margin);
}

void print_net(const char* name, const RunSummary& s) {
  std::printf("%-22s tool %.3f mm, tie stretch %.3f mm, tracking rms %.4f mm, force max %.3f N, "
              "largest force jump %.3f N (at a new model %.3f N), planes max %lld\n",
              name, s.tool_penetration_max_mm, s.net_tie_stretch_max_mm, s.tracking_error_free_rms_mm,
              s.feedback_force_max_n, s.feedback_force_jump_max_n, s.multirate.model_force_jump_max_n,
              static_cast<long long>(s.multirate.planes_max));
}

}  // namespace

// The deformable scene (paper §4.2): the probe's hidden rigid core is the god-object in the
// device loop, its net in the scene loop; the core feels the net's contacts with the post
// through node planes (each node's tie and springs in series with its contact, from the
// deflection the node had at the sample). The device loop runs at 1 kHz, the scene loop at
// 1 kHz, 200 Hz and 100 Hz: the core tracks the hand in free space as the single-rate run at
// 1 kHz does, the drives' largest force is within 5 % of it, and the probe goes no deeper into
// the post than a single-rate run whose whole step is the scene loop's (its net steps at
// scene_dt in both); at a rate ratio of 1 it is the single-rate run within 10 %.
TEST(RunMultirate, DeformableSceneNetGodObjectAtRateRatiosOneFiveAndTen) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "six runs of the 30 s scene compare figures, which is not what a sanitizer checks "
      "(RunMultirate.DeformableScenePeriodNeverAllocates runs the same path there)");
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const RunSummary single = run_whole(deformable_scene(dir, 0.001, 0.0, 0.0));
  print_net("single-rate 1 kHz", single);
  for (const double scene_dt : {0.001, 0.005, 0.01}) {
    const RunSummary s = run_whole(deformable_scene(dir, 0.001, scene_dt, 0.005));
    char name[32];
    std::snprintf(name, sizeof name, "multirate %.0f Hz", 1.0 / scene_dt);
    print_net(name, s);
    const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
    EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
    EXPECT_GT(s.node_contacts_max, 0);
    EXPECT_NEAR(s.tracking_error_free_rms_mm, single.tracking_error_free_rms_mm,
                0.05 * single.tracking_error_free_rms_mm) << scene_dt;
    EXPECT_NEAR(s.feedback_force_max_n, single.feedback_force_max_n, 0.05 * single.feedback_force_max_n) << scene_dt;
    if (scene_dt == 0.001) {
      EXPECT_NEAR(s.tool_penetration_max_mm, single.tool_penetration_max_mm, 0.1 * single.tool_penetration_max_mm);
      EXPECT_NEAR(s.net_tie_stretch_max_mm, single.net_tie_stretch_max_mm, 0.1 * single.net_tie_stretch_max_mm);
      continue;
    }
    const RunSummary slow = run_whole(deformable_scene(dir, scene_dt, 0.0, 0.0));
    std::snprintf(name, sizeof name, "single-rate %.0f Hz", 1.0 / scene_dt);
    print_net(name, slow);
    EXPECT_LE(s.tool_penetration_max_mm, slow.tool_penetration_max_mm) << scene_dt;
  }
}

namespace {

/// The deformable scene's first pass over the post (its first 3.3 s) in replay at a 10 kHz device
/// loop (`[bus] latency = 0.00001`, `compute_phase = 0.00005`), single-rate (`scene_dt` 0) or
/// with the scene loop at `scene_dt` (s) and a 2 mm margin.
RunSummary probe_first_pass(numen::test::TempDir& dir, double scene_dt) {
  const std::vector<std::pair<std::string, std::string>> bus = {
      {"latency = 0.0001", "compute_phase = 0.00005\nlatency = 0.00001"}};
  const Scene scene =
      replayed(shipped_scene(dir, "deformable.toml", 1e-4, scene_dt, scene_dt > 0.0 ? 0.002 : 0.0, bus));
  SceneRunner runner(scene);
  for (std::int64_t k = 0; k < std::llround(3.3 / scene.model.dt); ++k) runner.period();
  runner.finish();
  return runner.summary();
}

}  // namespace

// The probe's net at the device rate (docs/multirate.md, "Deformable god-objects": the
// look-ahead): the deformable scene's first pass over the post (its first 3.3 s) at a 10 kHz
// device loop, single-rate and with the scene loop at 1 kHz and at 100 Hz. At 1 ms the net goes
// no deeper into the post than 1.6× the single-rate run at 0.1 ms (measured: 0.025 against
// 0.028 mm; over the whole excerpt 0.93×, and 10× without the look-ahead). At 10 ms the component carries a pressed node's anchor 1–3 mm
// past the post between two scene steps, and a node off the post at a step's start is pulled by
// its tie to its anchor within the step: the look-ahead keeps it as a candidate
// (detail::anchor_reaches; without that rule 1.05 mm deep at 3.24 s, 38× the single-rate run).
// What is left at 10 ms is the node contacts' time-constant floor (k clamped to m (100 / h)²,
// 3 300 N/m for a probe node): within 10× (measured: 0.146 mm, 5.2×).
TEST(RunMultirate, DeformableNetAtOneAndTenMillisecondsAgainstSingleRateAtTheDeviceRate) {
  NUMEN_SKIP_UNDER_SANITIZER("three runs compare figures, which is not what a sanitizer checks");
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const RunSummary single = probe_first_pass(dir, 0.0);
  print_net("single-rate 10 kHz", single);
  EXPECT_GT(single.node_contacts_max, 0);
  EXPECT_GT(single.tool_penetration_max_mm, 0.0);
  for (const double scene_dt : {1e-3, 1e-2}) {
    const RunSummary multi = probe_first_pass(dir, scene_dt);
    char name[40];
    std::snprintf(name, sizeof name, "multirate 10 kHz / %.0f Hz", 1.0 / scene_dt);
    print_net(name, multi);
    EXPECT_GT(multi.node_contacts_max, 0) << scene_dt;
    EXPECT_LE(multi.tool_penetration_max_mm, (scene_dt < 5e-3 ? 1.6 : 10.0) * single.tool_penetration_max_mm)
        << scene_dt;
  }
}

// The endobag scene: a soft bag (a net on a body fixed to the instrument's tube) over the tip of
// the articulated instrument, against the tissue and the organs (sphere sets). The device loop
// steps the whole instrument with the bag's mass lumped onto its mount; the bag is the scene
// loop's. At a rate ratio of 1 the bag goes as deep as single-rate within 25 %; at 200 Hz and
// 100 Hz no deeper than a single-rate run whose whole step is the slower one (10 ms), while the
// instrument tracks the hand as closely as single-rate at 1 kHz. The margin is 2 mm (the hand
// travels less than that in 10 ms; docs/multirate.md, "The margin on sphere sets").
TEST(RunMultirate, EndobagSceneNetOnAnArticulatedGodObjectAtRateRatiosOneFiveAndTen) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "five runs of the 30 s scene compare figures, which is not what a sanitizer checks "
      "(RunMultirate.TheOtherShippedScenesNeverAllocate runs the same path there)");
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const RunSummary single = run_whole(shipped_scene(dir, "endobag.toml", 0.001, 0.0, 0.0));
  const RunSummary slow = run_whole(shipped_scene(dir, "endobag.toml", 0.01, 0.0, 0.0));
  print_net("single-rate 1 kHz", single);
  print_net("single-rate 100 Hz", slow);
  for (const double scene_dt : {0.001, 0.005, 0.01}) {
    const RunSummary s = run_whole(shipped_scene(dir, "endobag.toml", 0.001, scene_dt, 0.002));
    char name[32];
    std::snprintf(name, sizeof name, "multirate %.0f Hz", 1.0 / scene_dt);
    print_net(name, s);
    const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
    EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
    EXPECT_EQ(s.multirate.planes_dropped, 0);
    EXPECT_NEAR(s.tracking_error_free_rms_mm, single.tracking_error_free_rms_mm,
                0.05 * single.tracking_error_free_rms_mm) << scene_dt;
    EXPECT_LE(s.net_penetration_max_mm, slow.net_penetration_max_mm) << scene_dt;
    if (scene_dt == 0.001) {
      EXPECT_NEAR(s.net_penetration_max_mm, single.net_penetration_max_mm, 0.25 * single.net_penetration_max_mm);
    }
  }
}

TEST(RunMultirate, DeformableScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  const RunSummary s = run_without_allocation(deformable_scene(dir, 0.001, 0.01, 0.005), "deformable");
  EXPECT_GT(s.node_contacts_max, 0);
}

// The other shipped scenes a multirate god-object runs (the admittance scene has its own
// runner: AdmittanceScene* below): the mouse's puck, the phantom's stylus, the endobag's articulated
// instrument with a soft bag on a fixed mount (a net on a body of the articulation).
TEST(RunMultirate, TheOtherShippedScenesNeverAllocate) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  numen::test::TempDir dir;
  for (const char* name : {"mouse.toml", "phantom.toml", "endobag.toml"}) {
    const RunSummary s = run_without_allocation(shipped_scene(dir, name, 0.001, 0.005, 0.005), name);
    EXPECT_EQ(s.multirate.scene_steps, 2000) << name;
    EXPECT_EQ(s.multirate.planes_dropped, 0) << name;
  }
}

// The scene thread's own CPU affinity (--scene-cpu) is reported in the summary's real-time
// setup, as the loop thread's is: applied or failed, never silent.
TEST(RunMultirate, TheSceneThreadsSetupIsReported) {
  numen::test::TempDir dir;
  numen::sim::RunOptions options;
  options.realtime = true;
  options.duration_s = 0.1;
  options.overrun_limit = 0;
  options.scene_thread.cpu_affinity = {0};
  const RunSummary s = numen::sim::run_scene(construction_multirate(dir, 0.01, 0.01), options);
  bool reported = false, slack = false;
  for (const std::string& line : s.realtime_setup) {
    reported = reported || line.rfind("scene thread cpu affinity: ", 0) == 0;
    // The paced run's minimum timer slack, on the scene thread too (the defects issue).
    slack = slack || line.rfind("scene thread timer slack: applied: 1 ns (was ", 0) == 0;
  }
  EXPECT_TRUE(reported) << (s.realtime_setup.empty() ? "no real-time setup lines" : s.realtime_setup.back());
  EXPECT_TRUE(slack) << (s.realtime_setup.empty() ? "no real-time setup lines" : s.realtime_setup.back());
}

// The scene thread's options apply to a multirate scene in a paced run, below the loop's
// priority; elsewhere they are refused, naming the option (they used to be dropped silently).
TEST(RunMultirate, SceneThreadOptionsThatWouldNotApplyAreRefused) {
  numen::test::TempDir dir;
  const Scene scene = construction_multirate(dir, 0.01, 0.01);
  auto refused = [&](const numen::sim::RunOptions& o) -> std::string {
    try {
      (void)numen::sim::run_scene(scene, o);
    } catch (const numen::sim::InputError& e) {
      return e.key();
    }
    return "(accepted)";
  };
  numen::sim::RunOptions options;
  options.duration_s = 0.05;
  options.scene_thread.cpu_affinity = {0};
  EXPECT_EQ(refused(options), "--scene-cpu");  // offline: both loops on one thread
  options.scene_thread.cpu_affinity.clear();
  options.realtime = true;
  options.scene_thread.fifo_priority = 10;
  EXPECT_EQ(refused(options), "--scene-rt-priority");  // the loop thread is not real-time
  options.rt.fifo_priority = 10;
  EXPECT_EQ(refused(options), "--scene-rt-priority");  // not below the loop's
}

// --scene-spin (SceneThreadSettings::spin_ns) busy-waits on the scene thread's CPU: a paced
// multirate run with a scene CPU of its own and a spin below scene_dt only, refused elsewhere
// with the option named and why.
TEST(RunMultirate, ASceneSpinIsRefusedWhereItWouldNotApplyOrWouldTakeASharedCpu) {
  numen::test::TempDir dir;
  const Scene scene = construction_multirate(dir, 0.01, 0.01);
  auto refusal = [&](const numen::sim::RunOptions& o) -> std::string {
    try {
      numen::sim::check_run_options(scene, o);
    } catch (const numen::sim::InputError& e) {
      return e.what();
    }
    return "";
  };
  numen::sim::RunOptions options;
  options.scene_thread.spin_ns = 2'000'000;
  EXPECT_NE(refusal(options).find("--scene-spin: an offline run steps both loops on one thread"),
            std::string::npos)
      << refusal(options);
  options.realtime = true;
  EXPECT_NE(refusal(options).find("--scene-spin: busy-waits up to 2000 us a scene period on the "
                                  "scene thread's CPU: give it a CPU of its own with --scene-cpu"),
            std::string::npos)
      << refusal(options);
  options.scene_thread.cpu_affinity = {0};
  EXPECT_EQ(refusal(options), "");
  options.scene_thread.spin_ns = 10'000'000;  // scene_dt = 10 ms
  EXPECT_NE(refusal(options).find("--scene-spin: 10000 us must be below the scene period "
                                  "scene_dt = 10000 us"),
            std::string::npos)
      << refusal(options);
  options.scene_thread.spin_ns = 2'000'000;
  options.duration_s = 0.1;
  options.overrun_limit = 0;
  const RunSummary s = numen::sim::run_scene(scene, options);  // applied: the run goes through
  EXPECT_TRUE(s.multirate.scene_thread);
  EXPECT_EQ(s.steps, 100);
  EXPECT_GE(s.multirate.scene_steps, 1);  // about 10; a loaded machine delays the thread
}

namespace {

/// `periods` periods (default: the scene's duration) of an admittance scene through an
/// AdmittanceRunner.
RunSummary run_admittance(const Scene& scene, std::int64_t periods = -1) {
  numen::sim::AdmittanceRunner runner(scene);
  if (periods < 0) periods = std::llround(scene.duration_s / scene.model.dt);
  for (std::int64_t k = 0; k < periods; ++k) runner.period();
  runner.finish();
  return runner.summary();
}

}  // namespace

// The admittance scene (a force sensor drives the god-object, the device is commanded its pose;
// the hand goes 25 mm into an organ and holds): with the device loop at 1 kHz and the scene loop
// at 1 kHz, 200 Hz and 100 Hz the probe stops on the organ as in the single-rate run — the same
// penetration (the penalty contact balances the same measured force), the device as close to
// the god-object, the same largest measured force — and the scene loop steps every N-th period.
TEST(RunMultirate, AdmittanceSceneAtRateRatiosOneFiveAndTen) {
  numen::test::TempDir dir;
  // As shipped, the hand presses along the organ's normal (the tangent plane is then exact), and
  // a variant where it crosses the organ obliquely, 60 mm sideways, so that the probe slides over
  // the surface on planes up to N periods old.
  for (const bool oblique : {false, true}) {
    auto scene = [&](double scene_dt, double margin) {
      if (!oblique) return shipped_scene(dir, "admittance.toml", 0.001, scene_dt, margin);
      return shipped_scene(dir, "admittance.toml", 0.001, scene_dt, margin,
                           {{"start = { position = [0.0, 0.0, 0.075] }",
                             "start = { position = [0.03, 0.0, 0.075] }"},
                            {"to = [0.0, 0.0, 0.02]", "to = [-0.03, 0.0, 0.02]"}});
    };
    const RunSummary single = run_admittance(scene(0.0, 0.0));
    ASSERT_FALSE(single.multirate.enabled);
    std::printf("%s\n%-22s tool %.6f mm, hand %.2f mm, device error rms %.6f mm, force max %.6f N\n",
                oblique ? "oblique" : "as shipped", "single-rate", single.tool_penetration_max_mm,
                single.target_penetration_max_mm, single.admittance.device_error_rms_mm,
                single.admittance.measured_force_max_n);
    struct Case {
      double scene_dt, margin;
    };
    for (const Case c : {Case{0.001, 0.0}, Case{0.005, 0.005}, Case{0.01, 0.005}}) {
      const RunSummary s = run_admittance(scene(c.scene_dt, c.margin));
      const int n = static_cast<int>(std::lround(c.scene_dt / 0.001));
      std::printf("%-22s tool %.6f mm, hand %.2f mm, device error rms %.6f mm, force max %.6f N, "
                  "scene steps %lld, planes max %lld\n",
                  (std::string("multirate N = ") + std::to_string(n)).c_str(), s.tool_penetration_max_mm,
                  s.target_penetration_max_mm, s.admittance.device_error_rms_mm,
                  s.admittance.measured_force_max_n, static_cast<long long>(s.multirate.scene_steps),
                  static_cast<long long>(s.multirate.planes_max));
      EXPECT_TRUE(s.multirate.enabled);
      EXPECT_EQ(s.steps, single.steps);
      EXPECT_EQ(s.multirate.scene_steps, (single.steps + n - 1) / n) << n;
      EXPECT_GT(s.multirate.planes_max, 0) << n;
      EXPECT_NEAR(s.tool_penetration_max_mm, single.tool_penetration_max_mm,
                  0.05 * single.tool_penetration_max_mm) << n;
      EXPECT_NEAR(s.admittance.device_error_rms_mm, single.admittance.device_error_rms_mm,
                  0.05 * single.admittance.device_error_rms_mm) << n;
      EXPECT_NEAR(s.admittance.measured_force_max_n, single.admittance.measured_force_max_n,
                  0.02 * single.admittance.measured_force_max_n) << n;
      // The hand went into the organ (25 mm pressing, 10 mm crossing).
      EXPECT_GT(s.target_penetration_max_mm, oblique ? 9.0 : 24.0) << n;
      EXPECT_EQ(s.admittance.sensor_rejected_periods, 0) << n;
      EXPECT_EQ(s.admittance.hold_periods, 0) << n;
      EXPECT_EQ(s.nonfinite_steps, 0) << n;
      EXPECT_FALSE(s.nan_detected) << n;
      // It sends poses, not forces: no feedback-force jumps in its JSON (nor in its text).
      const nlohmann::json m = nlohmann::json::parse(numen::sim::format_summary_json(s)).at("multirate");
      EXPECT_TRUE(m.contains("scene_steps")) << n;
      EXPECT_FALSE(m.contains("model_force_jump_max_n")) << n;
      EXPECT_FALSE(m.contains("other_force_jump_max_n")) << n;
    }
  }
}

// 10 000 periods of the multirate admittance scene (past the end of its trajectory), 2 000 scene
// steps: no heap allocation in either loop; two runs are bit-identical.
TEST(RunMultirate, AdmittanceScenePeriodNeverAllocatesAndRepeats) {
  numen::test::TempDir dir;
  const Scene scene = shipped_scene(dir, "admittance.toml", 0.001, 0.005, 0.005);
  numen::sim::AdmittanceRunner a(scene), b(scene);
  a.period();
  std::int64_t count = -1;
  {
    numen::test::AllocationGuard guard;
    for (int k = 1; k < 10'000; ++k) a.period();
    count = guard.count();
  }
  EXPECT_EQ(count, 0) << "heap allocations in 10 000 multirate admittance periods";
  for (int k = 0; k < 10'000; ++k) b.period();
  a.finish();
  b.finish();
  EXPECT_EQ(a.summary().multirate.scene_steps, 2000);
  EXPECT_GT(a.summary().contacts_max, 0);
  for (std::size_t i = 0; i < a.data().bodies.size(); ++i) {
    EXPECT_EQ(std::memcmp(a.data().bodies[i].position.data(), b.data().bodies[i].position.data(),
                          3 * sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(a.data().bodies[i].linear_velocity.data(),
                          b.data().bodies[i].linear_velocity.data(), 3 * sizeof(double)), 0);
  }
  EXPECT_EQ(a.summary().admittance.measured_force_max_n, b.summary().admittance.measured_force_max_n);
}

// A paced admittance run (--realtime) steps the scene loop on its own thread, with its CPU
// affinity reported like the impedance runs'; the loop thread's own setup (--cpu) is applied and
// reported too (an admittance run used to ignore it).
TEST(RunMultirate, APacedAdmittanceRunStepsTheSceneOnItsOwnThread) {
  numen::test::TempDir dir;
  numen::sim::RunOptions options;
  options.realtime = true;
  options.duration_s = 0.5;
  options.overrun_limit = 0;  // a shared machine: overruns counted, not latched
  options.scene_thread.cpu_affinity = {0};
  options.rt.cpu_affinity = {4095};  // no such CPU here: reported as failed, the run goes on
  const Scene scene = shipped_scene(dir, "admittance.toml", 0.001, 0.005, 0.005);
  RunSummary s;
  std::string error;
  std::thread loop([&] {  // not this thread's real-time setup
    try {
      s = numen::sim::run_scene(scene, options);
    } catch (const std::exception& e) {
      error = e.what();
    }
  });
  loop.join();
  ASSERT_TRUE(error.empty()) << error;
  std::printf("paced admittance: %lld scene steps, %lld stale of %lld, loop overruns %lld\n",
              static_cast<long long>(s.multirate.scene_steps), static_cast<long long>(s.multirate.stale_models),
              static_cast<long long>(s.steps), static_cast<long long>(s.realtime_overruns));
  EXPECT_TRUE(s.admittance.enabled);
  EXPECT_TRUE(s.multirate.scene_thread);
  EXPECT_GE(s.multirate.scene_steps, 80);
  EXPECT_LE(s.multirate.scene_steps, std::llround(s.wall_time_s / 0.005) + 10)
      << s.wall_time_s;  // 5 ms in wall time (above)
  EXPECT_LT(s.multirate.stale_models, s.steps / 2);
  EXPECT_FALSE(s.nan_detected);
  bool scene_reported = false, loop_reported = false;
  for (const std::string& line : s.realtime_setup) {
    scene_reported = scene_reported || line.rfind("scene thread cpu affinity: ", 0) == 0;
    loop_reported = loop_reported || line.rfind("cpu affinity: ", 0) == 0;
  }
  EXPECT_TRUE(scene_reported);
  EXPECT_TRUE(loop_reported);
  // Paced: its wake-ups are measured and printed with the overruns (never latched here).
  EXPECT_GT(s.wakeup_latency_us.max, 0.0);
  const std::string text = numen::sim::format_summary(s);
  EXPECT_NE(text.find("realtime: wake-up latency us median"), std::string::npos) << text;
  EXPECT_NE(text.find("overrun policy: count only"), std::string::npos) << text;
}

namespace {

/// The shipped bimanual scene (both JIGSAWS manipulators, each an articulated trocar instrument
/// on its own device, against the default scene's organ) without its graspers (grasping runs in
/// the single-rate step: docs/grasping.md, "Not yet"), both devices in replay (the same hands in
/// every run), each over 1.5 s of the recording, their trocars where the whole recording places
/// them; with [multirate] scene_dt, margin (m) when scene_dt > 0.
Scene bimanual_window(numen::test::TempDir& dir, double scene_dt, double margin) {
  // Each hand 1.5 s from a time its tip is off the organ (where the whole run has dented it, the
  // recorded tip lies inside the organ's rest shape): "left" from 7.6 s (it touches at 8.3 s),
  // "right" from 3.5 s (at 3.75 s).
  const char* left_window = "start_time = 7.6\nend_time = 9.1\n";
  const char* right_window = "start_time = 3.5\nend_time = 5.0\n";
  const std::string left = "manipulator = \"slave_left\"\n", right = "manipulator = \"slave_right\"\n";
  std::string text = numen::test::shipped_scene_text("bimanual.toml");
  // Its files (the recording, the organ's mesh, the drives' DCFs) where the shipped scene is.
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"\"../data/", "/sim/data/"},
                                 std::pair<std::string, std::string>{"dcf = \"devices/", "/sim/scenes/devices/"}}) {
    const std::string prefix = from.substr(0, from.find('"') + 1) + NUMEN_SOURCE_DIR + to;
    for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + prefix.size()))
      text.replace(at, from.size(), prefix);
  }
  // Each trocar where the whole recording puts it (placed from a window's approach it moves).
  const Scene whole = numen::sim::load_scene(dir.write("bimanual_whole.toml", text));
  for (const numen::hal::DeviceConfig* device : {&whole.device, &whole.extra_devices.at(0).device}) {
    const numen::core::Vec3& p = device->trocar.point;
    const numen::core::Quat& q = device->trocar.orientation;
    char trocar[256];
    std::snprintf(trocar, sizeof trocar, "point = [%.17g, %.17g, %.17g]\norientation = [%.17g, %.17g, %.17g, %.17g]\n",
                  p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z());
    text = numen::test::replace(
        text, "placement = \"approach\"   # behind the recorded workspace along its mean approach axis\nstandoff = 0.12\n",
        trocar);
  }
  text = numen::test::replace(text, left, left + left_window);
  text = numen::test::replace(text, right, right + right_window);
  text = numen::test::replace(text, "[[grasp]]\nname = \"left_grasper\"\njaws = [\"jaw_1_l\", \"jaw_2_l\"]\n", "");
  text = numen::test::replace(text, "[[grasp]]\nname = \"right_grasper\"\njaws = [\"jaw_1_r\", \"jaw_2_r\"]\n", "");
  if (scene_dt > 0.0) {
    char table[128];
    std::snprintf(table, sizeof table, "\n[multirate]\nscene_dt = %.17g\nmargin = %.17g\n", scene_dt, margin);
    text += table;
  }
  Scene s = numen::sim::load_scene(dir.write("multirate_bimanual.toml", text));
  s.plant.reset();
  for (numen::sim::SceneDevice& d : s.extra_devices) d.plant.reset();
  return s;
}

/// One device's figures in a run of several: the deepest contact of the bodies it drives (mm;
/// the run's body and node contacts, each period) and the largest feedback force sent to it (N).
struct BimanualDevice {
  double deepest_mm = 0.0;
  double force_max_n = 0.0;
};

/// Runs `scene` whole; per device (0: the scene's own, then Scene::extra_devices) its figures.
std::vector<BimanualDevice> run_bimanual(const Scene& scene, RunSummary& summary) {
  std::vector<const numen::platform::DeviceBinding*> bindings{&scene.binding};
  for (const numen::sim::SceneDevice& d : scene.extra_devices) bindings.push_back(&d.binding);
  std::vector<int> device_of(scene.model.bodies.size(), -1);
  for (std::size_t i = 0; i < bindings.size(); ++i)
    for (const numen::platform::LinkBinding& l : bindings[i]->links)
      if (l.body >= 0) device_of[static_cast<std::size_t>(l.body)] = static_cast<int>(i);
  std::vector<BimanualDevice> out(bindings.size());
  const auto touch = [&](int body, double depth) {
    if (body < 0 || device_of[static_cast<std::size_t>(body)] < 0) return;
    double& deepest = out[static_cast<std::size_t>(device_of[static_cast<std::size_t>(body)])].deepest_mm;
    deepest = std::max(deepest, depth * 1e3);
  };
  SceneRunner runner(scene);
  const auto periods = std::llround(scene.duration_s / scene.model.dt);
  for (std::int64_t k = 0; k < periods; ++k) {
    runner.period();
    const numen::core::Data& d = runner.data();
    for (int i = 0; i < d.num_contacts; ++i) {
      const numen::core::Contact& c = d.contacts[static_cast<std::size_t>(i)];
      touch(c.body_a, c.depth);
      touch(c.body_b, c.depth);
    }
    for (int i = 0; i < d.num_node_contacts; ++i) {
      const numen::core::NodeContact& c = d.node_contacts[static_cast<std::size_t>(i)];
      touch(c.body_b, c.depth);
    }
  }
  runner.finish();
  summary = runner.summary();
  for (std::size_t i = 0; i < out.size() && i < summary.devices.size(); ++i)
    out[i].force_max_n = summary.devices[i].feedback_force_max_n;
  return out;
}

}  // namespace

// Two devices in the multirate god-object (issue 54; docs/multirate.md, "Several devices"): the
// bimanual scene's two instruments, each on its own device, both in the device loop (a composite
// god-object), the organ in the scene loop; 1.5 s of each hand pressing the organ. Against the
// single-rate run, at scene rates of 1 kHz and 100 Hz: every period clean, both devices touch the
// organ and feel it, each device's largest feedback force within 35 % of single-rate's; the
// deepest contact of each within 3x single-rate's at 1 kHz and under 2 mm at 100 Hz: the organ
// in the scene loop goes deeper than single-rate, with one device as with two (docs/organs.md,
// "Organs in multirate").
TEST(RunMultirate, BimanualSceneBothDevicesInTheDeviceLoopAgainstSingleRate) {
  NUMEN_SKIP_UNDER_SANITIZER("three runs compare figures, which is not what a sanitizer checks "
                             "(RunMultirate.BimanualScenePeriodNeverAllocates runs the same path)");
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  RunSummary single_summary;
  const std::vector<BimanualDevice> single = run_bimanual(bimanual_window(dir, 0.0, 0.0), single_summary);
  ASSERT_EQ(single.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    std::printf("single-rate 1 kHz       device %zu: deepest %.3f mm, force max %.3f N\n", i,
                single[i].deepest_mm, single[i].force_max_n);
    ASSERT_GT(single[i].deepest_mm, 0.0) << "device " << i << " touches the organ";
  }
  for (const double scene_dt : {0.001, 0.01}) {
    RunSummary s;
    const std::vector<BimanualDevice> multi =
        run_bimanual(bimanual_window(dir, scene_dt, scene_dt > 0.0015 ? 0.005 : 0.002), s);
    const numen::sim::RunVerdict v = numen::sim::run_verdict(s);
    EXPECT_EQ(v.status, numen::sim::ExitStatus::kClean) << (v.reasons.empty() ? "" : v.reasons.front());
    EXPECT_EQ(s.multirate.planes_dropped, 0);
    ASSERT_EQ(multi.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
      std::printf("multirate scene %4.0f Hz device %zu: deepest %.3f mm, force max %.3f N\n",
                  1.0 / scene_dt, i, multi[i].deepest_mm, multi[i].force_max_n);
      EXPECT_GT(multi[i].deepest_mm, 0.0) << "device " << i << " touches the organ";
      EXPECT_NEAR(multi[i].force_max_n, single[i].force_max_n, 0.35 * single[i].force_max_n)
          << "N: device " << i << " at " << scene_dt << " s";
      if (scene_dt < 0.0015)
        EXPECT_LE(multi[i].deepest_mm, 3.0 * single[i].deepest_mm) << "device " << i;
      else
        EXPECT_LT(multi[i].deepest_mm, 2.0) << "mm: device " << i;
    }
  }
}

// Zero allocations with two devices: the bimanual scene's periods in multirate (1 500 device
// periods, 150 scene periods: the whole window, both hands on the organ), both instruments in
// the device loop, the organ in the scene loop.
TEST(RunMultirate, BimanualScenePeriodNeverAllocates) {
  NUMEN_REQUIRE_DEFORMABLE();
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const RunSummary s = run_without_allocation(bimanual_window(dir, 0.01, 0.005), "bimanual", 1500);
  EXPECT_EQ(s.multirate.scene_steps, 150);
  EXPECT_EQ(s.devices.size(), 2u);
}
