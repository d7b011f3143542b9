// Tests of core/articulation: the elimination order of the articulation
// forest (build_articulation_topology: order property, trees, errors naming
// the joint). The KKT solve: articulation_solve_test.cpp.
#include "numen/core/articulation.hpp"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "articulation_forests.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"

namespace core = numen::core;
using namespace numen::test::articulation_forests;

// ---------------------------------------------------------------- topology --

TEST(ArticulationTopology, BodiesWithoutJointsAreOneNodeTrees) {
  core::Model m = bodies_only(3);
  ASSERT_EQ(core::build_articulation_topology(m), "");
  const core::ArticulationTopology& t = m.articulation;
  ASSERT_EQ(t.nodes.size(), 3u);
  EXPECT_EQ(t.num_trees, 3);
  EXPECT_EQ(t.num_rows, 0);
  for (int b = 0; b < 3; ++b) {
    const core::ArticulationNode& n = t.nodes[static_cast<std::size_t>(t.body_node[static_cast<std::size_t>(b)])];
    EXPECT_FALSE(n.is_joint);
    EXPECT_EQ(n.index, b);
    EXPECT_EQ(n.parent, -1);
    EXPECT_EQ(t.body_tree[static_cast<std::size_t>(b)], b);
  }
}

TEST(ArticulationTopology, ChainHungFromTheWorldIsRootedAtItsWorldJoint) {
  // world ← trocar ← tube ← jaw_a, tube ← jaw_b; a separate free body.
  core::Model m = bodies_only(4);
  m.joints = {joint("jaw_b", 1, 3), joint("trocar", -1, 1, core::JointType::kTrocar),
              joint("jaw_a", 1, 0, core::JointType::kRevolute, true)};
  ASSERT_EQ(core::build_articulation_topology(m), "");
  const core::ArticulationTopology& t = m.articulation;
  ASSERT_EQ(t.nodes.size(), 7u);
  EXPECT_EQ(t.num_rows, 5 + 2 + 6);
  EXPECT_EQ(t.num_trees, 2);
  EXPECT_EQ(t.body_tree, (std::vector<int>{0, 0, 1, 0}));
  // Leaves first: jaw_b's subtree (lower joint index), then jaw_a's, the tube,
  // the trocar as the tree's root; then the free body.
  const std::vector<std::pair<bool, int>> expected = {{false, 3}, {true, 0}, {false, 0}, {true, 2},
                                                      {false, 1}, {true, 1}, {false, 2}};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(t.nodes[i].is_joint, expected[i].first) << i;
    EXPECT_EQ(t.nodes[i].index, expected[i].second) << i;
  }
  EXPECT_EQ(t.nodes[5].parent, -1);
  EXPECT_EQ(t.nodes[6].parent, -1);
  EXPECT_EQ(t.nodes[4].parent, 5);
  EXPECT_EQ(t.nodes[0].parent, 1);
  EXPECT_EQ(t.nodes[1].parent, 4);
}

TEST(ArticulationTopology, EveryNodePrecedesItsParentOnRandomForests) {
  Rng rng(11);
  for (Shape shape : {Shape::kChain, Shape::kStar, Shape::kRandom}) {
    for (int trial = 0; trial < 40; ++trial) {
      const int nb = uniform_int(rng, 1, 50);
      core::Model m = random_forest(rng, shape, nb);
      ASSERT_EQ(core::build_articulation_topology(m), "") << name(shape);
      const core::ArticulationTopology& t = m.articulation;
      const int nj = m.num_joints();
      ASSERT_EQ(static_cast<int>(t.nodes.size()), nb + nj);
      std::vector<int> seen_body(static_cast<std::size_t>(nb), 0), seen_joint(static_cast<std::size_t>(nj), 0);
      int rows = 0;
      for (std::size_t i = 0; i < t.nodes.size(); ++i) {
        const core::ArticulationNode& n = t.nodes[i];
        EXPECT_TRUE(n.parent == -1 || n.parent > static_cast<int>(i)) << "node " << i;
        const auto k = static_cast<std::size_t>(n.index);
        if (n.is_joint) {
          ++seen_joint[k];
          EXPECT_EQ(t.joint_node[k], static_cast<int>(i));
          const core::JointModel& j = m.joints[k];
          rows += j.num_rows;
          // A joint sits below its parent body (root if hung from the world)…
          EXPECT_EQ(n.parent, j.parent >= 0 ? t.body_node[static_cast<std::size_t>(j.parent)] : -1);
          // …and above its child, in the same tree.
          EXPECT_EQ(t.nodes[static_cast<std::size_t>(t.body_node[static_cast<std::size_t>(j.child)])].parent,
                    static_cast<int>(i));
          if (j.parent >= 0) {
            EXPECT_EQ(t.body_tree[static_cast<std::size_t>(j.parent)],
                      t.body_tree[static_cast<std::size_t>(j.child)]);
          }
        } else {
          ++seen_body[k];
          EXPECT_EQ(t.body_node[k], static_cast<int>(i));
          if (n.parent >= 0) {
            EXPECT_TRUE(t.nodes[static_cast<std::size_t>(n.parent)].is_joint);
          }
        }
      }
      EXPECT_EQ(rows, t.num_rows);
      for (int v : seen_body) EXPECT_EQ(v, 1);
      for (int v : seen_joint) EXPECT_EQ(v, 1);
      // Tree ids: 0..num_trees-1, first seen in body order; one root per tree.
      int next = 0;
      for (int b = 0; b < nb; ++b) {
        const int id = t.body_tree[static_cast<std::size_t>(b)];
        ASSERT_TRUE(id >= 0 && id <= next) << "body " << b;
        if (id == next) ++next;
      }
      EXPECT_EQ(next, t.num_trees);
      std::vector<int> roots(static_cast<std::size_t>(t.num_trees), 0);
      for (const core::ArticulationNode& n : t.nodes)
        if (n.parent < 0) {
          const int body = n.is_joint ? m.joints[static_cast<std::size_t>(n.index)].child : n.index;
          ++roots[static_cast<std::size_t>(t.body_tree[static_cast<std::size_t>(body)])];
        }
      for (int r : roots) EXPECT_EQ(r, 1);
      // Nodes of one tree are contiguous (trees in id order).
      int last_tree = -1;
      for (const core::ArticulationNode& n : t.nodes) {
        const int body = n.is_joint ? m.joints[static_cast<std::size_t>(n.index)].child : n.index;
        const int id = t.body_tree[static_cast<std::size_t>(body)];
        EXPECT_TRUE(id == last_tree || id == last_tree + 1);
        last_tree = id;
      }
      // Deterministic.
      core::Model again = m;
      ASSERT_EQ(core::build_articulation_topology(again), "");
      for (std::size_t i = 0; i < t.nodes.size(); ++i) {
        EXPECT_EQ(again.articulation.nodes[i].index, t.nodes[i].index);
        EXPECT_EQ(again.articulation.nodes[i].is_joint, t.nodes[i].is_joint);
        EXPECT_EQ(again.articulation.nodes[i].parent, t.nodes[i].parent);
      }
    }
  }
}

TEST(ArticulationTopology, ErrorsNameTheJoint) {
  auto error = [](int nb, std::vector<core::JointModel> joints) {
    core::Model m = bodies_only(nb);
    m.joints = std::move(joints);
    return core::build_articulation_topology(m);
  };
  auto expect_error = [](const std::string& e, const std::string& who, const std::string& what) {
    EXPECT_NE(e.find(who), std::string::npos) << e;
    EXPECT_NE(e.find(what), std::string::npos) << e;
  };
  expect_error(error(2, {joint("a", 0, 1), joint("bad", 0, 2)}), "joint 'bad'", "out of range");
  expect_error(error(2, {joint("bad", -1, -1)}), "joint 'bad'", "out of range");
  expect_error(error(2, {joint("bad", 5, 1)}), "joint 'bad'", "out of range");
  expect_error(error(2, {joint("bad", -2, 1)}), "joint 'bad'", "out of range");
  expect_error(error(2, {joint("self", 1, 1)}), "joint 'self'", "same body");
  expect_error(error(3, {joint("first", 0, 2), joint("second", 1, 2)}), "joint 'second'",
               "already the child of joint 'first'");
  expect_error(error(3, {joint("w", -1, 2), joint("second", 1, 2)}), "joint 'second'",
               "already the child");
  expect_error(error(2, {joint("ab", 0, 1), joint("ba", 1, 0)}), "joint 'ba'", "cycle");
  expect_error(error(4, {joint("a", 0, 1), joint("b", 1, 2), joint("c", 2, 0), joint("d", 2, 3)}),
               "joint 'c'", "cycle");
  // Two world joints in one tree: only its root has no parent joint, so the
  // second one always makes a body the child of two joints.
  const std::string two_world = error(3, {joint("ground1", -1, 0), joint("a", 0, 1),
                                          joint("b", 0, 2), joint("ground2", -1, 2)});
  expect_error(two_world, "joint 'ground2'", "already the child of joint 'b'");
  expect_error(two_world, "joint 'ground2'", "loop through the world");
  expect_error(error(2, {joint("ground1", -1, 0), joint("ground2", -1, 0), joint("a", 0, 1)}),
               "joint 'ground2'", "loop through the world");
  core::JointModel ps = joint("ball", 0, 1, core::JointType::kSpherical);
  ps.prescribed = true;
  ps.num_rows = 3;
  expect_error(error(2, {ps}), "joint 'ball'", "prescribed");
  core::JointModel nr = joint("norows", 0, 1);
  nr.num_rows = 0;
  expect_error(error(2, {nr}), "joint 'norows'", "num_rows");
  // Two world joints in different trees are fine.
  EXPECT_EQ(error(2, {joint("g0", -1, 0), joint("g1", -1, 1)}), "");
}

TEST(ArticulationTopology, FinalizeModelBuildsIt) {
  core::Model m = bodies_only(2);
  m.material_pairs = {core::MaterialPair{}};
  m.joints = {joint("hinge", 0, 1)};
  m.joints[0].num_rows = 0;  // derived by finalize_model()
  ASSERT_EQ(core::finalize_model(m), "");
  EXPECT_EQ(m.articulation.num_rows, 5);
  EXPECT_EQ(m.articulation.num_trees, 1);
  m.joints.push_back(joint("loop", 1, 0));
  EXPECT_NE(core::finalize_model(m).find("joint 'loop'"), std::string::npos);
}
