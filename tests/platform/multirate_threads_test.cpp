// Tests of platform/multirate_threads: the scene loop of a multirate god-object on its own
// thread. The device loop holds its period and never waits when the scene step is ten times too
// slow (stale models counted, no NaN, no allocation), and a scene thread at its own pace gives
// the device loop fresh models.
#include "numen/platform/multirate_threads.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include <time.h>

#include "alloc_counter.hpp"
#include "numen/core/model.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/platform/periodic_timer.hpp"

namespace {

namespace core = numen::core;
using core::Vec3;

/// A 0.1 kg tool (two spheres) coupled to a hand that presses it onto a 0.2 kg block resting
/// on a floor; one material.
core::Model press_scene(double dt) {
  core::Model m;
  m.dt = dt;
  m.gravity = Vec3(0, 0, -9.81);
  m.material_names = {"wood"};
  m.material_pairs = {core::MaterialPair{5e3, 5.0, 0.5}};
  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;
  m.obstacles = {floor};
  m.body_spheres = {core::Sphere{Vec3(0, 0, -0.01), 0.01}, core::Sphere{Vec3(0, 0, 0.01), 0.01},
                    core::Sphere{Vec3::Zero(), 0.02}};
  core::BodyModel tool;
  tool.name = "tool";
  tool.mass = 0.1;
  tool.inertia_body = Vec3(1e-5, 1e-5, 5e-6).asDiagonal();
  tool.sphere_begin = 0;
  tool.sphere_count = 2;
  tool.coupling = {200.0, core::damping_from_ratio(0.9, tool.mass, 200.0), 0.05, 0.001};
  tool.initial_pose.position = Vec3(0.0, 0.0, 0.07);
  core::BodyModel block;
  block.name = "block";
  block.mass = 0.2;
  block.inertia_body = Vec3(3e-5, 3e-5, 3e-5).asDiagonal();
  block.sphere_begin = 2;
  block.sphere_count = 1;
  block.initial_pose.position = Vec3(0.0, 0.0, 0.0199);
  m.bodies = {tool, block};
  m.initial_held_body = 0;
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The hand: down onto the block, 5 mm into it, and back up, over 1 s.
void drive(core::Data& d, double t) {
  const double z = 0.07 - 0.035 * std::sin(M_PI * std::min(t, 1.0));
  d.target.position = Vec3(0.0, 0.0, z);
  d.target_twist.linear = Vec3(0.0, 0.0, t < 1.0 ? -0.035 * M_PI * std::cos(M_PI * t) : 0.0);
}

// The test: a device loop at 1 kHz, paced, with the scene loop at 100 Hz made ten times
// too slow (each scene step takes 100 ms more). The device loop never waits for it: its longest
// period of work stays far below one slow scene step (waiting would show as ≥ 100 ms), it keeps
// stepping on the last model (stale models counted), and nothing goes non-finite.
TEST(MultirateThreads, TheDeviceLoopHoldsItsPeriodWhenTheSceneIsTenTimesTooSlow) {
  const core::Model scene = press_scene(1e-3);
  // On the heap: the god-object and the buffers hold several plane sets (about 1 MB each).
  auto god = std::make_unique<core::MultirateGodObject>(scene, 0, core::MultirateSettings{10, 0.01, {}});
  core::MultirateGodObject& g = *god;
  numen::platform::SceneThreadSettings settings;
  settings.extra_scene_time_ns = 100'000'000;
  auto buffers = std::make_unique<numen::platform::MultirateThreads>(g, 10'000'000, settings);
  numen::platform::MultirateThreads& threads = *buffers;
  const std::int64_t started_ns = numen::platform::monotonic_now_ns();
  threads.start();
  numen::platform::PeriodicTimer timer(1'000'000, numen::platform::monotonic_now_ns());
  std::int64_t longest_ns = 0, overruns = 0, allocations = -1;
  bool finite = true;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 1000; ++k) {
      overruns += timer.wait_next().overrun ? 1 : 0;
      const std::int64_t t0 = numen::platform::monotonic_now_ns();
      drive(g.device_data(), 1e-3 * k);
      threads.device_step();
      longest_ns = std::max(longest_ns, numen::platform::monotonic_now_ns() - t0);
      finite = finite && g.device_data().bodies[0].position.allFinite();
    }
    allocations = guard.count();
  }
  threads.stop();
  const std::int64_t wall_ns = numen::platform::monotonic_now_ns() - started_ns;
  const numen::platform::SceneThreadCounters c = threads.counters();
  std::printf("slow scene: %lld scene steps (10 Hz instead of 100 Hz), %lld stale device periods of "
              "1000, %lld device overruns, longest device period of work %.3f ms\n",
              static_cast<long long>(c.scene_steps), static_cast<long long>(g.counters().stale_models),
              static_cast<long long>(overruns), static_cast<double>(longest_ns) * 1e-6);
  EXPECT_EQ(allocations, 0) << "the device loop allocated";
  EXPECT_TRUE(finite);
  EXPECT_LT(longest_ns, 50'000'000) << "ns: the device loop waited for the scene";
  // Each scene step takes over 100 ms: about 10 in the 1 s of periods (more if a loaded
  // machine stretches the 1 000 periods; one more may finish while stop() waits).
  EXPECT_LE(c.scene_steps, wall_ns / 100'000'000 + 2) << "the scene thread ran at about 10 Hz";
  EXPECT_GE(c.scene_steps, 5);
  EXPECT_GT(c.scene_overruns, 0) << "its steps overran their 10 ms";
  EXPECT_GT(g.counters().stale_models, 500) << "most device periods used a model older than 10 ms";
  EXPECT_EQ(g.counters().device_steps, 1000);
}

// The same loops at their own pace (scene 100 Hz): the device loop gets a fresh model about
// every ten periods, and the tool presses the block without going through it.
TEST(MultirateThreads, ASceneThreadAtItsPaceKeepsTheModelFresh) {
  const core::Model scene = press_scene(1e-3);
  auto god = std::make_unique<core::MultirateGodObject>(scene, 0, core::MultirateSettings{10, 0.01, {}});
  core::MultirateGodObject& g = *god;
  auto buffers = std::make_unique<numen::platform::MultirateThreads>(g, 10'000'000);
  numen::platform::MultirateThreads& threads = *buffers;
  threads.start();
  numen::platform::PeriodicTimer timer(1'000'000, numen::platform::monotonic_now_ns());
  double deepest = 0.0;
  int contact_periods = 0;
  for (int k = 0; k < 1200; ++k) {
    timer.wait_next();
    drive(g.device_data(), 1e-3 * k);
    threads.device_step();
    deepest = std::max(deepest, g.device_data().max_penetration);
    contact_periods += g.device_data().num_contacts > 0 ? 1 : 0;
  }
  threads.stop();
  const numen::platform::SceneThreadCounters c = threads.counters();
  std::printf("paced: %lld scene steps, %lld reports taken, %lld stale of 1200, %lld scene overruns, "
              "%d periods in contact, deepest %.3f mm\n",
              static_cast<long long>(c.scene_steps), static_cast<long long>(c.reports_taken),
              static_cast<long long>(g.counters().stale_models), static_cast<long long>(c.scene_overruns),
              contact_periods, deepest * 1e3);
  EXPECT_GE(c.scene_steps, 100) << "about 120 at 100 Hz";
  EXPECT_GT(contact_periods, 100) << "the tool pressed the block";
  EXPECT_LT(deepest, 5e-3) << "m: the planes held the tool";
  EXPECT_LT(g.counters().stale_models, 600) << "a shared machine delays some scene steps, not most";
}

// The scene thread's settings are applied before start() returns: a CPU that does not exist is
// reported (the thread runs on) or, strict, ends the thread and start() throws naming the step.
TEST(MultirateThreads, AFailedSetupIsReportedOrStrictlyRefused) {
  const core::Model scene = press_scene(1e-3);
  auto god = std::make_unique<core::MultirateGodObject>(scene, 0, core::MultirateSettings{10, 0.01, {}});
  numen::platform::SceneThreadSettings settings;
  settings.cpu_affinity = {4095};  // no such CPU here
  {
    numen::platform::MultirateThreads threads(*god, 10'000'000, settings);
    threads.start();  // returns after the setup: the report is complete
    EXPECT_EQ(threads.realtime_report().affinity.status, numen::platform::RealtimeStepStatus::kFailed);
    EXPECT_TRUE(threads.running());
    threads.stop();
  }
  settings.strict = true;
  numen::platform::MultirateThreads threads(*god, 10'000'000, settings);
  try {
    threads.start();
    ADD_FAILURE() << "a strict scene thread started on CPU 4095";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("scene thread"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("4095"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(threads.running());
  EXPECT_EQ(threads.counters().scene_steps, 0);
}

// The defects issue: the scene thread's timer slack is set on it whatever its scheduling, read
// back on it (apply_realtime() on the thread) and reported.
TEST(MultirateThreads, TheSceneThreadsTimerSlackIsSetOnIt) {
  const core::Model scene = press_scene(1e-3);
  auto god = std::make_unique<core::MultirateGodObject>(scene, 0, core::MultirateSettings{10, 0.01, {}});
  numen::platform::SceneThreadSettings settings;
  settings.timer_slack_ns = 1;
  const std::int64_t mine = numen::platform::current_timer_slack_ns();
  numen::platform::MultirateThreads threads(*god, 10'000'000, settings);
  threads.start();
  const numen::platform::RealtimeStep& slack = threads.realtime_report().timer_slack;
  EXPECT_EQ(slack.status, numen::platform::RealtimeStepStatus::kApplied) << slack.message;
  EXPECT_EQ(slack.message.rfind("1 ns (was ", 0), 0u) << slack.message;
  EXPECT_EQ(numen::platform::current_timer_slack_ns(), mine);  // not the starting thread's
  threads.stop();
}

// The scene thread's spin (SceneThreadSettings::spin_ns, `numen run --scene-spin`): its wait
// ends in a busy-wait on its CPU. Ten 10 ms scene periods with a 5 ms spin take tens of ms of the
// process's CPU time (the scene step here is a few µs; a sleep to the deadline takes almost
// none): at least a tenth of the 50 ms on a machine shared with other work, and far more than
// the same run without the spin.
TEST(MultirateThreads, ASceneSpinEndsEachScenePeriodsWaitOnTheSceneThreadsCpu) {
  const core::Model scene = press_scene(1e-3);
  auto god = std::make_unique<core::MultirateGodObject>(scene, 0, core::MultirateSettings{10, 0.01, {}});
  auto process_cpu_ns = [] {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
  };
  auto cpu_over_ten_scene_periods = [&](std::int64_t spin_ns) {
    numen::platform::SceneThreadSettings settings;
    settings.spin_ns = spin_ns;
    numen::platform::MultirateThreads threads(*god, 10'000'000, settings);
    const std::int64_t cpu0 = process_cpu_ns();
    threads.start();
    const timespec ts{0, 100'000'000};
    nanosleep(&ts, nullptr);  // this thread sleeps: the CPU time is the scene thread's
    threads.stop();
    return process_cpu_ns() - cpu0;
  };
  const std::int64_t asleep = cpu_over_ten_scene_periods(0);
  const std::int64_t spinning = cpu_over_ten_scene_periods(5'000'000);
  std::printf("[   info   ] 100 ms of 10 ms scene periods: %.1f ms of CPU time sleeping, %.1f ms "
              "with a 5 ms spin\n",
              static_cast<double>(asleep) * 1e-6, static_cast<double>(spinning) * 1e-6);
  EXPECT_GT(spinning, 5'000'000);
  EXPECT_GT(spinning, 2 * asleep);
}

}  // namespace

