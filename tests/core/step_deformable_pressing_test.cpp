// Tests of core/step with a deformable god-object pressed on obstacles (paper §4.2): zero
// allocations, determinism, the solver's reported iterations and residual, non-finite
// rollback, and the first-order coupling carrying the net.
#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "sanitizer.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "step_deformable_nets.hpp"

#include "scratch/data_scratch.hpp"

namespace core = numen::core;
using core::Mat3;
using core::Vec3;
using namespace numen::test::deformable_nets;

// ---------------------------------------------------------------------------
// (4) Zero allocations; (5) determinism; (7) solver reports.

namespace {

/// A net pressed on a floor plane and a static sphere-set ridge by its god-object
/// rigid component (target 1 cm below the resting height, sliding along x).
/// With `joints`: the device holds a handle body carrying the rigid component
/// on a revolute joint (axis y).
core::Model pressing_scene(core::Integrator integ, bool joints) {
  core::Model m;
  m.dt = integ == core::Integrator::kSymplecticEuler ? 5e-4 : 1e-3;
  m.integrator = integ;
  m.material_names = {"world", "net"};
  m.material_pairs.assign(4, core::MaterialPair{2e3, 3.0, 0.2});
  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;
  core::Obstacle ridge;
  ridge.name = "ridge";
  ridge.type = core::ShapeType::kSphereSet;
  ridge.sphere_begin = 0;
  ridge.sphere_count = 6;
  for (int i = 0; i < 6; ++i) m.static_spheres.push_back(core::Sphere{Vec3(-0.05 + 0.02 * i, 0.03, 0.0), 0.012});
  m.obstacles = {floor, ridge};
  core::BodyModel b;
  b.name = "core";
  b.mass = 0.1;
  b.inertia_body = 1e-4 * Mat3::Identity();
  b.initial_pose.position = Vec3(0.0, 0.0, 0.055);
  b.coupling = {500.0, core::damping_from_ratio(0.9, 0.2, 500.0), 0.5, core::damping_from_ratio(0.9, 2.7e-4, 0.5)};
  m.bodies = {b};
  m.initial_held_body = 0;
  if (joints) {
    core::BodyModel handle = b;
    handle.name = "handle";
    handle.initial_pose.position = Vec3(0.0, 0.0, 0.155);
    m.bodies.push_back(handle);
    m.initial_held_body = 1;
    core::JointModel j;
    j.name = "wrist";
    j.type = core::JointType::kRevolute;
    j.parent = 1;
    j.child = 0;
    j.frame_parent = core::Pose{Vec3(0, 0, -0.05), rot(-M_PI / 2, Vec3::UnitX())};
    j.frame_child = core::Pose{Vec3(0, 0, 0.05), rot(-M_PI / 2, Vec3::UnitX())};
    m.joints = {j};
  }
  core::NetSettings s;
  s.name = "bag";
  s.body = 0;
  s.material = 1;
  s.mass = 0.1;
  s.stiffness = 50.0;
  s.damping = 0.1;
  s.bending_stiffness = 10.0;
  s.bending_damping = 0.02;
  s.tie_stiffness = 300.0;
  s.tie_damping = core::damping_from_ratio(0.7, 0.1 / 42, 300.0);
  EXPECT_EQ(core::add_net(m, core::make_icosphere(0.05, 1), s), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

void drive(const core::Model& m, core::Data& d, int k) {
  const double t = k * m.dt;
  const core::Pose& home = m.bodies[at(m.initial_held_body)].initial_pose;
  d.target.position = home.position + Vec3(0.04 * std::sin(2.0 * t), 0.01 * std::sin(3.0 * t), -0.012);
  d.target.orientation = rot(0.2 * std::sin(1.5 * t), Vec3(0.3, 1.0, 0.0)) * home.orientation;
  d.target_twist.linear = Vec3(0.08 * std::cos(2.0 * t), 0.03 * std::cos(3.0 * t), 0.0);
  d.target_twist.angular = 0.3 * std::cos(1.5 * t) * Vec3(0.3, 1.0, 0.0).normalized();
}

/// Why only the implicit and symplectic Euler runs (and the symplectic jointed one) take their
/// steps under a sanitizer: each run takes 35–65 s under ASan+UBSan with coverage, and the other
/// integrators' and the jointed net's step code runs there in StepDeformable's shorter tests.
constexpr const char* kVariantTooSlowUnderSanitizer =
    "35-65 s under ASan+UBSan with coverage; the implicit and symplectic runs without joints "
    "take their steps there, this variant's step code runs in the shorter tests";

/// The steps of a pressing run: 10 000 natively; under a sanitizer (each net step some 300x
/// slower: the implicit run's 10 000 steps took 289 s under ASan+UBSan) the first π/2 s, half a
/// period of drive()'s x sweep (the net slides 4 cm along the ridge and back), which presses on
/// the floor and on the ridge's spheres from the first steps on: the same contact, solver and
/// coupling code runs, on fewer steps.
int pressing_steps(const core::Model& m) {
  return numen::test::under_sanitizer() ? static_cast<int>(M_PI / 2.0 / m.dt) : 10000;
}

void check_ten_thousand_steps_do_not_allocate(core::Integrator integ, bool joints) {
  const core::Model m = pressing_scene(integ, joints);
  core::Data d = core::make_data(m);
  const int steps = pressing_steps(m);
  std::int64_t count = 0;
  int bad_step = -1, max_contacts = 0, min_iterations = 1 << 30, max_iterations = 0, ridge_steps = 0;
  std::uint32_t bad_status = 0;
  double max_pen = 0.0, max_residual = 0.0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < steps; ++k) {
      drive(m, d, k);
      core::step(m, d);
      if (d.status != core::kStepOk && bad_step < 0) {
        bad_step = k;
        bad_status = d.status;
      }
      max_contacts = std::max(max_contacts, d.num_node_contacts);
      bool ridge = false;
      for (int c = 0; c < d.num_node_contacts; ++c) ridge = ridge || d.node_contacts[at(c)].obstacle == 1;
      ridge_steps += ridge ? 1 : 0;
      max_pen = std::max(max_pen, d.nets[0].max_penetration);
      min_iterations = std::min(min_iterations, d.solver_iterations);
      max_iterations = std::max(max_iterations, d.solver_iterations);
      max_residual = std::max(max_residual, d.solver_residual);
    }
    count = guard.count();
  }
  std::printf("[alloc %-10s joints %d] %d steps: allocations %lld, node contacts ≤ %d (steps on "
              "the ridge %d), max penetration %.2e m, iterations %d..%d, max residual %.2e\n",
              name(integ), joints ? 1 : 0, steps, static_cast<long long>(count), max_contacts,
              ridge_steps, max_pen, min_iterations, max_iterations, max_residual);
  EXPECT_EQ(count, 0);
  EXPECT_EQ(bad_step, -1) << "status " << bad_status;
  EXPECT_GT(max_contacts, 5) << "the net must press on the obstacles";
  EXPECT_GT(ridge_steps, steps / 10) << "and on the sphere set";
  EXPECT_EQ(d.nonfinite_steps, 0);
  for (const core::NodeState& n : d.nodes) EXPECT_TRUE(n.position.allFinite() && n.velocity.allFinite());
  if (integ != core::Integrator::kSymplecticEuler) {
    EXPECT_GT(min_iterations, 0);
    EXPECT_LE(max_residual, m.solver.tolerance);
  } else {
    EXPECT_EQ(max_iterations, 0);
    EXPECT_EQ(max_residual, 0.0);
  }
}

}  // namespace

TEST(StepDeformable, TenThousandImplicitStepsPressingOnObstaclesDoNotAllocate) {
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kLinearlyImplicitEuler, false);
}

TEST(StepDeformable, TenThousandImplicitJointedStepsPressingOnObstaclesDoNotAllocate) {
  NUMEN_SKIP_UNDER_SANITIZER(kVariantTooSlowUnderSanitizer);
  NUMEN_REQUIRE_ARTICULATION();
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kLinearlyImplicitEuler, true);
}

TEST(StepDeformable, TenThousandTrapezoidalStepsPressingOnObstaclesDoNotAllocate) {
  NUMEN_SKIP_UNDER_SANITIZER(kVariantTooSlowUnderSanitizer);
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kTrapezoidal, false);
}

TEST(StepDeformable, TenThousandTrapezoidalJointedStepsPressingOnObstaclesDoNotAllocate) {
  NUMEN_SKIP_UNDER_SANITIZER(kVariantTooSlowUnderSanitizer);
  NUMEN_REQUIRE_ARTICULATION();
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kTrapezoidal, true);
}

TEST(StepDeformable, TenThousandTrBdf2StepsPressingOnObstaclesDoNotAllocate) {
  NUMEN_SKIP_UNDER_SANITIZER(kVariantTooSlowUnderSanitizer);
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kTrBdf2, false);
}

TEST(StepDeformable, TenThousandTrBdf2JointedStepsPressingOnObstaclesDoNotAllocate) {
  NUMEN_SKIP_UNDER_SANITIZER(kVariantTooSlowUnderSanitizer);
  NUMEN_REQUIRE_ARTICULATION();
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kTrBdf2, true);
}

TEST(StepDeformable, TenThousandSymplecticStepsPressingOnObstaclesDoNotAllocate) {
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kSymplecticEuler, false);
}

TEST(StepDeformable, TenThousandSymplecticJointedStepsPressingOnObstaclesDoNotAllocate) {
  NUMEN_REQUIRE_ARTICULATION();
  check_ten_thousand_steps_do_not_allocate(core::Integrator::kSymplecticEuler, true);
}

namespace {

bool same_bits(const void* a, const void* b, std::size_t n) { return std::memcmp(a, b, n) == 0; }

bool same_nodes(const core::Data& a, const core::Data& b) {
  for (std::size_t i = 0; i < a.nodes.size(); ++i)
    if (!same_bits(a.nodes[i].position.data(), b.nodes[i].position.data(), 24) ||
        !same_bits(a.nodes[i].velocity.data(), b.nodes[i].velocity.data(), 24))
      return false;
  return true;
}

bool same_bodies(const core::Data& a, const core::Data& b) {
  for (std::size_t i = 0; i < a.bodies.size(); ++i)
    if (!same_bits(a.bodies[i].position.data(), b.bodies[i].position.data(), 24) ||
        !same_bits(a.bodies[i].orientation.coeffs().data(), b.bodies[i].orientation.coeffs().data(), 32) ||
        !same_bits(a.bodies[i].linear_velocity.data(), b.bodies[i].linear_velocity.data(), 24) ||
        !same_bits(a.bodies[i].angular_velocity.data(), b.bodies[i].angular_velocity.data(), 24))
      return false;
  return true;
}

}  // namespace

TEST(StepDeformable, RepeatedRunsAreBitIdentical) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "bit-identity is not what a sanitizer checks, and the 6 000 net steps take 38 s under"
      " ASan+UBSan with coverage");
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    for (bool joints : {false, true}) {
      if (joints && !core::kWithArticulation) continue;  // this build has no joints
      SCOPED_TRACE(std::string(name(integ)) + (joints ? " jointed" : ""));
      const core::Model m = pressing_scene(integ, joints);
      core::Data a = core::make_data(m);
      core::Data b = core::make_data(m);
      for (int k = 0; k < 1500; ++k) {
        drive(m, a, k);
        drive(m, b, k);
        core::step(m, a);
        core::step(m, b);
      }
      EXPECT_GT(a.num_node_contacts, 0);
      EXPECT_TRUE(same_nodes(a, b));
      EXPECT_TRUE(same_bodies(a, b));
      EXPECT_EQ(a.solver_iterations, b.solver_iterations);
      EXPECT_TRUE(same_bits(&a.solver_residual, &b.solver_residual, sizeof(double)));
      EXPECT_TRUE(same_bits(a.feedback_wrench.force.data(), b.feedback_wrench.force.data(), 24));
      // Replayed after a reset: the same bits again (the warm start is reset too).
      core::reset_data(m, a);
      for (int k = 0; k < 1500; ++k) {
        drive(m, a, k);
        core::step(m, a);
      }
      EXPECT_TRUE(same_nodes(a, b));
      EXPECT_TRUE(same_bodies(a, b));
    }
  }
}

TEST(StepDeformable, SolverIterationsAndResidualAreReported) {
  const core::Model m = pressing_scene(core::Integrator::kLinearlyImplicitEuler, false);
  core::Data d = core::make_data(m);
  int total = 0;
  for (int k = 0; k < 300; ++k) {
    drive(m, d, k);
    core::step(m, d);
    ASSERT_EQ(d.status & core::kSolverNotConverged, 0u) << k;
    EXPECT_GT(d.solver_iterations, 0) << k;
    EXPECT_LE(d.solver_residual, m.solver.tolerance) << k;
    EXPECT_GE(d.solver_residual, 0.0);
    total += d.solver_iterations;
  }
  std::printf("[solver report] mean iterations %.2f over 300 pressing steps (tolerance %.0e)\n", total / 300.0,
              m.solver.tolerance);
  // A tolerance out of reach: reported as not converged, residual above it.
  core::Model tight = m;
  tight.solver.max_iterations = 2;
  tight.solver.tolerance = 1e-15;
  core::Data dt = core::make_data(tight);
  drive(tight, dt, 0);
  dt.nodes[3].velocity += Vec3(0.5, 0.0, 0.0);
  core::step(tight, dt);
  EXPECT_TRUE(dt.status & core::kSolverNotConverged);
  EXPECT_EQ(dt.solver_iterations, 2);
  EXPECT_GT(dt.solver_residual, 1e-15);
  EXPECT_TRUE(std::isfinite(dt.solver_residual));
}

// ---------------------------------------------------------------------------
// (6) Non-finite inputs.

TEST(StepDeformable, NonFiniteTargetSkipsTheCouplingAndKeepsTheNetFinite) {
  for (auto mode : {core::CouplingMode::kGodObject, core::CouplingMode::kDirect}) {
    for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
      SCOPED_TRACE(std::string(name(integ)) + " " + name(mode));
      core::Model m = pressing_scene(integ, false);
      m.coupling_mode = mode;
      ASSERT_EQ(core::finalize_model(m), "");
      core::Data d = core::make_data(m);
      for (int k = 0; k < 50; ++k) {
        drive(m, d, k);
        core::step(m, d);
      }
      d.target.position.x() = std::numeric_limits<double>::quiet_NaN();
      core::step(m, d);
      EXPECT_TRUE(d.status & core::kInvalidTarget);
      EXPECT_EQ(d.status & core::kNonFinite, 0u);
      for (const core::NodeState& n : d.nodes) EXPECT_TRUE(n.position.allFinite() && n.velocity.allFinite());
      for (const core::BodyState& b : d.bodies) EXPECT_TRUE(core::state_is_finite(b));
      EXPECT_TRUE(std::isfinite(d.nets[0].max_tie_stretch));
      drive(m, d, 51);
      core::step(m, d);
      EXPECT_EQ(d.status & (core::kInvalidTarget | core::kNonFinite), 0u);
    }
  }
}

TEST(StepDeformable, NonFiniteResultIsRolledBackWithTheNodes) {
  for (auto integ : {core::Integrator::kLinearlyImplicitEuler, core::Integrator::kSymplecticEuler}) {
    for (bool joints : {false, true}) {
      if (joints && !core::kWithArticulation) continue;  // this build has no joints
      SCOPED_TRACE(std::string(name(integ)) + (joints ? " jointed" : ""));
      const core::Model m = pressing_scene(integ, joints);
      core::Data d = core::make_data(m);
      for (int k = 0; k < 100; ++k) {
        drive(m, d, k);
        core::step(m, d);
      }
      const std::vector<core::NodeState> nodes_before = d.nodes;
      const std::vector<core::BodyState> bodies_before = d.bodies;
      // A NaN force on the rigid component (a corrupted admittance input).
      d.applied_wrench[0].force.z() = std::numeric_limits<double>::quiet_NaN();
      drive(m, d, 100);
      core::step(m, d);
      EXPECT_TRUE(d.status & core::kNonFinite);
      EXPECT_EQ(d.nonfinite_steps, 1);
      for (std::size_t i = 0; i < d.nodes.size(); ++i) {
        EXPECT_EQ(d.nodes[i].position, nodes_before[i].position) << i;
        EXPECT_TRUE(d.nodes[i].velocity.isZero(0.0)) << i;
        EXPECT_TRUE(d.scratch->net.delta[i].isZero(0.0)) << i;  // the next warm start
      }
      for (std::size_t b = 0; b < d.bodies.size(); ++b) {
        EXPECT_EQ(d.bodies[b].position, bodies_before[b].position);
        EXPECT_TRUE(d.bodies[b].linear_velocity.isZero(0.0));
        EXPECT_TRUE(d.scratch->solver.delta[b].isZero(0.0));
      }
      EXPECT_TRUE(d.feedback_wrench.force.isZero(0.0));
      // Recovers with a sane input; nothing non-finite is carried.
      d.applied_wrench[0] = core::Wrench{};
      for (int k = 101; k < 140; ++k) {
        drive(m, d, k);
        core::step(m, d);
        ASSERT_EQ(d.status & core::kNonFinite, 0u) << k;
      }
      EXPECT_EQ(d.nonfinite_steps, 1);
      for (const core::NodeState& n : d.nodes) EXPECT_TRUE(n.position.allFinite() && n.velocity.allFinite());
      const core::NetOutput& o = d.nets[0];
      EXPECT_TRUE(std::isfinite(o.max_tie_stretch) && std::isfinite(o.max_node_speed) &&
                  std::isfinite(o.max_strain) && std::isfinite(o.kinetic_energy) &&
                  o.tie_wrench.force.allFinite());
      EXPECT_TRUE(std::isfinite(d.solver_residual));
    }
  }
}

TEST(StepDeformable, OutputsOfARejectedStepDescribeTheRestoredNet) {
  // After a rolled-back step the nodes are back at their saved positions with
  // zero velocity; the per-net outputs (traces, studies) should describe that
  // state (or be zeroed), like the feedback, and carry no NaN.
  const core::Model m = pressing_scene(core::Integrator::kLinearlyImplicitEuler, false);
  core::Data d = core::make_data(m);
  for (int k = 0; k < 100; ++k) {
    drive(m, d, k);
    core::step(m, d);
  }
  d.applied_wrench[0].force.z() = std::numeric_limits<double>::quiet_NaN();
  drive(m, d, 100);
  core::step(m, d);
  ASSERT_TRUE(d.status & core::kNonFinite);
  const core::NetOutput& o = d.nets[0];
  std::printf("[rejected step] NetOutput: stretch %g speed %g strain %g KE %g tie force %g; solver residual %g\n",
              o.max_tie_stretch, o.max_node_speed, o.max_strain, o.kinetic_energy, o.tie_wrench.force.norm(),
              d.solver_residual);
  EXPECT_TRUE(std::isfinite(o.max_tie_stretch));
  EXPECT_TRUE(std::isfinite(o.max_strain));
  EXPECT_EQ(o.max_node_speed, 0.0);
  EXPECT_EQ(o.kinetic_energy, 0.0);
}

namespace {

struct PressingRun {
  double final_error = 0.0, max_stretch = 0.0;
  int nonfinite_steps = 0, first_bad = -1;
  std::uint32_t bad_status = 0;
};

/// kFirstOrder (massless rigid component, the paper's footnote) carrying the
/// pressing scene's net (no obstacles, no gravity) to a target 10 cm away
/// along a 0.5 m/s ramp.
PressingRun first_order_run(core::Integrator integ, double gamma_t, double gamma_r) {
  core::Model m = pressing_scene(integ, false);
  m.coupling_mode = core::CouplingMode::kFirstOrder;
  m.gravity = Vec3::Zero();
  m.obstacles.clear();
  m.bodies[0].coupling = {500.0, gamma_t, 0.5, gamma_r};
  EXPECT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  const Vec3 home = d.target.position;
  PressingRun r;
  const int steps = static_cast<int>(0.5 / m.dt);
  for (int k = 0; k < steps; ++k) {
    d.target.position = home + Vec3(0.1 * std::min(1.0, k * m.dt / 0.2), 0.0, 0.0);
    d.target_twist.linear = Vec3(k * m.dt < 0.2 ? 0.5 : 0.0, 0.0, 0.0);
    core::step(m, d);
    if (d.status != core::kStepOk && r.first_bad < 0) {
      r.first_bad = k;
      r.bad_status = d.status;
    }
    r.max_stretch = std::max(r.max_stretch, d.nets[0].max_tie_stretch);
  }
  r.nonfinite_steps = static_cast<int>(d.nonfinite_steps);
  r.final_error = (d.bodies[0].position - (home + Vec3(0.1, 0, 0))).norm();
  return r;
}

}  // namespace

TEST(StepDeformable, FirstOrderCouplingCarriesTheNet) {
  // Sums of the ties' damping on the rigid component (pressing scene's net:
  // 42 nodes, γ_tie ≈ 1.18 N·s/m, r = 5 cm): Γ_t = Σ γ_tie ≈ 50 N·s/m for a
  // translation, Γ_r = Σ γ_tie |ρ⊥|² ≈ 0.083 N·m·s for a rotation.
  const double gamma_tie = core::damping_from_ratio(0.7, 0.1 / 42, 300.0);
  const double sum_t = 42 * gamma_tie, sum_r = sum_t * 2.0 / 3.0 * 0.05 * 0.05;
  // Implicit: any first-order gains, here weaker than the ties' damping.
  const PressingRun imp = first_order_run(core::Integrator::kLinearlyImplicitEuler, 20.0, 0.05);
  std::printf("[first order implicit   γ_t 20  γ_r 0.05] final error %.2e m, max tie stretch %.2e m, non-finite %d\n",
              imp.final_error, imp.max_stretch, imp.nonfinite_steps);
  EXPECT_EQ(imp.first_bad, -1) << imp.bad_status;
  EXPECT_LT(imp.final_error, 1e-4);
  EXPECT_LT(imp.max_stretch, 2e-3);
  // Symplectic: the first-order law v1 = v_t + (k e + F_other)/γ takes the ties'
  // reaction explicitly, and that reaction holds −Γ v0: v1 ∝ −(Γ/γ) v0 is
  // unstable unless γ_t > Γ_t and γ_r > Γ_r (integrator.hpp states only
  // h k/γ < 2). With twice those sums it is bounded...
  const PressingRun ok =
      first_order_run(core::Integrator::kSymplecticEuler, 2.0 * sum_t, 2.0 * sum_r);
  std::printf("[first order symplectic γ_t %.0f γ_r %.3f] final error %.2e m, max tie stretch %.2e m, non-finite %d\n",
              2.0 * sum_t, 2.0 * sum_r, ok.final_error, ok.max_stretch, ok.nonfinite_steps);
  EXPECT_EQ(ok.first_bad, -1) << ok.bad_status;
  EXPECT_LT(ok.final_error, 1e-3);
  EXPECT_LT(ok.max_stretch, 2e-3);
  // ... with the implicit run's gains it diverges (rejected steps, rolled back).
  const PressingRun bad = first_order_run(core::Integrator::kSymplecticEuler, 20.0, 0.05);
  std::printf("[first order symplectic γ_t 20  γ_r 0.05] final error %.2e m, max tie stretch %.2e m, non-finite %d "
              "(first bad step %d)\n",
              bad.final_error, bad.max_stretch, bad.nonfinite_steps, bad.first_bad);
  EXPECT_GT(bad.nonfinite_steps, 0);
  RecordProperty("first_order_symplectic_low_gain_nonfinite_steps", bad.nonfinite_steps);
}
