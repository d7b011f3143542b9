// The multirate god-object's device step against a deformable organ (docs/organs.md,
// "Organs"): an icosphere organ of 2562 nodes (radius 30 mm, the shipped organ's constants per
// spring and per node) on an anchored core, and a 5 mm sphere god-object (50 g, 1000 N/m
// coupling) pressed 6 mm into it while its target circles; the organ in the scene loop at
// 1 kHz, the god-object in the device loop at 10 kHz against the organ's planes, beside the
// single-rate step of the whole at 10 kHz. Each iteration is one 10 kHz period; counters as in
// multirate_ball_bench.cpp:
//   device_p50_us, device_p99_us   periods without a scene step: what the device loop costs
//   scene_p50_us                   periods with one: scene step + device step
//   single_p50_us                  the single-rate core::step of the same period
//   device_vs_single               device_p50 / single_p50
//
//   ./build/tests/numen_bench --benchmark_filter=multirate_organ

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/step.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace {

using numen::core::Vec3;

/// Body 0 the organ's anchored core with a 2562-node icosphere net of radius 30 mm; body 1 the
/// held sphere (radius 5 mm, 50 g) starting above it. Device step `dt`.
numen::core::Model organ_scene(double dt) {
  namespace core = numen::core;
  core::Model m;
  m.dt = dt;
  m.gravity = Vec3::Zero();
  m.solver.tolerance = 3e-4;
  m.solver.max_iterations = 100;
  m.material_names = {"steel", "tissue"};
  m.material_pairs.assign(4, core::MaterialPair{2e4, 10.0, 0.5});
  core::BodyModel anchor;
  anchor.name = "organ_core";
  anchor.mass = 0.1;
  anchor.inertia_body = 1e-4 * core::Mat3::Identity();
  anchor.material = 1;
  anchor.anchored = true;
  core::BodyModel tool;
  tool.name = "tool";
  tool.mass = 0.05;
  tool.inertia_body = 5e-7 * core::Mat3::Identity();
  tool.sphere_count = 1;
  tool.initial_pose.position = Vec3(0.0, 0.0, 0.04);
  tool.coupling = core::CouplingGains{1000.0, core::damping_from_ratio(0.85, 0.05, 1000.0), 0.01,
                                      core::damping_from_ratio(0.85, 5e-7, 0.01)};
  m.body_spheres = {core::Sphere{Vec3::Zero(), 0.005}};
  m.bodies = {anchor, tool};
  m.initial_held_body = 1;
  m.feedback.k_t = 300.0;
  m.feedback.gamma_t = 1.0;
  const core::TriangleMesh mesh = core::make_icosphere(0.03, 4);
  core::NetSettings s;
  s.name = "organ";
  s.body = 0;
  s.material = 1;
  s.mass = 7e-5 * mesh.num_vertices();
  s.stiffness = 200.0;
  s.damping = 0.1;
  s.bending_stiffness = 50.0;
  s.bending_damping = 0.03;
  s.tie_stiffness = 100.0;
  s.tie_damping = 0.17;
  std::string error = core::add_net(m, mesh, s);
  if (error.empty()) error = core::finalize_model(m);
  if (!error.empty()) throw std::runtime_error(error);
  return m;
}

/// The target: 6 mm into the organ's top, circling 5 mm around its pole at 1 Hz.
void set_target(numen::core::Data& d, std::int64_t k, double dt) {
  const double t = static_cast<double>(k) * dt, w = 2.0 * M_PI;
  const double r = 0.005;
  d.target.position = Vec3(r * std::cos(w * t), r * std::sin(w * t), 0.029);
  d.target.orientation = numen::core::Quat::Identity();
  d.target_twist.linear = Vec3(-r * w * std::sin(w * t), r * w * std::cos(w * t), 0.0);
  d.target_twist.angular.setZero();
}

void multirate_organ(benchmark::State& state) {
  const int ratio = static_cast<int>(state.range(0));
  const double dt = 1e-4;
  const numen::core::Model model = organ_scene(dt);
  numen::core::Data single_data = numen::core::make_data(model);
  numen::core::MultirateGodObject mr(model, 1, {ratio, 0.001, {}});
  numen::platform::LatencyHistogram device, scene_periods, single;
  double single_depth = 0.0, multirate_depth = 0.0;
  std::int64_t k = 0;
  for (auto _ : state) {
    set_target(single_data, k, dt);
    std::int64_t t0 = numen::platform::monotonic_now_ns();
    numen::core::step(model, single_data);
    single.record(numen::platform::monotonic_now_ns() - t0);
    set_target(mr.device_data(), k, dt);
    t0 = numen::platform::monotonic_now_ns();
    mr.step();
    const std::int64_t t = numen::platform::monotonic_now_ns() - t0;
    state.SetIterationTime(static_cast<double>(t) * 1e-9);
    (k % ratio == 0 ? scene_periods : device).record(t);
    // The god-object's depth below the organ's rest surface (a sphere of radius 30 mm).
    // The god-object is body 1 of the scene, body 0 of the device loop's model.
    single_depth = std::max(single_depth, 0.035 - single_data.bodies[1].position.norm());
    multirate_depth = std::max(multirate_depth, 0.035 - mr.device_data().bodies[0].position.norm());
    ++k;
  }
  const double single_p50 = static_cast<double>(single.quantile(0.5)) * 1e-3;
  state.counters["nodes"] = model.num_nodes();
  state.counters["device_p50_us"] = static_cast<double>(device.quantile(0.5)) * 1e-3;
  state.counters["device_p99_us"] = static_cast<double>(device.quantile(0.99)) * 1e-3;
  state.counters["scene_p50_us"] = static_cast<double>(scene_periods.quantile(0.5)) * 1e-3;
  state.counters["single_p50_us"] = single_p50;
  state.counters["device_vs_single"] =
      single_p50 > 0.0 ? static_cast<double>(device.quantile(0.5)) * 1e-3 / single_p50 : 0.0;
  state.counters["planes_max"] = static_cast<double>(mr.counters().planes_max);
  state.counters["single_depth_mm"] = 1e3 * single_depth;
  state.counters["multirate_depth_mm"] = 1e3 * multirate_depth;
}

}  // namespace

BENCHMARK(multirate_organ)->Arg(10)->UseManualTime()->Iterations(4000);
