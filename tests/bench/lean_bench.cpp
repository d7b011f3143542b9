// Cost of core::step on scenes without joints or nets (issue 6, "leave out
// what a scene does not need"): the rigid-only model of lean_scenes.hpp (one
// coupled body, no obstacle: no contact pass), the same with a floor (contact
// pass), and the shipped construction game (rigid bodies and obstacles). Built
// in every NUMEN_WITH_* combination: .ci/options-matrix --compare-lean runs it
// in the all-ON and the all-OFF builds alternately and prints the time ratio,
// which is 1 within noise when the optional parts cost a scene that does not
// use them nothing. The time is core::step alone (manual timing); the device
// target moves on a 1 Hz, 2 cm circle so the solve has work to do.
//
//   ./build/tests/numen_bench --benchmark_filter=Lean --benchmark_repetitions=5

#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <string>

#include "lean_scenes.hpp"
#include "numen/core/data.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

namespace core = numen::core;

void run_steps(benchmark::State& state, const core::Model& m) {
  core::Data d = core::make_data(m);
  const core::Vec3 home = d.target.position;
  std::int64_t k = 0;
  for (auto _ : state) {
    const double t = static_cast<double>(k++) * m.dt, w = 2.0 * M_PI;
    d.target.position = home + core::Vec3(0.02 * std::cos(w * t) - 0.02, 0.02 * std::sin(w * t), -0.005);
    d.target_twist.linear = core::Vec3(-0.02 * w * std::sin(w * t), 0.02 * w * std::cos(w * t), 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    core::step(m, d);
    const auto t1 = std::chrono::steady_clock::now();
    state.SetIterationTime(std::chrono::duration<double>(t1 - t0).count());
    benchmark::DoNotOptimize(d.bodies.data());
  }
  state.counters["stages_run"] = static_cast<double>(d.stages_run);
  state.counters["contacts"] = d.num_contacts;
}

void LeanRigidOnly(benchmark::State& state) {
  run_steps(state, numen::test::make_lean_model(numen::test::LeanPart::kNone));
}

void LeanRigidWithFloor(benchmark::State& state) {
  run_steps(state, numen::test::make_lean_model(numen::test::LeanPart::kObstacle));
}

void LeanConstruction(benchmark::State& state) {
  const numen::sim::Scene scene =
      numen::sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/construction.toml");
  run_steps(state, scene.model);
}

}  // namespace

BENCHMARK(LeanRigidOnly)->UseManualTime()->Iterations(200000);
BENCHMARK(LeanRigidWithFloor)->UseManualTime()->Iterations(200000);
BENCHMARK(LeanConstruction)->UseManualTime()->Iterations(20000);
