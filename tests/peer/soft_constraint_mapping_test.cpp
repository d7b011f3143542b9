// Tests of tests/peer/soft_constraint_mapping: the formulas, and MuJoCo itself resting a body
// on a mapped contact at numen's penalty depth.
#include "soft_constraint_mapping.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <stdexcept>

#include "mujoco_engine.hpp"
#include "numen/core/data.hpp"

namespace peer = numen::peer;
namespace core = numen::core;

TEST(SoftConstraintMapping,
     ASoftSpringGetsTheImpedanceFloorWithNumensRestStiffnessAndDampingRatio) {
  // Construction game: k = 5000 N/m, c = 2 N·s/m on 50 g: ω Δt = 0.32 ≤ ½, so the time-constant
  // rule asks for nothing and the floor kMinImpedance applies: K = (1 − d) k/m.
  const double k = 5000.0, c = 2.0, m = 0.05;
  const peer::SoftConstraint s = peer::match_spring(k, c, m, 1e-3);
  EXPECT_EQ(s.impedance, peer::kMinImpedance);
  EXPECT_NEAR(s.stiffness, (1.0 - peer::kMinImpedance) * k / m, 1e-9 * k / m);
  EXPECT_NEAR(peer::static_stiffness(s, m), k, 1e-9 * k);
  EXPECT_NEAR(s.damping / (2.0 * std::sqrt(s.stiffness)), c / (2.0 * std::sqrt(k * m)), 1e-12);
}

TEST(SoftConstraintMapping, AStiffSpringKeepsItsRestStiffnessAndTheTimeConstantRule) {
  // The wall: k = 1e5 N/m on 50 g, ω Δt = 1.41: the impedance rises until 1/√K = 2 Δt.
  const double k = 1e5, c = 50.0, m = 0.05, dt = 1e-3;
  const peer::SoftConstraint s = peer::match_spring(k, c, m, dt);
  EXPECT_GT(s.impedance, 0.8);
  EXPECT_NEAR(1.0 / std::sqrt(s.stiffness), 2.0 * dt, 1e-12);
  EXPECT_NEAR(peer::static_stiffness(s, m), k, 1e-9 * k);
  const double zeta = c / (2.0 * std::sqrt(k * m));
  EXPECT_NEAR(s.damping / (2.0 * std::sqrt(s.stiffness)), zeta, 1e-12);
}

TEST(SoftConstraintMapping, RejectsArgumentsOutOfRangeByName) {
  EXPECT_THROW(peer::match_spring(0.0, 1.0, 1.0, 1e-3), std::invalid_argument);
  EXPECT_THROW(peer::match_spring(1.0, -1.0, 1.0, 1e-3), std::invalid_argument);
  EXPECT_THROW(peer::match_spring(1.0, 1.0, 0.0, 1e-3), std::invalid_argument);
  try {
    peer::match_spring(1.0, 1.0, 1.0, std::nan(""));
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("dt"), std::string::npos);
  }
}

namespace {

/// A ball of mass m on a floor plane under gravity, contact (k, c).
core::Model ball_on_floor(double k, double c, double m) {
  core::Model model;
  model.material_names = {"default"};
  model.material_pairs = {core::MaterialPair{k, c, 0.0}};
  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;
  model.obstacles = {floor};
  model.body_spheres = {core::Sphere{core::Vec3::Zero(), 0.01}};
  core::BodyModel b;
  b.name = "ball";
  b.mass = m;
  b.inertia_body = core::Mat3::Identity() * (0.4 * m * 1e-4);
  b.sphere_count = 1;
  b.initial_pose.position = core::Vec3(0.0, 0.0, 0.01);
  model.bodies = {b};
  model.initial_held_body = -1;
  EXPECT_EQ(core::finalize_model(model), "");
  return model;
}

}  // namespace

TEST(SoftConstraintMapping, MujocoRestsABallAtNumensPenaltyDepth) {
  // At rest the mapped contact carries m g at a depth m g / k (numen's penalty balance), for a
  // soft contact (d → 0) and a stiff one (d ≈ 0.9).
  for (const double k : {5000.0, 1e5}) {
    const double m = 0.05, c = 2.0 * 0.7 * std::sqrt(k * m);
    const core::Model model = ball_on_floor(k, c, m);
    peer::MujocoEngine engine(model, peer::Drive::kPdForce, {});
    peer::StepInput idle;
    idle.body_targets.resize(1);
    std::vector<core::BodyState> s;
    for (int i = 0; i < 2000; ++i) {
      engine.apply(idle);
      engine.step();
    }
    engine.read_states(s);
    const double depth = 0.01 - s[0].position.z();
    EXPECT_NEAR(depth, m * 9.81 / k, 0.02 * m * 9.81 / k) << "k = " << k;
    EXPECT_LT(s[0].linear_velocity.norm(), 1e-6);
    EXPECT_EQ(engine.divergences(), 0);
  }
}
