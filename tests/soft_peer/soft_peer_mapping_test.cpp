/// @file soft_peer_mapping_test.cpp
/// The constants' mapping (soft_peer_mapping.hpp) in formulas and in Bullet itself: an
/// isolated anchored node steps as numen's tie, an isolated link holds a constant force at
/// the stretch of numen's spring.

#include <BulletSoftBody/btSoftBody.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "bullet_organ.hpp"
#include "numen/core/step.hpp"
#include "organ_indentation.hpp"
#include "soft_peer_mapping.hpp"

namespace numen::soft_peer {
namespace {

using core::Vec3;
using test::organ::OrganParams;

TEST(SoftPeerMapping, AnchorStepEqualsNumensTieStep) {
  for (int n : {1, 4, 10})
    for (double m : {2e-5, 7e-5, 3e-4})
      for (double dt : {1e-4, 1e-3}) {
        const AnchorMapping a = anchor_mapping(100.0, 0.17, m, dt, n);
        EXPECT_GT(a.influence, 0.0);
        EXPECT_LE(a.influence, 1.0 / (1.0 + a.hardness));
        const TieStep b = bullet_anchor_step(a.hardness, a.influence, n);
        const TieStep e = numen_tie_step(100.0, 0.17, m, dt);
        EXPECT_NEAR(b.retain, e.retain, 1e-12) << "n " << n << " m " << m << " dt " << dt;
        EXPECT_NEAR(b.pull, e.pull, 1e-12) << "n " << n << " m " << m << " dt " << dt;
      }
  EXPECT_NEAR(anchor_mapping(100.0, 0.17, 7e-5, 1e-3, 4).hardness, 0.1 / 0.17, 1e-15);
}

TEST(SoftPeerMapping, LinkFractionLeavesTheImplicitStepsShareOfAStretch) {
  const double mu = 3.5e-5, dt = 1e-3;
  for (int n : {1, 4, 10}) {
    const double s = link_stiffness_fraction(200.0, mu, dt, n);
    EXPECT_NEAR(std::pow(1.0 - s, n), mu / (mu + 200.0 * dt * dt), 1e-12);
    EXPECT_GT(s, 0.0);
    EXPECT_LT(s, 1.0);
  }
  EXPECT_EQ(link_stiffness_fraction(0.0, mu, dt, 4), 0.0);
  // Stiffer spring, larger fraction; more iterations, smaller fraction each.
  EXPECT_GT(link_stiffness_fraction(400.0, mu, dt, 4), link_stiffness_fraction(200.0, mu, dt, 4));
  EXPECT_LT(link_stiffness_fraction(200.0, mu, dt, 8), link_stiffness_fraction(200.0, mu, dt, 4));
}

TEST(SoftPeerMapping, RefusesConstantsOutOfRange) {
  EXPECT_THROW(anchor_mapping(100.0, 0.0, 7e-5, 1e-3, 4), std::invalid_argument);  // undamped tie
  EXPECT_THROW(anchor_mapping(0.0, 0.17, 7e-5, 1e-3, 4), std::invalid_argument);
  EXPECT_THROW(anchor_mapping(100.0, 0.17, 7e-5, 1e-3, 0), std::invalid_argument);
  EXPECT_THROW(link_stiffness_fraction(-1.0, 3.5e-5, 1e-3, 4), std::invalid_argument);
  EXPECT_THROW(link_stiffness_fraction(200.0, 0.0, 1e-3, 4), std::invalid_argument);
}

/// A 2 × 2-node patch (two triangles, 10 mm) with `p`'s constants; the tool 1 m away.
core::Model patch_model(const OrganParams& p) {
  return test::organ::organ_model(test::organ::flat_patch(1, 0.01), p, 1e-3, core::CouplingMode::kDirect,
                                  0.0025, Vec3(0, 0, 1.0));
}

TEST(SoftPeerMapping, AnIsolatedAnchoredNodeStepsInBulletAsInNumen) {
  // Springs of zero stiffness (Bullet: kLST 0, links that do nothing): every node is alone
  // with its tie. Each node displaced and moving; one step of each engine.
  OrganParams p;
  p.k = p.k_bend = 0.0;
  p.gamma = p.gamma_bend = 0.0;
  const core::Model m = patch_model(p);
  ASSERT_EQ(m.num_nodes(), 4);
  core::Data d = core::make_data(m);
  d.target.position = Vec3(0, 0, 1.0);
  BulletOrgan b(m, BulletOptions{});
  btSoftBody* sb = b.soft_body();
  for (int i = 0; i < 4; ++i) {
    const Vec3 u(1e-3 * (i + 1), -0.5e-3 * i, 0.7e-3), v(0.01 * i, 0.02, -0.03);
    const auto k = static_cast<std::size_t>(i);
    d.nodes[k].position = m.node_rest[k] + u;
    d.nodes[k].velocity = v;
    sb->m_nodes[i].m_x = btVector3(static_cast<btScalar>(d.nodes[k].position.x()),
                                   static_cast<btScalar>(d.nodes[k].position.y()),
                                   static_cast<btScalar>(d.nodes[k].position.z()));
    sb->m_nodes[i].m_v = btVector3(static_cast<btScalar>(v.x()), static_cast<btScalar>(v.y()),
                                   static_cast<btScalar>(v.z()));
  }
  core::step(m, d);
  ASSERT_EQ(d.status, core::kStepOk);
  b.step();
  for (int i = 0; i < 4; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Vec3 u(1e-3 * (i + 1), -0.5e-3 * i, 0.7e-3), v(0.01 * i, 0.02, -0.03);
    const TieStep e = numen_tie_step(p.k_tie, p.gamma_tie, m.node_mass[k], m.dt);
    const Vec3 expected = e.retain * v - e.pull * u / m.dt;
    EXPECT_LT((d.nodes[k].velocity - expected).norm(), 1e-4 * expected.norm()) << "numen, node " << i;
    const btVector3& bv = sb->m_nodes[i].m_v;
    EXPECT_LT((Vec3(bv.x(), bv.y(), bv.z()) - expected).norm(), 1e-4 * expected.norm())
        << "Bullet, node " << i;
  }
}

TEST(SoftPeerMapping, AnIsolatedLinkHoldsAConstantForceAtTheSpringsStretch) {
  // One triangle's link 0-1 alone: nodes 0 and 2 fixed (mass 0), no anchors,
  // the other links without stiffness; kLST from the spring's k and node 1's mass (its reduced
  // mass against a fixed node); a constant force along the link on node 1, damped to rest.
  OrganParams p;
  core::TriangleMesh tri;
  tri.vertices = {Vec3(0, 0, 0), Vec3(0.005, 0, 0), Vec3(0, 0.005, 0)};
  tri.triangles = {{0, 1, 2}};
  const core::Model m = test::organ::organ_model(tri, p, 1e-3, core::CouplingMode::kDirect, 0.0025, Vec3(0, 0, 1.0));
  BulletOrgan b(m, BulletOptions{});
  btSoftBody* sb = b.soft_body();
  const double m1 = m.node_mass[1];
  sb->setMass(0, 0);
  sb->setMass(2, 0);
  sb->m_anchors.clear();  // (an anchor on a node of mass 0 is singular)
  bool found = false;
  for (int i = 0; i < sb->m_links.size(); ++i) {
    btSoftBody::Link& l = sb->m_links[i];
    const bool is01 = (l.m_n[0] == &sb->m_nodes[0] && l.m_n[1] == &sb->m_nodes[1]) ||
                      (l.m_n[0] == &sb->m_nodes[1] && l.m_n[1] == &sb->m_nodes[0]);
    found = found || is01;
    l.m_material->m_kLST = static_cast<btScalar>(is01 ? link_stiffness_fraction(p.k, m1, m.dt, 4) : 0.0);
  }
  ASSERT_TRUE(found);
  sb->m_bUpdateRtCst = true;
  sb->m_cfg.kDP = 0.2;
  // N: 0.01 mm at 200 N/m. Small: Bullet projects a link by L (L² − L0²) / (L² + L0²), linear
  // in the stretch only while the step's predicted stretch (F dt² / m, 0.03 mm) is small against L0.
  const double force = 0.002;
  for (int k = 0; k < 3000; ++k) {
    sb->addForce(btVector3(static_cast<btScalar>(force), 0, 0), 1);
    b.step();
  }
  const double stretch = (b.node_position(1) - b.node_position(0)).norm() - 0.005;
  EXPECT_NEAR(stretch, force / p.k, 0.01 * force / p.k);
}

}  // namespace
}  // namespace numen::soft_peer
