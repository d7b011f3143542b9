// Tests of sim/run/target_measurement: the run's measurement of the target (the tool where the
// encoders put it), inline in an offline run and on a thread of its own in a paced run. The
// thread gives what the inline measurement gives, the loop's side of it never allocates, and a
// paced run reports the offline run's figures with the measurement off the loop thread
// (docs/realtime.md, "Paced on a 16-core machine": the measurement was ~45 % of a 10 kHz
// device loop's work with a 200 000-triangle organ).
#include "numen/sim/run/target_measurement.hpp"

#include <gtest/gtest.h>

#include <sched.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "run_scenes.hpp"
#include "numen/core/data.hpp"
#include "numen/sim/run/run.hpp"

namespace {

/// The mesh scene's probe (its held body) with its tip's target `depth` m below the lobe's
/// surface above x = −20 mm (z = 55 mm, sim/scenes/mesh.toml: its path goes to 8 mm below it),
/// the other bodies as the scene starts them.
numen::sim::TargetInputs probe_pressed_in(const numen::sim::Scene& scene, double depth) {
  const numen::core::Data data = numen::core::make_data(scene.model);
  numen::sim::TargetInputs in = numen::sim::make_target_inputs(scene.model);
  in.bodies = data.bodies;
  in.body_targets = data.body_targets;
  in.held = data.held_body;
  in.tree = scene.model.articulation.body_tree[static_cast<std::size_t>(in.held)];
  in.target.position = numen::core::Vec3(-0.02, 0.0, 0.055 - depth);
  in.target.orientation = data.bodies[static_cast<std::size_t>(in.held)].orientation;
  return in;
}

}  // namespace

// The measuring thread gives, for the inputs handed to it, exactly the inline measurement's
// figures (the same code on its own ghost), and counts what it measured.
TEST(TargetMeasurement, TheThreadGivesWhatTheInlineMeasurementGives) {
  const numen::sim::Scene& scene = numen::test::run_scenes::mesh_scene();
  numen::sim::TargetMeasurement inline_measurement(scene.model);
  numen::sim::TargetMeasurementThread thread(scene.model);
  thread.start();
  for (const double depth : {-0.02, 0.002, 0.008, 0.015}) {
    const numen::sim::TargetInputs in = probe_pressed_in(scene, depth);
    const numen::sim::TargetContacts expected = inline_measurement.measure(in);
    const std::int64_t before = thread.measured();
    thread.inputs() = in;
    thread.submit();
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (thread.measured() == before && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ASSERT_GT(thread.measured(), before) << "depth " << depth;
    const numen::sim::TargetContacts got = thread.latest();
    EXPECT_EQ(got.target_pen, expected.target_pen) << "depth " << depth;
    EXPECT_EQ(got.hand_pen, expected.hand_pen) << "depth " << depth;
    EXPECT_EQ(got.target_contacts, expected.target_contacts) << "depth " << depth;
    if (depth > 0.0) {
      EXPECT_GT(expected.target_pen, 0.0) << "depth " << depth << ": the probe's target is in the lobe";
    } else {
      EXPECT_EQ(expected.target_pen, 0.0) << "20 mm above the lobe";
    }
  }
  thread.stop();
  EXPECT_EQ(thread.submitted(), 4);
  EXPECT_EQ(thread.measured(), 4);
}

// The loop's side — filling the inputs, submitting, reading the newest result — and the
// inline measurement after its first never allocate.
TEST(TargetMeasurement, HandingOverAndMeasuringNeverAllocate) {
  const numen::sim::Scene& scene = numen::test::run_scenes::mesh_scene();
  const numen::sim::TargetInputs in = probe_pressed_in(scene, 0.008);
  numen::sim::TargetMeasurement measurement(scene.model);
  (void)measurement.measure(in);  // first contacts sized
  numen::sim::TargetMeasurementThread thread(scene.model);
  thread.start();
  double deepest = 0.0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 200; ++k) {
      deepest = std::max(deepest, measurement.measure(in).target_pen);
      thread.inputs() = in;
      thread.submit();
      deepest = std::max(deepest, thread.latest().target_pen);
    }
    EXPECT_EQ(guard.count(), 0);
  }
  thread.stop();
  EXPECT_GT(deepest, 0.0);
  EXPECT_LE(thread.measured(), thread.submitted());
}

// A paced run measures the target on its own thread (said in the summary's real-time setup)
// and reports the offline run's figures: the mesh scene's probe driven 11.2 mm into the lobe.
// The thread measures the newest target it is given, so a late one skips a period's: the
// paced maximum is at most the offline one and within 2 % of it.
TEST(TargetMeasurement, APacedRunMeasuresTheTargetOffTheLoopThreadWithTheOfflineFigures) {
  const numen::sim::Scene& scene = numen::test::run_scenes::mesh_scene();
  numen::sim::RunOptions offline;
  offline.duration_s = 1.5;
  const numen::sim::RunSummary a = numen::sim::run_scene(scene, offline);
  numen::sim::RunOptions paced = offline;
  paced.realtime = true;
  paced.overrun_limit = 0;  // a shared machine: count overruns, do not latch
  numen::sim::RunSummary b;
  std::thread t([&] { b = numen::sim::run_scene(scene, paced); });  // not the runner's thread
  t.join();
  std::string line;
  for (const std::string& l : b.realtime_setup)
    if (l.rfind("target measurement: on its own thread, ", 0) == 0) line = l;
  ASSERT_FALSE(line.empty()) << "no target measurement line in the real-time setup";
  std::printf("[   info   ] offline target penetration %.4f mm, paced %.4f mm; %s\n",
              a.target_penetration_max_mm, b.target_penetration_max_mm, line.c_str());
  EXPECT_GT(a.target_penetration_max_mm, 10.0);
  EXPECT_LE(b.target_penetration_max_mm, a.target_penetration_max_mm + 1e-9);
  EXPECT_GE(b.target_penetration_max_mm, 0.98 * a.target_penetration_max_mm);
  for (const std::string& l : a.realtime_setup)
    EXPECT_EQ(l.find("target measurement"), std::string::npos) << "offline: measured inline";
}

// The measuring thread keeps off the CPUs it is told to avoid (the loop's and the scene
// thread's pinned CPUs) where the process has another; with none left it runs where the
// scheduler puts it, and says so (start() false).
TEST(TargetMeasurement, TheThreadKeepsOffTheLoopsCpusWhereAnotherIsLeft) {
  const numen::sim::Scene& scene = numen::test::run_scenes::mesh_scene();
  cpu_set_t mine;
  CPU_ZERO(&mine);
  ASSERT_EQ(sched_getaffinity(0, sizeof(mine), &mine), 0);
  std::vector<int> all;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &mine)) all.push_back(c);
  {
    numen::sim::TargetMeasurementThread t(scene.model);
    EXPECT_FALSE(t.start());  // nothing to avoid
  }
  {
    numen::sim::TargetMeasurementThread t(scene.model);
    EXPECT_FALSE(t.start(all));  // no CPU left
  }
  if (all.size() < 2) GTEST_SKIP() << "one CPU: nothing to keep off";
  numen::sim::TargetMeasurementThread t(scene.model);
  EXPECT_TRUE(t.start({all.front()}));
  t.inputs() = probe_pressed_in(scene, 0.008);  // it still measures
  t.submit();
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (t.measured() == 0 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_EQ(t.measured(), 1);
  EXPECT_GT(t.latest().target_pen, 0.0);
}
