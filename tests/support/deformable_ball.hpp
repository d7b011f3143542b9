#pragma once
/// @file deformable_ball.hpp
/// The deformable ball of the net benchmarks (tests/bench/deformable_bench.cpp,
/// net_solve_peer_bench.cpp) and of the solver tests (tests/core/
/// net_solve_tolerance_test.cpp, net_solve_test.cpp), so that all measure the
/// same model: a 0.1 kg icosphere net of radius 3 cm
/// (structural springs 200 N/m, γ 0.05 N·s/m; bending 20 N/m, γ 0.01; ties
/// 5 N/m, γ 0.05, per node) on a 50 g hidden rigid component held through
/// the coupling springs (k_t 300 N/m, critically damped for 0.15 kg), over a
/// floor plane z = 0 (contact 2000 N/m, 2 N·s/m, friction 0.5 N·s/m). The
/// target circles at 1 Hz with a 2 cm radius, 5 mm below the resting height.
/// Header-only; needs only numen::core.

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/step.hpp"

namespace numen::test {

inline constexpr double kBallRadius = 0.03;    ///< m
inline constexpr double kBallCoreMass = 0.05;  ///< kg, the hidden rigid component

/// The ball's net constants (0.1 kg; structural 200 N/m, γ 0.05 N·s/m;
/// bending 20 N/m, γ 0.01; ties 5 N/m, γ 0.05), named "ball" on body 0.
inline core::NetSettings ball_net_settings() {
  core::NetSettings s;
  s.name = "ball";
  s.body = 0;
  s.mass = 0.1;
  s.stiffness = 200.0;
  s.damping = 0.05;
  s.bending_stiffness = 20.0;
  s.bending_damping = 0.01;
  s.tie_stiffness = 5.0;
  s.tie_damping = 0.05;
  return s;
}

/// The ball model with `subdivisions` (1–4: 42–2562 nodes), time step `dt`
/// (s) and CG `tolerance` (default: the shipped setting of a net without
/// joints, docs/deformable.md "Solver tolerance"). Throws std::runtime_error if the model is
/// refused.
inline core::Model make_deformable_ball(int subdivisions, double dt = 1e-3, double tolerance = 3e-4,
                                        int max_iterations = 100) {
  core::Model m;
  m.dt = dt;
  m.material_names = {"default"};
  core::MaterialPair contact;
  contact.stiffness = 2000.0;
  contact.damping = 2.0;
  contact.friction = 0.5;
  m.material_pairs = {contact};
  m.solver.tolerance = tolerance;
  m.solver.max_iterations = max_iterations;
  core::BodyModel b;
  b.name = "core";
  b.mass = kBallCoreMass;
  b.inertia_body = core::Mat3::Identity() * (0.4 * kBallCoreMass * kBallRadius * kBallRadius);
  b.initial_pose.position = core::Vec3(0.02, 0.0, kBallRadius);
  b.coupling.k_t = 300.0;
  b.coupling.gamma_t = core::damping_from_ratio(1.0, kBallCoreMass + 0.1, b.coupling.k_t);
  b.coupling.k_r = 1.0;
  b.coupling.gamma_r = 0.02;
  m.bodies.push_back(b);
  m.initial_held_body = 0;
  core::Obstacle floor;
  floor.name = "floor";
  m.obstacles.push_back(floor);
  std::string err =
      core::add_net(m, core::make_icosphere(kBallRadius, subdivisions), ball_net_settings());
  if (err.empty()) err = core::finalize_model(m);
  if (!err.empty()) throw std::runtime_error(err);
  return m;
}

/// Device target of step `k`: the 1 Hz, 2 cm circle, pressed 5 mm.
inline void set_deformable_ball_target(const core::Model& m, core::Data& d, std::int64_t k) {
  const double w = 2.0 * M_PI, t = static_cast<double>(k) * m.dt;
  d.target.position =
      core::Vec3(0.02 * std::cos(w * t), 0.02 * std::sin(w * t), kBallRadius - 0.005);
  d.target_twist.linear = 0.02 * w * core::Vec3(-std::sin(w * t), std::cos(w * t), 0.0);
}

/// Steps the benchmark's warm-up takes before it measures: the ball has
/// settled onto the floor and a patch of nodes is in contact.
inline constexpr std::int64_t kBallWarmUpSteps = 300;

/// Steps [from, to) of the ball's trajectory, each with its target
/// (set_deformable_ball_target) then core::step. Returns `to`, the next step.
inline std::int64_t run_deformable_ball(const core::Model& m, core::Data& d, std::int64_t from,
                                        std::int64_t to) {
  for (std::int64_t k = from; k < to; ++k) {
    set_deformable_ball_target(m, d, k);
    core::step(m, d);
  }
  return to;
}

}  // namespace numen::test
