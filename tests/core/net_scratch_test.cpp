// Tests of core/net_scratch: the sizing of the nets' scratch by
// NetScratch::resize() — the SSOR sweep order (reverse Cuthill–McKee per net:
// a permutation that keeps each net's range and narrows the spring graph's
// bandwidth), the springs grouped by their earlier node in that order with
// their constants copied, and the structure-of-arrays view of the springs.
#include "scratch/net_scratch.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "deformable_ball.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_model.hpp"
#include "scratch/data_scratch.hpp"
#include "net_states.hpp"

namespace core = numen::core;
using core::Vec3;

namespace {

using numen::test::at;

/// Two bodies, each carrying a net: a 642-node icosphere on body 0 and a
/// capsule net on body 1 (two nets, so that the per-net ranges are checked).
core::Model two_nets() {
  core::Model m;
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  for (int b = 0; b < 2; ++b) {
    core::BodyModel body;
    body.name = b == 0 ? "ball core" : "probe core";
    body.mass = 0.05;
    body.inertia_body = core::Mat3::Identity() * 1e-5;
    body.initial_pose.position = Vec3(0.1 * b, 0.0, 0.05);
    m.bodies.push_back(body);
  }
  core::NetSettings s = numen::test::ball_net_settings();
  EXPECT_EQ(core::add_net(m, core::make_icosphere(0.03, 3), s), "");
  s.name = "probe";
  s.body = 1;
  s.bending_stiffness = 5.0;  // distinct constants, to check the copies
  EXPECT_EQ(core::add_net(m, core::make_capsule(0.006, 0.02, 12, 4, 6), s), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// Largest |position(a) − position(b)| over a net's springs: the bandwidth
/// (in nodes) of its spring graph's adjacency under that numbering.
int bandwidth(const core::Model& m, const core::NetModel& net, const std::vector<int>& position) {
  int w = 0;
  for (int e = net.spring_begin; e < net.spring_begin + net.structural_count + net.bending_count;
       ++e) {
    const core::NetSpring& sp = m.net_springs[at(e)];
    w = std::max(w, std::abs(position[at(sp.node_a)] - position[at(sp.node_b)]));
  }
  return w;
}

}  // namespace

TEST(NetScratch, SweepOrderIsAPermutationThatKeepsEachNetsRange) {
  const core::Model m = two_nets();
  const core::Data d = core::make_data(m);
  const core::NetScratch& ns = d.scratch->net;
  ASSERT_EQ(m.node_sweep_order.size(), at(m.num_nodes()));
  ASSERT_EQ(ns.sweep_position.size(), at(m.num_nodes()));
  ASSERT_EQ(ns.sweep_nodes.size(), at(m.num_nodes()));
  EXPECT_EQ(ns.spring_block.size(), at(m.num_nodes()));  // per node
  EXPECT_EQ(ns.tie_sums.size(), m.nets.size());          // per net
  std::vector<int> seen(at(m.num_nodes()), 0);
  for (const core::NetModel& net : m.nets) {
    for (int p = net.node_begin; p < net.node_begin + net.node_count; ++p) {
      const int node = m.node_sweep_order[at(p)];
      ASSERT_GE(node, net.node_begin) << net.name << " position " << p;
      ASSERT_LT(node, net.node_begin + net.node_count) << net.name << " position " << p;
      ++seen[at(node)];
      EXPECT_EQ(ns.sweep_position[at(node)], p) << "node " << node;
    }
  }
  for (int i = 0; i < m.num_nodes(); ++i) EXPECT_EQ(seen[at(i)], 1) << "node " << i;
}

TEST(NetScratch, ReverseCuthillMcKeeNarrowsTheSpringGraphsBandwidth) {
  // The mesh's vertex order interleaves the icosphere's refinement levels (a
  // new vertex per edge, appended level by level): neighbours end up hundreds
  // of indices apart. The level-set order keeps them within a few rings.
  const core::Model m = two_nets();
  const core::Data d = core::make_data(m);
  std::vector<int> identity(at(m.num_nodes()));
  for (int i = 0; i < m.num_nodes(); ++i) identity[at(i)] = i;
  const std::vector<int> position(d.scratch->net.sweep_position.begin(), d.scratch->net.sweep_position.end());
  const int vertex_order = bandwidth(m, m.nets[0], identity);
  const int sweep_order = bandwidth(m, m.nets[0], position);
  std::printf(
      "[sweep order] icosphere 642 nodes: bandwidth %d (vertex order) -> %d (sweep order)\n",
      vertex_order, sweep_order);
  EXPECT_LT(4 * sweep_order, vertex_order);  // 633 -> 81 when written
  // A spring of a level-set order joins two consecutive levels, so the
  // bandwidth is below the size of two levels; the widest level of a
  // 642-node icosphere is about its equator, 10 · 2³ = 80 nodes.
  EXPECT_LT(sweep_order, 2 * 80);
  // The capsule's rings are already in order: no worse than its vertex order.
  EXPECT_LE(bandwidth(m, m.nets[1], position), bandwidth(m, m.nets[1], identity));
}

TEST(NetScratch, SpringsAreGroupedByTheirEarlierNodeInTheSweepOrder) {
  const core::Model m = two_nets();
  const core::Data d = core::make_data(m);
  const core::NetScratch& ns = d.scratch->net;
  const std::size_t num_springs = m.net_springs.size();
  ASSERT_EQ(ns.sweep_springs.size(), num_springs);
  ASSERT_EQ(ns.spring_low_begin.size(), at(m.num_nodes()) + 1);
  EXPECT_EQ(ns.spring_low_begin.front(), 0);
  EXPECT_EQ(ns.spring_low_begin.back(), static_cast<int>(num_springs));
  std::vector<int> slot_used(num_springs, 0);
  for (std::size_t e = 0; e < num_springs; ++e) {
    const core::NetSpring& sp = m.net_springs[e];
    const auto j = at(ns.spring_slot[e]);
    ASSERT_LT(j, num_springs);
    ++slot_used[j];
    const int pa = ns.sweep_position[at(sp.node_a)], pb = ns.sweep_position[at(sp.node_b)];
    const int low = std::min(pa, pb);
    // In the group of its earlier node, pointing at the later one.
    EXPECT_GE(static_cast<int>(j), ns.spring_low_begin[at(low)]) << "spring " << e;
    EXPECT_LT(static_cast<int>(j), ns.spring_low_begin[at(low) + 1]) << "spring " << e;
    EXPECT_EQ(ns.sweep_springs.high[j], pa < pb ? sp.node_b : sp.node_a) << "spring " << e;
    EXPECT_EQ(ns.spring_constants.rest_length[j], sp.rest_length) << "spring " << e;
    EXPECT_EQ(ns.spring_constants.stiffness[j], sp.stiffness) << "spring " << e;
    EXPECT_EQ(ns.spring_constants.damping[j], sp.damping) << "spring " << e;
  }
  for (std::size_t j = 0; j < num_springs; ++j) EXPECT_EQ(slot_used[j], 1) << "slot " << j;
}

TEST(NetScratch, SweepSpringsViewReadsOneSpringAcrossTheArrays) {
  core::SweepSprings s;
  s.assign(3);
  ASSERT_EQ(s.size(), 3u);
  const core::SweepSpring fresh = s[1];
  EXPECT_EQ(fresh.direction, Vec3::UnitX());
  EXPECT_EQ(fresh.weight_axial, 0.0);
  EXPECT_EQ(fresh.weight_isotropic, 0.0);
  s.direction_x[2] = 0.0;
  s.direction_y[2] = 0.6;
  s.direction_z[2] = 0.8;
  s.weight_axial[2] = 2.5e-4;
  s.weight_isotropic[2] = 1e-5;
  s.high[2] = 7;
  const core::SweepSpring t = s[2];
  EXPECT_EQ(t.direction, Vec3(0.0, 0.6, 0.8));
  EXPECT_EQ(t.weight_axial, 2.5e-4);
  EXPECT_EQ(t.weight_isotropic, 1e-5);
  EXPECT_EQ(t.high, 7);
}

TEST(NetScratch, NoNetsNoScratch) {
  core::Model m;
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  core::BodyModel body;
  body.mass = 1.0;
  body.inertia_body = core::Mat3::Identity();
  m.bodies.push_back(body);
  ASSERT_EQ(core::finalize_model(m), "");
  const core::Data d = core::make_data(m);
  EXPECT_TRUE(m.node_sweep_order.empty());
  EXPECT_TRUE(d.scratch->net.sweep_position.empty());
  EXPECT_TRUE(d.scratch->net.sweep_nodes.empty());
  EXPECT_EQ(d.scratch->net.sweep_springs.size(), 0u);
  EXPECT_TRUE(d.scratch->net.spring_low_begin.empty());
  EXPECT_TRUE(d.scratch->net.spring_block.empty());
  EXPECT_TRUE(d.scratch->net.tie_sums.empty());
}
