// Cost of core::step on articulated chains (issue 3: the linear-time KKT
// solve of articulation.hpp, Baraff 96). A chain of N rigid links (0.05 m,
// 0.1 kg) along x, body 0 hinged to the world, each link to the previous one;
// gravity on, no obstacles, implicit integrator (default). The last link is
// held, coupled to the device target, which moves along a 1 cm circle, so the
// coupling springs (Eq. 2) are in the solve. Revolute joints (axis y, 5 rows)
// and spherical joints (3 rows) show the effect of the row count.
// 200 warm-up steps, then each iteration times one core::step (manual timing).
// Counter ns_per_body = step time / N; linear cost means it stays flat in N.
//
//   ./build/tests/numen_bench --benchmark_filter=Chain --benchmark_repetitions=3

#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "numen/core/data.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

namespace {

namespace core = numen::core;
using core::Vec3;

constexpr double kLink = 0.05;  // m
constexpr double kMass = 0.1;   // kg

core::Model make_chain(int n, core::JointType type) {
  core::Model m;
  m.material_pairs = {core::MaterialPair{}};
  // Joint frames: z onto the world y axis (a revolute about y).
  const core::Quat z_to_y(Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitX()));
  for (int i = 0; i < n; ++i) {
    core::BodyModel b;
    b.name = "link_" + std::to_string(i);
    b.mass = kMass;
    const double inertia = kMass * kLink * kLink / 12.0;  // slender rod along x
    b.inertia_body = Vec3(1e-2 * inertia, inertia, inertia).asDiagonal();
    b.initial_pose.position = Vec3((i + 0.5) * kLink, 0, 0);
    m.bodies.push_back(b);
    core::JointModel j;
    j.name = "joint_" + std::to_string(i);
    j.type = type;
    j.parent = i - 1;
    j.child = i;
    j.frame_parent = core::Pose{i == 0 ? Vec3::Zero() : Vec3(kLink / 2, 0, 0), z_to_y};
    j.frame_child = core::Pose{Vec3(-kLink / 2, 0, 0), z_to_y};
    m.joints.push_back(j);
  }
  core::BodyModel& tip = m.bodies.back();
  tip.coupling.k_t = 500.0;
  tip.coupling.gamma_t = core::damping_from_ratio(1.0, kMass, tip.coupling.k_t);
  tip.coupling.k_r = 0.5;
  tip.coupling.gamma_r = 2.0 * std::sqrt(tip.inertia_body(1, 1) * tip.coupling.k_r);
  m.initial_held_body = n - 1;
  const std::string err = core::finalize_model(m);
  if (!err.empty()) throw std::runtime_error(err);
  return m;
}

/// Device target of the tip: a 1 cm circle at 1 Hz around its rest position.
void set_target(const core::Model& m, core::Data& d, std::int64_t k) {
  const double w = 2.0 * M_PI, t = static_cast<double>(k) * m.dt;
  const Vec3 c = m.bodies.back().initial_pose.position;
  d.held_body = m.num_bodies() - 1;
  d.target.position = c + 0.01 * Vec3(std::cos(w * t), 0, std::sin(w * t));
  d.target_twist.linear = 0.01 * w * Vec3(-std::sin(w * t), 0, std::cos(w * t));
}

void chain_step(benchmark::State& state, core::JointType type) {
  const int n = static_cast<int>(state.range(0));
  const core::Model m = make_chain(n, type);
  core::Data d = core::make_data(m);
  std::int64_t k = 0;
  double total_s = 0.0;
  for (; k < 200; ++k) {  // warm-up
    set_target(m, d, k);
    core::step(m, d);
  }
  for (auto _ : state) {
    set_target(m, d, k++);
    const auto t0 = std::chrono::steady_clock::now();
    core::step(m, d);
    const auto t1 = std::chrono::steady_clock::now();
    const double dt_s = std::chrono::duration<double>(t1 - t0).count();
    total_s += dt_s;
    state.SetIterationTime(dt_s);
  }
  if (d.status != core::kStepOk) state.SkipWithError("step status not ok");
  state.counters["bodies"] = n;
  state.counters["joints"] = m.num_joints();
  state.counters["rows"] = m.articulation.num_rows;
  // Mean time per step / N (kAvgIterations divides by the iterations).
  state.counters["ns_per_body"] =
      benchmark::Counter(total_s * 1e9 / n, benchmark::Counter::kAvgIterations);
  state.counters["max_drift_um"] = d.max_joint_drift * 1e6;
}

void chain_args(benchmark::internal::Benchmark* b) {
  for (int n : {2, 4, 8, 16, 32, 64}) b->Arg(n);
  b->UseManualTime()->MinTime(0.3);
}

void ChainRevolute(benchmark::State& state) { chain_step(state, core::JointType::kRevolute); }
void ChainSpherical(benchmark::State& state) { chain_step(state, core::JointType::kSpherical); }

}  // namespace

BENCHMARK(ChainRevolute)->Apply(chain_args);
BENCHMARK(ChainSpherical)->Apply(chain_args);
