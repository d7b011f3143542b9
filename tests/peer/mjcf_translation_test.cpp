// Tests of tests/peer/mjcf_translation: the MuJoCo model compiled from a numen scene has the
// same bodies (count, masses, inertias, spheres), joints and obstacles.
#include "mjcf_translation.hpp"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <stdexcept>

#include "mujoco_engine.hpp"
#include "peer_run.hpp"
#include "peer_scene.hpp"

namespace peer = numen::peer;
namespace core = numen::core;

namespace {

/// Same bodies in both models: mass, principal moments, sphere geoms (radius, body-frame centre).
void expect_same_bodies(const core::Model& model, const peer::MujocoEngine& engine) {
  const mjModel* m = engine.mj_model();
  for (int b = 0; b < model.num_bodies(); ++b) {
    const core::BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const int id = engine.body_id(b);
    ASSERT_GT(id, 0) << bm.name;
    EXPECT_DOUBLE_EQ(m->body_mass[id], bm.mass) << bm.name;
    Eigen::Vector3d numen_moments =
        Eigen::SelfAdjointEigenSolver<core::Mat3>(bm.inertia_body).eigenvalues();
    Eigen::Vector3d mj_moments(m->body_inertia[3 * id], m->body_inertia[3 * id + 1],
                               m->body_inertia[3 * id + 2]);
    std::sort(mj_moments.data(), mj_moments.data() + 3);
    EXPECT_LT((mj_moments - numen_moments).norm(), 1e-12 + 1e-9 * numen_moments.norm()) << bm.name;
    EXPECT_EQ(m->body_geomnum[id], bm.sphere_count) << bm.name;
    for (int g = 0; g < bm.sphere_count; ++g) {
      const int gid = m->body_geomadr[id] + g;
      const core::Sphere& s = model.body_spheres[static_cast<std::size_t>(bm.sphere_begin + g)];
      EXPECT_EQ(m->geom_type[gid], mjGEOM_SPHERE);
      EXPECT_DOUBLE_EQ(m->geom_size[3 * gid], s.radius);
      // geom_pos is in the body frame, which is numen's COM frame (inertial pos 0).
      EXPECT_LT(
          (core::Vec3(m->geom_pos[3 * gid], m->geom_pos[3 * gid + 1], m->geom_pos[3 * gid + 2]) -
           s.center)
              .norm(),
          1e-12);
    }
  }
}

}  // namespace

TEST(MjcfTranslation, TheInstrumentHasTheSameBodiesJointsAndObstacles) {
  const peer::PeerScene s =
      peer::load_recorded_scene("instrument", "sim/scenes/lattice.toml", 0.01);
  peer::MujocoEngine engine(s.model, peer::Drive::kMocapWeld, peer::held_bodies(s.inputs));
  const mjModel* m = engine.mj_model();
  // world + sleeve, tube, two jaws + the tube's mocap body.
  EXPECT_EQ(m->nbody, 1 + s.model.num_bodies() + 1);
  EXPECT_EQ(m->nmocap, 1);
  expect_same_bodies(s.model, engine);
  // pivot (ball), insertion (slide + hinge), two jaw hinges.
  ASSERT_EQ(m->njnt, 5);
  EXPECT_EQ(m->jnt_type[0], mjJNT_BALL);
  EXPECT_EQ(m->jnt_type[1], mjJNT_SLIDE);
  EXPECT_EQ(m->jnt_type[2], mjJNT_HINGE);
  EXPECT_EQ(m->jnt_type[3], mjJNT_HINGE);
  EXPECT_EQ(m->jnt_type[4], mjJNT_HINGE);
  EXPECT_EQ(m->nv, 3 + 2 + 2);
  // The weld of the tube and the two prescribed jaw hinges.
  EXPECT_EQ(m->neq, 3);
  // World geoms: the tissue plane and every sphere of the organ.
  std::size_t static_geoms = 0;
  for (int g = 0; g < m->ngeom; ++g) static_geoms += m->geom_bodyid[g] == 0 ? 1 : 0;
  EXPECT_EQ(static_geoms, 1 + s.model.static_spheres.size());
  // The bodies start where numen's do (nested relative poses compose back to the world).
  std::vector<core::BodyState> states;
  engine.read_states(states);
  for (int b = 0; b < s.model.num_bodies(); ++b) {
    const core::Pose& p = s.model.bodies[static_cast<std::size_t>(b)].initial_pose;
    EXPECT_LT((states[static_cast<std::size_t>(b)].position - p.position).norm(), 1e-12);
    EXPECT_GT(
        std::abs(states[static_cast<std::size_t>(b)].orientation.dot(p.orientation.normalized())),
        1.0 - 1e-12);
  }
}

TEST(MjcfTranslation, TheConstructionGameHasTwelveFreeBlocksAndAWeldPerHeldBlock) {
  const peer::PeerScene s =
      peer::load_recorded_scene("construction", "sim/scenes/construction.toml", -1.0);
  const std::vector<int> held = peer::held_bodies(s.inputs);
  ASSERT_EQ(held.size(), 2u);  // "held", then "loose_1" after the tool switch
  peer::MujocoEngine engine(s.model, peer::Drive::kMocapWeld, held);
  const mjModel* m = engine.mj_model();
  EXPECT_EQ(m->nbody, 1 + 12 + 2);
  EXPECT_EQ(m->njnt, 12);
  for (int j = 0; j < m->njnt; ++j) EXPECT_EQ(m->jnt_type[j], mjJNT_FREE);
  EXPECT_EQ(m->neq, 2);
  expect_same_bodies(s.model, engine);
  EXPECT_DOUBLE_EQ(m->opt.timestep, s.model.dt);
  EXPECT_DOUBLE_EQ(m->opt.gravity[2], s.model.gravity.z());
  // The PD variant has no mocap body and no weld.
  peer::MujocoEngine pd(s.model, peer::Drive::kPdForce, held);
  EXPECT_EQ(pd.mj_model()->nmocap, 0);
  EXPECT_EQ(pd.mj_model()->neq, 0);
}

TEST(MjcfTranslation, ContactsTakeTheBodyGeomsMappedParameters) {
  // The wall: once the ball touches it, MuJoCo's contact carries the body geom's solref/solimp
  // (priority 1), not a mix with the plane's defaults.
  const peer::PeerScene s = peer::make_wall_scene(0.4);
  peer::MujocoEngine engine(s.model, peer::Drive::kPdForce, {});
  for (const peer::StepInput& in : s.inputs) {
    engine.apply(in);
    engine.step();
  }
  ASSERT_GE(engine.num_contacts(), 1);
  const mjContact& c = engine.mj_data()->contact[0];
  const mjModel* m = engine.mj_model();
  const int body_geom = m->body_geomadr[engine.body_id(0)];
  EXPECT_DOUBLE_EQ(c.solref[0], m->geom_solref[2 * body_geom]);
  EXPECT_DOUBLE_EQ(c.solref[1], m->geom_solref[2 * body_geom + 1]);
  EXPECT_DOUBLE_EQ(c.solimp[0], m->geom_solimp[5 * body_geom]);
  EXPECT_LT(c.solref[0], 0.0);  // the direct (−K, −B) form of the mapping
}

TEST(MjcfTranslation, RefusesATrocarJointByName) {
  core::Model m;
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel b;
  b.name = "shaft";
  b.mass = 0.1;
  m.bodies = {b};
  core::JointModel j;
  j.name = "port";
  j.type = core::JointType::kTrocar;
  j.parent = -1;
  j.child = 0;
  m.joints = {j};
  ASSERT_EQ(core::finalize_model(m), "");
  try {
    peer::translate_to_mjcf(m, peer::Drive::kMocapWeld, {0});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'port'"), std::string::npos) << e.what();
  }
}
