// The coupled solve's tolerance against the integrator's own error
// (net_solve.hpp; docs/deformable.md, "Solver tolerance"): a relative residual
// of 1e-4 — the shipped deformable scenes' setting — must move the nodes far
// less than halving the time step does.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/step.hpp"

namespace {

namespace core = numen::core;
using core::Vec3;

struct BallRun {
  std::vector<Vec3> nodes;   // node positions at the end (m)
  double iterations = 0.0;   // mean CG iterations per step
};

/// A 162-node ball net (the benchmark's settings) on a god-object pressed
/// 5 mm onto a floor while the target circles at 1 Hz; 1 s.
BallRun run_ball(double tolerance, double dt) {
  core::Model m;
  m.dt = dt;
  m.material_names = {"default"};
  core::MaterialPair contact;
  contact.stiffness = 2000.0;
  contact.damping = 2.0;
  contact.friction = 0.5;
  m.material_pairs = {contact};
  m.solver.tolerance = tolerance;
  m.solver.max_iterations = 1000;
  core::BodyModel b;
  b.name = "core";
  b.mass = 0.05;
  b.inertia_body = core::Mat3::Identity() * (0.4 * 0.05 * 0.03 * 0.03);
  b.initial_pose.position = Vec3(0.02, 0.0, 0.03);
  b.coupling = {300.0, core::damping_from_ratio(1.0, 0.15, 300.0), 1.0, 0.02};
  m.bodies.push_back(b);
  m.initial_attached_body = 0;
  m.obstacles.push_back(core::Obstacle{});  // floor plane z = 0
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
  EXPECT_EQ(core::add_net(m, core::make_icosphere(0.03, 2), s), "");
  EXPECT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  const long steps = std::lround(1.0 / dt);
  BallRun r;
  for (long k = 0; k < steps; ++k) {
    const double w = 2.0 * M_PI, t = static_cast<double>(k) * dt;
    d.target.position = Vec3(0.02 * std::cos(w * t), 0.02 * std::sin(w * t), 0.025);
    d.target_twist.linear = 0.02 * w * Vec3(-std::sin(w * t), std::cos(w * t), 0.0);
    core::step(m, d);
    EXPECT_EQ(d.status & core::kNonFinite, 0u);
    r.iterations += d.solver_iterations;
  }
  EXPECT_GT(d.num_node_contacts, 0);  // pressed on the floor
  r.iterations /= static_cast<double>(steps);
  for (const core::NodeState& n : d.nodes) r.nodes.push_back(n.position);
  return r;
}

double max_distance(const BallRun& a, const BallRun& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.nodes.size(); ++i) m = std::max(m, (a.nodes[i] - b.nodes[i]).norm());
  return m;
}

TEST(NetSolveTolerance, SolverErrorIsFarBelowTheIntegratorError) {
  const BallRun reference = run_ball(1e-12, 1e-3);
  const BallRun half_step = run_ball(1e-12, 5e-4);
  const BallRun loose = run_ball(1e-4, 1e-3);
  const double integrator_error = max_distance(reference, half_step);
  const double solver_error = max_distance(reference, loose);
  RecordProperty("integrator_error_m", std::to_string(integrator_error));
  RecordProperty("solver_error_m", std::to_string(solver_error));
  EXPECT_GT(integrator_error, 1e-5);  // the comparison means something
  EXPECT_LT(solver_error, 1e-3 * integrator_error);
  EXPECT_LT(loose.iterations, 0.6 * reference.iterations);  // and it pays
}

}  // namespace
