// Tests of the time-domain passivity controller in a closed-loop run (scene
// `[device.passivity]`, hal::PassivityController in ImpedanceDevice::write()): the shipped
// default scene made active — no damping in the trainer's mechanics ([device.plant] damping 0),
// a stiff undamped coupling ([device.feedback] stiffness 3000 N/m, damping 0) and the 50 Hz
// velocity filter, whose lag in the coupling's target velocity produces energy — chatters
// (a limit cycle in the summary) without the controller and does not with it, in the
// single-rate loop and in the multirate one (scene loop at 200 Hz), with an energy limit of
// 0.1 mJ (the observer alone, E_max = ∞, keeps the god-object's dissipation as margin and does
// not act enough); the summary reports what the controller did. And the transparency on the
// passive shipped scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

using numen::sim::RunSummary;
using numen::sim::Scene;
using numen::sim::SceneRunner;
using numen::test::replace;

/// The lattice scene made active (see the file comment), with `[device.passivity]` when
/// `passivity`, and `[multirate] scene_dt = 5 ms` when `multirate`.
Scene active_default_scene(numen::test::TempDir& dir, bool passivity, bool multirate) {
  std::string text = numen::test::shipped_scene_text("lattice.toml");
  text = replace(text, "\"../data/", std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/");
  text = replace(text, "damping = [0.02, 0.02, 1.5, 0.0, 0.0]", "damping = [0.0, 0.0, 0.0, 0.0, 0.0]");
  text = replace(text, "stiffness = 300.0            # N/m\ndamping = 1.0                # N·s/m",
                 "stiffness = 3000.0\ndamping = 0.0");
  text = replace(text, "[device]\n", "[device]\nvelocity_estimator = \"filter\"\n");
  if (passivity) text += "\n[device.passivity]\nenergy_limit = 1e-4\n";
  if (multirate) text += "\n[multirate]\nscene_dt = 0.005\nmargin = 0.005\n";
  const std::string name = std::string("active_") + (passivity ? "pc_" : "") +
                           (multirate ? "multirate_" : "") + "lattice.toml";
  return numen::sim::load_scene(dir.write(name, text));
}

RunSummary run_for(const Scene& scene, double seconds) {
  SceneRunner runner(scene);
  const auto periods = std::llround(seconds / scene.model.dt);
  for (std::int64_t k = 0; k < periods; ++k) runner.period();
  runner.finish();
  return runner.summary();
}

void print_run(const char* name, const RunSummary& s) {
  std::printf("%-32s limit cycle %d (%.3f mm at %.1f Hz, at %.2f s), port energy min %.4f J, "
              "controller acted %lld periods, dissipated %.4f J\n",
              name, s.limit_cycle_detected ? 1 : 0, s.limit_cycle_amplitude_mm, s.limit_cycle_hz,
              s.limit_cycle_time_s, s.device_port_energy_min_j,
              static_cast<long long>(s.passivity_acting_periods), s.passivity_dissipated_j);
}

}  // namespace

TEST(RunPassivity, ControllerRemovesTheLimitCycleOfAnActiveLatticeSceneSingleRateAndMultirate) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "four closed-loop runs of the 30 s trial compare figures, which is not what a sanitizer "
      "checks");
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  for (const bool multirate : {false, true}) {
    SCOPED_TRACE(multirate ? "multirate" : "single-rate");
    const Scene plain = active_default_scene(dir, false, multirate);
    const Scene controlled = active_default_scene(dir, true, multirate);
    const RunSummary without = run_for(plain, plain.duration_s);
    const RunSummary with = run_for(controlled, controlled.duration_s);
    print_run(multirate ? "multirate, no controller" : "single-rate, no controller", without);
    print_run(multirate ? "multirate, controller" : "single-rate, controller", with);
    EXPECT_EQ(without.multirate.enabled, multirate);
    EXPECT_TRUE(without.closed_loop);
    EXPECT_TRUE(without.limit_cycle_detected);
    EXPECT_LT(without.device_port_energy_min_j, -0.05);  // the device gave the hand energy
    EXPECT_FALSE(without.passivity_controller);
    EXPECT_EQ(without.passivity_acting_periods, 0);
    EXPECT_FALSE(with.limit_cycle_detected);
    EXPECT_GE(with.device_port_energy_min_j, -1e-3);  // passive at the hand's port
    EXPECT_TRUE(with.passivity_controller);
    EXPECT_GT(with.passivity_acting_periods, 0);
    EXPECT_GT(with.passivity_dissipated_j, 0.0);
  }
}

// Transparency: the shipped default scene (passive: the trainer's own damping, the shipped
// coupling) in replay — the device follows the recorded hand whatever it is sent, so the run
// with the controller and the one without see the same motion and render the same
// environment — sent torques compared period by period on the driven axes (pivot_x, pivot_y in
// N·m, depth in N), without an energy limit and with 0.1 mJ: what the controller changes of the
// unconstrained render. Figures in docs/passivity.md, "Passivity controller".
TEST(RunPassivity, TransparencyOnThePassiveLatticeSceneInReplay) {
  NUMEN_SKIP_UNDER_SANITIZER("three 10 s runs compare figures, which is not what a sanitizer checks");
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  std::string text = numen::test::shipped_scene_text("lattice.toml");
  text = replace(text, "\"../data/", std::string("\"") + NUMEN_SOURCE_DIR + "/sim/data/");
  Scene plain = numen::sim::load_scene(dir.write("plain.toml", text));
  plain.plant.reset();  // replay
  constexpr double kSeconds = 10.0;
  const auto periods = std::llround(kSeconds / plain.model.dt);
  for (const char* limit : {"", "energy_limit = 1e-4\n"}) {
    SCOPED_TRACE(limit);
    Scene controlled =
        numen::sim::load_scene(dir.write("pc.toml", text + "\n[device.passivity]\n" + limit));
    controlled.plant.reset();
    SceneRunner a(plain), b(controlled);
    double sq[3] = {0.0, 0.0, 0.0}, max_err[3] = {0.0, 0.0, 0.0}, max_tau[3] = {0.0, 0.0, 0.0};
    for (std::int64_t k = 0; k < periods; ++k) {
      a.period();
      b.period();
      const std::span<const double> ta = a.loop().device().output().torque;
      const std::span<const double> tb = b.loop().device().output().torque;
      for (int i = 0; i < 3; ++i) {
        const double e = tb[i] - ta[i];
        sq[i] += e * e;
        max_err[i] = std::max(max_err[i], std::abs(e));
        max_tau[i] = std::max(max_tau[i], std::abs(ta[i]));
      }
    }
    a.finish();
    b.finish();
    const RunSummary sb = b.summary();
    std::printf("%s\n", *limit ? "E_max = 0.1 mJ" : "E_max = inf");
    const char* names[3] = {"pivot_x (N·m)", "pivot_y (N·m)", "depth (N)"};
    for (int i = 0; i < 3; ++i) {
      const double rms = std::sqrt(sq[i] / static_cast<double>(periods));
      std::printf("  %-14s |τ| max %.4g, controller's change: rms %.3g, max %.3g\n", names[i],
                  max_tau[i], rms, max_err[i]);
      // Against the render's largest torque: a few per cent without a limit; the 0.1 mJ
      // limit pays for its margin in transparency (18 % rms on the depth, measured).
      EXPECT_LE(rms, (*limit ? 0.25 : 0.1) * max_tau[i]) << names[i];
    }
    std::printf("  controller acted in %lld of %lld periods, dissipated %.4g J\n",
                static_cast<long long>(sb.passivity_acting_periods),
                static_cast<long long>(periods), sb.passivity_dissipated_j);
    EXPECT_TRUE(sb.passivity_controller);
    EXPECT_GT(sb.passivity_acting_periods, 0);
  }
}

namespace run_passivity_test {

// The closed loop's periods with the passivity controller acting (the active scene, where it
// dissipates) never allocate: the plant, the hand, the observer and its damper.
TEST(RunPassivity, PeriodsWithTheControllerActingNeverAllocate) {
  NUMEN_REQUIRE_ARTICULATION();
  numen::test::TempDir dir;
  const Scene scene = active_default_scene(dir, true, false);
  SceneRunner runner(scene);
  for (int k = 0; k < 200; ++k) runner.period();  // start-up, first contacts
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 15000; ++k) runner.period();  // to 15.2 s: the contacts that chatter
  EXPECT_EQ(guard.count(), 0);
  runner.finish();
  EXPECT_GT(runner.summary().passivity_acting_periods, 0);  // it did act in those periods
}

}  // namespace run_passivity_test
