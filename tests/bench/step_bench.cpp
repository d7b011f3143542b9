// Per-step cost of the shipped scenes (issue: default scene median ≤ 5 µs,
// construction game ≤ 20 µs on this 2-core machine). Each iteration runs one
// full control period of the real loop (SYNC, simulated encoders, decode,
// checks, kinematics, core::step, Jᵀ torques) through SceneRunner; the time
// reported is the wall time of core::step alone (manual timing), so the
// figure is the dynamics cost on realistic, moving inputs; the counters
// step_p50_us / step_p99_us give the per-step median and 99th percentile (the
// time column is a mean). period_time reports the whole period including the
// simulated bus and the run's measurements.
//
//   ./build/tests/numen_bench --benchmark_filter=step_time --benchmark_repetitions=5

#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "numen/platform/latency_histogram.hpp"
#include "numen/sim/run.hpp"
#include "numen/sim/scene.hpp"

namespace {

std::string scene_path(const char* name) { return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name; }

void step_time(benchmark::State& state, const char* name, const char* coupling) {
  numen::sim::SceneOverrides o;
  if (coupling) o.coupling = numen::sim::parse_coupling_mode(coupling);
  const numen::sim::Scene scene = numen::sim::load_scene(scene_path(name), o);
  const auto periods = static_cast<std::int64_t>(scene.duration_s / scene.model.dt);
  auto runner = std::make_unique<numen::sim::SceneRunner>(scene);
  std::int64_t contacts = 0;
  numen::platform::LatencyHistogram hist;  // per-step distribution (the time above is a mean)
  for (auto _ : state) {
    if (runner->periods() >= periods) {  // replay the scene from the start
      state.PauseTiming();
      runner = std::make_unique<numen::sim::SceneRunner>(scene);
      state.ResumeTiming();
    }
    runner->period();
    state.SetIterationTime(static_cast<double>(runner->last_report().step_ns) * 1e-9);
    hist.record(runner->last_report().step_ns);
    contacts += runner->data().num_contacts;
  }
  state.counters["contacts_per_step"] =
      benchmark::Counter(static_cast<double>(contacts), benchmark::Counter::kAvgIterations);
  state.counters["bodies"] = scene.model.num_bodies();
  state.counters["step_p50_us"] = static_cast<double>(hist.quantile(0.5)) * 1e-3;
  state.counters["step_p99_us"] = static_cast<double>(hist.quantile(0.99)) * 1e-3;
}

void period_time(benchmark::State& state, const char* name) {
  const numen::sim::Scene scene = numen::sim::load_scene(scene_path(name));
  const auto periods = static_cast<std::int64_t>(scene.duration_s / scene.model.dt);
  auto runner = std::make_unique<numen::sim::SceneRunner>(scene);
  for (auto _ : state) {
    if (runner->periods() >= periods) {
      state.PauseTiming();
      runner = std::make_unique<numen::sim::SceneRunner>(scene);
      state.ResumeTiming();
    }
    runner->period();
  }
}

}  // namespace

BENCHMARK_CAPTURE(step_time, DefaultScene, "default.toml", nullptr)->UseManualTime()->Iterations(30000);
BENCHMARK_CAPTURE(step_time, ConstructionGodObject, "construction.toml", nullptr)->UseManualTime()->Iterations(9000);
BENCHMARK_CAPTURE(step_time, PhantomScene, "phantom.toml", nullptr)->UseManualTime()->Iterations(6000);
BENCHMARK_CAPTURE(step_time, ConstructionDirect, "construction.toml", "direct")->UseManualTime()->Iterations(9000);
BENCHMARK_CAPTURE(period_time, DefaultScene, "default.toml")->Iterations(30000);
BENCHMARK_CAPTURE(period_time, ConstructionGodObject, "construction.toml")->Iterations(9000);

BENCHMARK_MAIN();
