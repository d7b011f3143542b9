// Tests of core/sliding_tie (sliding_tie.hpp): a body's point held on a moving line of the world
// — stiff across it, viscous along it — in the linearly implicit step: stable at a stiffness the
// explicit step cannot take, free to slide along the line but for its friction, carried by a
// moving anchor, its force at the step's start reported; no allocation.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/sliding_tie.hpp"
#include "numen/core/step.hpp"

namespace {

namespace core = numen::core;

/// One free 78 mg body (a 26 mm half-circle needle's mass), no gravity, no sphere; step `dt`.
core::Model one_body(double dt, core::Integrator integrator = core::Integrator::kLinearlyImplicitEuler) {
  core::Model m;
  m.dt = dt;
  m.gravity = core::Vec3::Zero();
  m.integrator = integrator;
  m.material_names = {"steel"};
  m.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5}};
  core::BodyModel b;
  b.name = "needle";
  b.mass = 7.8e-5;
  b.inertia_body = 1e-9 * core::Mat3::Identity();
  m.bodies.push_back(b);
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The body's point 2 mm along its x axis tied to `anchor` on a line along z: k 1000 N/m,
/// c 1 N·s/m, f 2 N·s/m (the needle's default tie, needle.hpp).
core::SlidingTie tie_at(const core::Vec3& anchor) {
  core::SlidingTie t;
  t.body = 0;
  t.local_point = core::Vec3(0.002, 0, 0);
  t.anchor = anchor;
  t.axis = core::Vec3::UnitZ();
  t.stiffness = 1000.0;
  t.damping = 1.0;
  t.friction = 2.0;
  return t;
}

}  // namespace

// 1 mm off across the line, at 1 ms: ω = √(k/m) = 3 580 rad/s, ω h = 3.6 (the symplectic Euler
// diverges above 2). The implicit step pulls the point onto the line and holds it there.
TEST(SlidingTie, HoldsAPointOnTheLineAtAStiffnessTheExplicitStepCannotTake) {
  const core::Model m = one_body(1e-3);
  core::Data d = core::make_data(m);
  d.bodies[0].position = core::Vec3(-0.002 + 0.001, 0, 0);  // its point 1 mm off along x
  double first = 0.0;
  for (int k = 0; k < 200; ++k) {
    d.num_sliding_ties = 1;
    d.sliding_ties[0] = tie_at(core::Vec3::Zero());
    core::step(m, d);
    ASSERT_EQ(d.status & core::kNonFinite, 0u) << k;
    if (k == 0) first = d.sliding_ties[0].force.x();
  }
  EXPECT_NEAR(first, -1.0, 1e-9) << "k · 1 mm at the first step's start, towards the line";
  const core::Vec3 point = d.bodies[0].position + d.bodies[0].orientation * core::Vec3(0.002, 0, 0);
  EXPECT_LT(point.norm(), 1e-6) << "on the line";
  // The symplectic Euler (the force alone, explicit) cannot hold it at this step.
  const core::Model e = one_body(1e-3, core::Integrator::kSymplecticEuler);
  core::Data x = core::make_data(e);
  x.bodies[0].position = core::Vec3(-0.001, 0, 0);
  for (int k = 0; k < 50; ++k) {
    x.num_sliding_ties = 1;
    x.sliding_ties[0] = tie_at(core::Vec3::Zero());
    core::step(e, x);
  }
  EXPECT_TRUE((x.status & core::kNonFinite) != 0u || x.bodies[0].position.norm() > 0.01)
      << "the explicit step grew the deviation: " << x.bodies[0].position.norm();
}

// Along the line only the friction acts: moving at 10 mm/s along z, the force is −f v there,
// and a displacement along the line gives none.
TEST(SlidingTie, SlidesAlongTheLineAgainstItsFrictionAlone) {
  const core::Model m = one_body(1e-4);
  core::Data d = core::make_data(m);
  d.bodies[0].position = core::Vec3(0, 0, 0.003);  // on the line, 3 mm along it
  d.bodies[0].linear_velocity = core::Vec3(0, 0, 0.01);
  d.num_sliding_ties = 1;
  d.sliding_ties[0] = tie_at(core::Vec3::Zero());
  d.sliding_ties[0].local_point.setZero();  // at the centre of mass: no turn
  core::step(m, d);
  EXPECT_NEAR(d.sliding_ties[0].force.z(), -2.0 * 0.01, 1e-12);
  EXPECT_NEAR(d.sliding_ties[0].force.x(), 0.0, 1e-12);
  EXPECT_NEAR(d.sliding_ties[0].force.y(), 0.0, 1e-12);
  // Viscous: v decays as exp(−f t / m), the implicit step's (1 + h f / m)⁻¹ a step.
  const double v1 = d.bodies[0].linear_velocity.z();
  EXPECT_NEAR(v1, 0.01 / (1.0 + 1e-4 * 2.0 / 7.8e-5), 1e-9);
  EXPECT_NEAR(d.bodies[0].position.x(), 0.0, 1e-12) << "nothing across the line";
}

// An anchor moving across the line at 10 mm/s: the point, at rest at first, catches up with
// it and follows it (nothing else acts on the body: no lag once the start has died out).
TEST(SlidingTie, APointFollowsItsMovingAnchor) {
  const core::Model m = one_body(1e-4);
  core::Data d = core::make_data(m);
  d.bodies[0].position = core::Vec3(-0.002, 0, 0);
  const core::Vec3 w(0.01, 0, 0);
  for (int k = 0; k < 2000; ++k) {
    core::SlidingTie t = tie_at(w * (k * m.dt));
    t.anchor_velocity = w;
    d.num_sliding_ties = 1;
    d.sliding_ties[0] = t;
    core::step(m, d);
  }
  const core::Vec3 point = d.bodies[0].position + d.bodies[0].orientation * core::Vec3(0.002, 0, 0);
  const core::Vec3 anchor = w * (2000 * m.dt);
  EXPECT_NEAR(d.bodies[0].linear_velocity.x(), 0.01, 1e-6);
  EXPECT_NEAR(anchor.x() - point.x(), 0.0, 1e-7);
}

TEST(SlidingTie, StepWithTiesNeverAllocates) {
  const core::Model m = one_body(1e-4);
  core::Data d = core::make_data(m);
  core::step(m, d);
  numen::test::AllocationGuard guard;
  for (int k = 0; k < 100; ++k) {
    d.num_sliding_ties = 2;
    d.sliding_ties[0] = tie_at(core::Vec3(0.001, 0, 0));
    d.sliding_ties[1] = tie_at(core::Vec3(0, 0.001, 0));
    core::step(m, d);
  }
  EXPECT_EQ(guard.count(), 0);
}
