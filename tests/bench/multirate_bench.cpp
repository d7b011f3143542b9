// The multirate god-object's device step against its intermediate model (core/multirate.hpp,
// docs/multirate.md) beside the single-rate step, on the construction scene (a rigid tool among
// twelve free blocks; replayed up to its first tool switch, so that both hold the same body),
// the default scene (an articulated instrument: its whole articulation is the god-object), the
// deformable and endobag scenes (a net on the god-object: node planes), the mouse and phantom
// scenes, and the admittance scene (its measured wrench drives the god-object). Each iteration
// is one 1 kHz period: the single-rate SceneRunner (AdmittanceRunner) steps the scene (the
// reference, and the source of the hand's target or measured wrench), the MultirateGodObject
// gets the same target and steps — a device step, and on every N-th period the scene step
// first (N = the benchmark's argument). The time reported is the multirate period's (manual
// timing); the counters split it:
//   device_p50_us, device_p99_us   periods without a scene step: what the device loop costs
//   scene_p50_us                   periods with one: scene step + device step (on its own thread later)
//   single_p50_us, single_p99_us   the single-rate core::step of the same periods
//   device_vs_single               device_p50 / single_p50
//   tool_pen_mm, single_tool_pen_mm  deepest tool contact, multirate (device) and single-rate
//                                    (admittance: the god-object is driven open-loop by the
//                                    single-rate run's measured wrench, with no device of its
//                                    own to close the loop, so its tool_pen_mm is a cost
//                                    benchmark's by-product, not a quality figure: see
//                                    RunMultirate.AdmittanceSceneAtRateRatiosOneFiveAndTen)
//
//   ./build/tests/numen_bench --benchmark_filter=multirate

#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/core/multirate.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/monotonic_clock.hpp"
#include "numen/sim/run/admittance_run.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

/// The single-rate step's wall time of the runner's last period (ns).
std::int64_t step_ns(const numen::sim::SceneRunner& r) { return r.last_report().step_ns; }
std::int64_t step_ns(const numen::sim::AdmittanceRunner& r) { return r.loop().last_report().step_ns; }

/// `speed` (m/s): the margin is the travel at that speed over a scene period. `Runner`: the
/// scene's single-rate run harness.
template <class Runner>
void multirate_time(benchmark::State& state, const char* name, double speed) {
  const int ratio = static_cast<int>(state.range(0));
  numen::sim::Scene scene;
  try {
    scene = numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  const int body = scene.model.initial_held_body;
  // The margin covers `speed` of tool travel over a scene period (docs/multirate.md).
  const numen::core::MultirateSettings settings{ratio, speed * scene.model.dt * ratio, {}};
  const auto periods = static_cast<std::int64_t>(scene.duration_s / scene.model.dt);
  std::unique_ptr<Runner> runner;
  std::unique_ptr<numen::core::MultirateGodObject> mr;
  const auto restart = [&] {
    runner = std::make_unique<Runner>(scene);
    mr = std::make_unique<numen::core::MultirateGodObject>(scene.model, body, settings);
  };
  restart();
  numen::platform::LatencyHistogram device, scene_periods, single;
  double tool_pen = 0.0, single_tool_pen = 0.0;
  std::int64_t k = 0;
  for (auto _ : state) {
    // Replay from the start at the scene's end and at its first tool switch (the multirate
    // god-object holds one body: docs/multirate.md).
    if (runner->periods() >= periods || runner->data().held_body != body) {
      state.PauseTiming();
      single_tool_pen = std::max(single_tool_pen, runner->summary().tool_penetration_max_mm);
      restart();
      k = 0;
      state.ResumeTiming();
    }
    runner->period();
    single.record(step_ns(*runner));
    numen::core::Data& d = mr->device_data();
    if (k == 0) {  // the runner starts the god-object at the hand (sim/run/run.hpp): so does this
      const std::span<const int> god = mr->god_object();
      for (std::size_t i = 0; i < god.size(); ++i)
        d.bodies[i] = runner->data().bodies[static_cast<std::size_t>(god[i])];
      for (std::size_t b = 0; b < runner->data().bodies.size(); ++b)
        mr->scene_data().bodies[b] = runner->data().bodies[b];
    }
    mr->take_targets(runner->data());
    const std::int64_t t0 = numen::platform::monotonic_now_ns();
    mr->step();
    const std::int64_t t = numen::platform::monotonic_now_ns() - t0;
    state.SetIterationTime(static_cast<double>(t) * 1e-9);
    (k % ratio == 0 ? scene_periods : device).record(t);
    tool_pen = std::max(tool_pen, d.max_penetration);
    ++k;
  }
  const double single_p50 = static_cast<double>(single.quantile(0.5)) * 1e-3;
  state.counters["device_p50_us"] = static_cast<double>(device.quantile(0.5)) * 1e-3;
  state.counters["device_p99_us"] = static_cast<double>(device.quantile(0.99)) * 1e-3;
  state.counters["scene_p50_us"] = static_cast<double>(scene_periods.quantile(0.5)) * 1e-3;
  state.counters["single_p50_us"] = single_p50;
  state.counters["single_p99_us"] = static_cast<double>(single.quantile(0.99)) * 1e-3;
  state.counters["device_vs_single"] =
      single_p50 > 0.0 ? static_cast<double>(device.quantile(0.5)) * 1e-3 / single_p50 : 0.0;
  state.counters["tool_pen_mm"] = tool_pen * 1e3;
  state.counters["single_tool_pen_mm"] =
      std::max(single_tool_pen, runner->summary().tool_penetration_max_mm);
}

/// The impedance scenes' and the admittance scene's benchmarks.
void multirate_impedance(benchmark::State& state, const char* name, double speed) {
  multirate_time<numen::sim::SceneRunner>(state, name, speed);
}
void multirate_admittance(benchmark::State& state, const char* name, double speed) {
  multirate_time<numen::sim::AdmittanceRunner>(state, name, speed);
}

}  // namespace

BENCHMARK_CAPTURE(multirate_impedance, Construction, "construction.toml", 2.0)
    ->Arg(1)->Arg(10)->Arg(100)->UseManualTime()->Iterations(9000);
// The lattice scene: an articulated haptic instrument (4 bodies, 4 joints) on a recorded trial;
// its first 9 s; the margin covers 1 m/s (10 mm at 100 Hz, as docs/figures/plot_multirate.py).
BENCHMARK_CAPTURE(multirate_impedance, Lattice, "lattice.toml", 1.0)
    ->Arg(1)->Arg(10)->UseManualTime()->Iterations(9000);
// The deformable scene (a 306-node probe on its hidden core) and the endobag (a 162-node bag on
// the articulated instrument), their first 9 s; the margin covers 0.2 m/s (2 mm at 100 Hz, the
// hand travels less: docs/multirate.md, "Deformable god-objects").
BENCHMARK_CAPTURE(multirate_impedance, Deformable, "deformable.toml", 0.2)
    ->Arg(1)->Arg(2)->Arg(10)->UseManualTime()->Iterations(9000);
BENCHMARK_CAPTURE(multirate_impedance, Endobag, "endobag.toml", 0.2)
    ->Arg(1)->Arg(2)->Arg(10)->UseManualTime()->Iterations(9000);
// The mouse's puck and the phantom's stylus (rigid tools on short recordings: all of them).
BENCHMARK_CAPTURE(multirate_impedance, Mouse, "mouse.toml", 0.2)
    ->Arg(1)->Arg(10)->UseManualTime()->Iterations(3800);
BENCHMARK_CAPTURE(multirate_impedance, Phantom, "phantom.toml", 0.2)
    ->Arg(1)->Arg(10)->UseManualTime()->Iterations(4200);

// The admittance scene (a 5 mm probe driven by the measured force, pressed into an organ), all
// of its 4.3 s.
BENCHMARK_CAPTURE(multirate_admittance, Admittance, "admittance.toml", 0.2)
    ->Arg(1)->Arg(10)->UseManualTime()->Iterations(4300);
