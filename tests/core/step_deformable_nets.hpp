#pragma once
/// @file step_deformable_nets.hpp
/// Held nets shared by the tests of core/step with deformable god-objects
/// (step_deformable_test.cpp, step_deformable_fast_motion_test.cpp,
/// step_deformable_pressing_test.cpp): a net on a rigid component held by the device, the
/// nodes' offsets from their anchors and the linear static solution they sag to.

#include <cmath>
#include <cstddef>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "net_states.hpp"
#include "rotation.hpp"

namespace numen::test::deformable_nets {

using core::Mat3;
using core::Quat;
using core::Vec3;

using numen::test::at;

using numen::test::rot;

inline const char* name(core::Integrator i) {
  return i == core::Integrator::kSymplecticEuler ? "symplectic"
         : i == core::Integrator::kTrapezoidal   ? "trapezoidal"
         : i == core::Integrator::kTrBdf2        ? "tr-bdf2"
                                                 : "implicit";
}

inline const char* name(core::CouplingMode c) {
  return c == core::CouplingMode::kDirect ? "imposed (kDirect)" : "god-object";
}

/// Equilateral triangle of side `side` in the body's x–y plane, centred on its COM.
inline core::TriangleMesh triangle(double side) {
  core::TriangleMesh m;
  const double r = side / std::sqrt(3.0);
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 * M_PI * k / 3.0;
    m.vertices.push_back(Vec3(r * std::cos(a), r * std::sin(a), 0.0));
  }
  m.triangles = {{0, 1, 2}};
  return m;
}

struct NetParams {
  double mass = 0.1;
  double k = 50.0, gamma = 0.1;
  double k_bend = 10.0, gamma_bend = 0.02;
  double k_tie = 100.0, gamma_tie = 0.5;
};

/// Body 0, the rigid component of one net (no spheres), held by the
/// device; its target starts at its initial pose.
inline core::Model net_model(core::Integrator integ, core::CouplingMode mode, double dt,
                             const core::TriangleMesh& mesh, const NetParams& p,
                             const Vec3& gravity, double body_mass = 0.1) {
  core::Model m;
  m.dt = dt;
  m.gravity = gravity;
  m.integrator = integ;
  m.coupling_mode = mode;
  m.material_names = {"world", "net"};
  m.material_pairs.assign(4, core::MaterialPair{1e3, 2.0, 0.1});
  core::BodyModel b;
  b.name = "core";
  b.mass = body_mass;
  b.inertia_body = 1e-4 * Mat3::Identity();
  b.initial_pose = core::Pose{Vec3(0.0, 0.0, 0.3), rot(0.3, Vec3(1, -2, 0.5))};
  m.bodies = {b};
  m.initial_held_body = 0;
  core::NetSettings s;
  s.name = "bag";
  s.body = 0;
  s.material = 1;
  s.mass = p.mass;
  s.stiffness = p.k;
  s.damping = p.gamma;
  s.bending_stiffness = p.k_bend;
  s.bending_damping = p.gamma_bend;
  s.tie_stiffness = p.k_tie;
  s.tie_damping = p.gamma_tie;
  EXPECT_EQ(core::add_net(m, mesh, s), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Displacement of every node from its anchor (m, world), stacked.
inline Eigen::VectorXd node_offsets(const core::Model& m, const core::Data& d) {
  Eigen::VectorXd x(3 * m.num_nodes());
  for (int i = 0; i < m.num_nodes(); ++i) {
    const core::NetModel& net = m.nets[at(m.node_net[at(i)])];
    const core::BodyState& b = d.bodies[at(net.body)];
    x.segment<3>(3 * i) = d.nodes[at(i)].position - (b.position + b.orientation * m.node_rest[at(i)]);
  }
  return x;
}

/// Small-displacement static solution (K_tie + K_springs) δ = m g at the rest
/// configuration of the held net: K_tie = k_tie I per node, each spring
/// k d̂d̂ᵀ (τ = 0 at rest length) on its two nodes and −k d̂d̂ᵀ between them.
inline Eigen::VectorXd linear_static_deflection(const core::Model& m, const core::BodyState& body) {
  const int n = 3 * m.num_nodes();
  Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd f(n);
  const core::NetModel& net = m.nets[0];
  for (int i = 0; i < m.num_nodes(); ++i) {
    k.block<3, 3>(3 * i, 3 * i) += net.tie_stiffness * Mat3::Identity();
    f.segment<3>(3 * i) = m.node_mass[at(i)] * m.gravity;
  }
  for (const core::NetSpring& s : m.net_springs) {
    const Vec3 dir = (body.orientation * (m.node_rest[at(s.node_b)] - m.node_rest[at(s.node_a)])).normalized();
    const Mat3 kk = s.stiffness * dir * dir.transpose();
    const int a = 3 * s.node_a, b = 3 * s.node_b;
    k.block<3, 3>(a, a) += kk;
    k.block<3, 3>(b, b) += kk;
    k.block<3, 3>(a, b) -= kk;
    k.block<3, 3>(b, a) -= kk;
  }
  return k.llt().solve(f);
}

}  // namespace numen::test::deformable_nets
