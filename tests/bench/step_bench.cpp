// Per-step cost of the shipped scenes (issue: lattice scene median ≤ 5 µs,
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
#include <optional>
#include <stdexcept>
#include <vector>
#include <string>

#include "numen/platform/latency_histogram.hpp"
#include "numen/sim/run/run.hpp"
#include "numen/sim/scene/scene.hpp"

namespace {

std::string scene_path(const char* name) { return std::string(NUMEN_SOURCE_DIR) + "/sim/scenes/" + name; }

/// The scene, or nothing (the benchmark is reported skipped with the loader's
/// error) when this build cannot load it (a NUMEN_WITH_* option is OFF).
std::optional<numen::sim::Scene> load_or_skip(benchmark::State& state, const char* name,
                                              const numen::sim::SceneOverrides& o = {}) {
  try {
    return numen::sim::load_scene(scene_path(name), o);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return std::nullopt;
  }
}

/// Refills the scene's sphere-set organ with a denser lattice of the same
/// ellipsoid (semi-axes 35 × 25 × 20 mm in the organ's frame): spacing 4.4 mm,
/// spheres of 3.9 mm (≥ spacing·√3/2, no hole) — about 500 spheres, the organ of
/// issue 3's target. Re-finalizes the model (broad-phase grid).
void densify_organ(numen::sim::Scene& scene) {
  using numen::core::Vec3;
  numen::core::Model& m = scene.model;
  for (numen::core::Obstacle& o : m.obstacles) {
    if (o.type != numen::core::ShapeType::kSphereSet) continue;
    const Vec3 radii(0.035, 0.025, 0.020);
    const double spacing = 0.0044, r = 0.0039;
    const Vec3 inner = radii - Vec3::Constant(r);
    std::vector<numen::core::Sphere> spheres;
    for (double x = -inner.x(); x <= inner.x() + 1e-12; x += spacing)
      for (double y = -inner.y(); y <= inner.y() + 1e-12; y += spacing)
        for (double z = -inner.z(); z <= inner.z() + 1e-12; z += spacing) {
          const Vec3 p(x, y, z);
          if (p.cwiseQuotient(inner).squaredNorm() > 1.0) continue;
          spheres.push_back({o.pose.position + o.pose.orientation * p, r});
        }
    m.static_spheres = spheres;  // the scene's only sphere set
    o.sphere_begin = 0;
    o.sphere_count = static_cast<int>(spheres.size());
  }
  const std::string err = numen::core::finalize_model(m);
  if (!err.empty()) throw std::runtime_error(err);
}

void step_time(benchmark::State& state, const char* name, const char* coupling,
               bool dense_organ = false) {
  numen::sim::SceneOverrides o;
  if (coupling) o.coupling = numen::sim::parse_coupling_mode(coupling);
  std::optional<numen::sim::Scene> loaded = load_or_skip(state, name, o);
  if (!loaded) return;
  numen::sim::Scene& scene = *loaded;
  if (dense_organ) densify_organ(scene);
  const auto periods = static_cast<std::int64_t>(scene.duration_s / scene.model.dt);
  auto runner = std::make_unique<numen::sim::SceneRunner>(scene);
  std::int64_t contacts = 0, iterations = 0;
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
    iterations += runner->data().solver_iterations;  // the step's CG iterations: load-independent
  }
  state.counters["contacts_per_step"] =
      benchmark::Counter(static_cast<double>(contacts), benchmark::Counter::kAvgIterations);
  state.counters["solver_iterations_per_step"] =
      benchmark::Counter(static_cast<double>(iterations), benchmark::Counter::kAvgIterations);
  state.counters["bodies"] = scene.model.num_bodies();
  state.counters["static_spheres"] = static_cast<double>(scene.model.static_spheres.size());
  state.counters["step_p50_us"] = static_cast<double>(hist.quantile(0.5)) * 1e-3;
  state.counters["step_p99_us"] = static_cast<double>(hist.quantile(0.99)) * 1e-3;
}

void period_time(benchmark::State& state, const char* name) {
  const std::optional<numen::sim::Scene> loaded = load_or_skip(state, name);
  if (!loaded) return;
  const numen::sim::Scene& scene = *loaded;
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

BENCHMARK_CAPTURE(step_time, LatticeScene, "lattice.toml", nullptr)->UseManualTime()->Iterations(30000);
BENCHMARK_CAPTURE(step_time, LatticeSceneOrgan500, "lattice.toml", nullptr, true)
    ->UseManualTime()
    ->Iterations(30000);
BENCHMARK_CAPTURE(step_time, ConstructionGodObject, "construction.toml", nullptr)->UseManualTime()->Iterations(9000);
BENCHMARK_CAPTURE(step_time, PhantomScene, "phantom.toml", nullptr)->UseManualTime()->Iterations(6000);
BENCHMARK_CAPTURE(step_time, ConstructionDirect, "construction.toml", "direct")->UseManualTime()->Iterations(9000);
BENCHMARK_CAPTURE(period_time, LatticeScene, "lattice.toml")->Iterations(30000);
// The default scene (its deformable organ, 1002 nodes): its first 10 s.
BENCHMARK_CAPTURE(step_time, DefaultScene, "default.toml", nullptr)->UseManualTime()->Iterations(10000);
BENCHMARK_CAPTURE(period_time, ConstructionGodObject, "construction.toml")->Iterations(9000);

BENCHMARK_MAIN();
