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
// multirate_organ_two_instruments: two devices' instruments in the device loop (below).
//
//   ./build/tests/numen_bench --benchmark_filter=multirate_organ

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

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

namespace {

/// organ_scene() with a second instrument (body 2, a device of its own: feedback group 1, Eq. 8
/// gains as the first's): a sphere like the first, starting below the organ.
numen::core::Model organ_scene_two_instruments(double dt) {
  namespace core = numen::core;
  core::Model m = organ_scene(dt);
  core::BodyModel second = m.bodies[1];
  second.name = "tool_2";
  second.sphere_begin = static_cast<int>(m.body_spheres.size());
  m.body_spheres.push_back(core::Sphere{Vec3::Zero(), 0.005});
  second.initial_pose.position = Vec3(0.0, 0.0, -0.04);
  m.bodies.push_back(second);
  m.extra_feedback = {m.feedback};
  if (std::string error = core::finalize_model(m); !error.empty()) throw std::runtime_error(error);
  return m;
}

/// The second instrument's target (body 2's own, Eq. 6): organ_scene()'s circle about the
/// organ's other pole, half a turn behind.
void set_second_target(numen::core::Data& d, int body, std::int64_t k, double dt) {
  const double t = static_cast<double>(k) * dt, w = 2.0 * M_PI;
  const double r = 0.005;
  numen::core::BodyTarget& b = d.body_targets[static_cast<std::size_t>(body)];
  b.pose.position = Vec3(-r * std::cos(w * t), -r * std::sin(w * t), -0.029);
  b.pose.orientation = numen::core::Quat::Identity();
  b.twist.linear = Vec3(r * w * std::sin(w * t), -r * w * std::cos(w * t), 0.0);
  b.twist.angular.setZero();
  b.enabled = true;
  d.feedback_group[static_cast<std::size_t>(body)] = 1;
}

/// Two devices (issue 54): the device step of a composite god-object — both instruments in the
/// device loop at 10 kHz, each pressed 6 mm into the organ at its own pole — against the
/// one-instrument device step of multirate_organ, both in this run, alternated period by period
/// (same machine state):
///   one_device_p50_us, two_device_p50_us, two_device_p99_us   periods without a scene step
///   two_vs_one                                                two_device_p50 / one_device_p50
///   two_scene_p50_us                                          periods with a scene step
void multirate_organ_two_instruments(benchmark::State& state) {
  const int ratio = static_cast<int>(state.range(0));
  const double dt = 1e-4;
  const numen::core::Model one = organ_scene(dt);
  const numen::core::Model two = organ_scene_two_instruments(dt);
  numen::core::MultirateGodObject mr1(one, 1, {ratio, 0.001, {}});
  numen::core::MultirateSettings settings{ratio, 0.001, {}};
  settings.other_devices = {2};
  numen::core::MultirateGodObject mr2(two, 1, settings);
  numen::platform::LatencyHistogram device_one, device_two, scene_two;
  double depth_one = 0.0, depth_two = 0.0;
  std::int64_t k = 0;
  for (auto _ : state) {
    set_target(mr1.device_data(), k, dt);
    std::int64_t t0 = numen::platform::monotonic_now_ns();
    mr1.step();
    const std::int64_t t1 = numen::platform::monotonic_now_ns() - t0;
    set_target(mr2.device_data(), k, dt);
    set_second_target(mr2.device_data(), 1, k, dt);  // body 2 is the device model's body 1
    t0 = numen::platform::monotonic_now_ns();
    mr2.step();
    const std::int64_t t2 = numen::platform::monotonic_now_ns() - t0;
    state.SetIterationTime(static_cast<double>(t2) * 1e-9);
    if (k % ratio == 0) {
      scene_two.record(t2);
    } else {
      device_one.record(t1);
      device_two.record(t2);
    }
    // Each instrument's depth below the organ's rest surface (a sphere of radius 30 mm).
    const numen::core::Data& d = mr2.device_data();
    depth_one = std::max(depth_one, 0.035 - d.bodies[0].position.norm());
    depth_two = std::max(depth_two, 0.035 - d.bodies[1].position.norm());
    ++k;
  }
  const double one_p50 = static_cast<double>(device_one.quantile(0.5)) * 1e-3;
  const double two_p50 = static_cast<double>(device_two.quantile(0.5)) * 1e-3;
  state.counters["one_device_p50_us"] = one_p50;
  state.counters["two_device_p50_us"] = two_p50;
  state.counters["two_device_p99_us"] = static_cast<double>(device_two.quantile(0.99)) * 1e-3;
  state.counters["two_scene_p50_us"] = static_cast<double>(scene_two.quantile(0.5)) * 1e-3;
  state.counters["two_vs_one"] = one_p50 > 0.0 ? two_p50 / one_p50 : 0.0;
  state.counters["planes_max"] = static_cast<double>(mr2.counters().planes_max);
  state.counters["depth_1_mm"] = 1e3 * depth_one;
  state.counters["depth_2_mm"] = 1e3 * depth_two;
}

}  // namespace

BENCHMARK(multirate_organ_two_instruments)->Arg(10)->UseManualTime()->Iterations(4000);
