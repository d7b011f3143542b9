// Tests of core/data_size: the footprint by buffer group is what make_data()
// asked the allocator for, and a scene allocates nothing for what it lacks.
#include "numen/core/data_size.hpp"

#include <cstring>
#include <string>

#include <gtest/gtest.h>

#include "alloc_counter.hpp"
#include "build_features.hpp"
#include "lean_scenes.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_material.hpp"
#include "octahedron_net.hpp"
#include "thread_scenes.hpp"

namespace core = numen::core;
using numen::test::LeanPart;
using numen::test::make_lean_model;

namespace {

std::size_t group(const core::DataFootprint& f, const char* name) {
  for (const core::BufferGroupBytes& g : f.groups)
    if (std::strcmp(g.group, name) == 0) return g.heap_bytes;
  ADD_FAILURE() << "no group " << name;
  return 0;
}

/// Bytes the allocator was asked for by make_data(m), and the Data.
std::int64_t make_data_bytes(const core::Model& m, core::DataFootprint& footprint) {
  const std::int64_t before = numen::test::allocated_bytes();
  const core::Data d = core::make_data(m);
  const std::int64_t bytes = numen::test::allocated_bytes() - before;
  footprint = core::data_footprint(d);
  return bytes;
}

}  // namespace

TEST(DataSize, FootprintIsExactlyWhatMakeDataAllocatedWithoutNets) {
  for (LeanPart part : numen::test::lean_parts()) {
    if (part == LeanPart::kNet) continue;  // below
    const core::Model m = make_lean_model(part);
    core::DataFootprint f;
    const std::int64_t bytes = make_data_bytes(m, f);
    EXPECT_GT(bytes, 0);
    EXPECT_EQ(static_cast<std::size_t>(bytes), f.heap_bytes()) << static_cast<int>(part);
    EXPECT_EQ(f.sizeof_data, sizeof(core::Data));
  }
}

TEST(DataSize, FootprintIsExactlyWhatMakeDataAllocatedWithAThread) {
  // A 200-segment thread: its state, its banded solve's and its terms' buffers, counted in
  // "needles and threads"; nothing else of the Data's grows for it.
  core::ThreadModel t;
  t.segments = 200;
  const core::Model m = numen::test::thread_model(t);
  core::DataFootprint f;
  const std::int64_t bytes = make_data_bytes(m, f);
  EXPECT_EQ(static_cast<std::size_t>(bytes), f.heap_bytes());
  EXPECT_GT(group(f, "needles and threads"), 201u * 3u * sizeof(core::Mat3)) << "its band at least";
  EXPECT_EQ(group(f, "nets"), 0u);
}

TEST(DataSize, FootprintCoversTheNetsBuffers) {
  NUMEN_REQUIRE_DEFORMABLE();
  // NetScratch::resize() sorts the springs with a temporary array: make_data()
  // asks for exactly that array (num_nodes ints) more than it keeps.
  const core::Model m = make_lean_model(LeanPart::kNet);
  core::DataFootprint f;
  const std::int64_t bytes = make_data_bytes(m, f);
  const std::size_t temporary = static_cast<std::size_t>(m.num_nodes()) * sizeof(std::int32_t);
  EXPECT_EQ(static_cast<std::size_t>(bytes), f.heap_bytes() + temporary);
}

// A net given by its material has the tissue contact's load patch buffers besides (NetScratch::
// patch_nodes, patch_weights): counted too. A regular octahedron with a node at its centre
// (tests/support/octahedron_net.hpp).
TEST(DataSize, FootprintCoversAMaterialNetsLoadPatch) {
  NUMEN_REQUIRE_DEFORMABLE();
  std::string err;
  core::Model m =
      numen::test::octahedron_material_model(core::NetMaterial{10e3, 0.45, 1000.0, 1e-3, 0.03, 0.0}, nullptr, &err);
  ASSERT_EQ(err, "");
  m.material_names = {"tissue"};
  m.material_pairs.assign(1, core::MaterialPair{2e4, 10.0, 0.0});
  m.initial_held_body = -1;  // the organ alone: no device
  ASSERT_EQ(core::finalize_model(m), "");
  core::DataFootprint f;
  const std::int64_t bytes = make_data_bytes(m, f);
  const std::size_t temporary = static_cast<std::size_t>(m.num_nodes()) * sizeof(std::int32_t);
  EXPECT_EQ(static_cast<std::size_t>(bytes), f.heap_bytes() + temporary);
}

TEST(DataSize, RigidOnlySceneAllocatesNoJointNetOrContactBuffer) {
  core::DataFootprint rigid;
  make_data_bytes(make_lean_model(LeanPart::kNone), rigid);
  EXPECT_EQ(group(rigid, "joints"), 0u);
  EXPECT_EQ(group(rigid, "nets"), 0u);
  EXPECT_EQ(group(rigid, "contact solver scratch"), 0u);
  EXPECT_GT(group(rigid, "bodies"), 0u);
  EXPECT_GT(group(rigid, "body solver scratch"), 0u);
}

TEST(DataSize, EachOptionalPartAllocatesOnlyItsOwnGroup) {
  NUMEN_REQUIRE_ARTICULATION();
  NUMEN_REQUIRE_DEFORMABLE();
  core::DataFootprint rigid, obstacle, joint, net;
  const std::int64_t b0 = make_data_bytes(make_lean_model(LeanPart::kNone), rigid);
  const std::int64_t b1 = make_data_bytes(make_lean_model(LeanPart::kObstacle), obstacle);
  make_data_bytes(make_lean_model(LeanPart::kJoint), joint);
  make_data_bytes(make_lean_model(LeanPart::kNet), net);

  // An obstacle: contact scratch (kMaxContacts terms), nothing for joints or nets.
  EXPECT_GT(group(obstacle, "contact solver scratch"), 0u);
  EXPECT_EQ(group(obstacle, "joints"), 0u);
  EXPECT_EQ(group(obstacle, "nets"), 0u);
  EXPECT_EQ(b1 - b0, static_cast<std::int64_t>(group(obstacle, "contact solver scratch") +
                                                 group(obstacle, "collision scratch") -
                                                 group(rigid, "collision scratch")));
  // A joint (to a second body of the same articulation): joint buffers, no
  // contact scratch (joined bodies never collide), nothing for nets.
  EXPECT_GT(group(joint, "joints"), 0u);
  EXPECT_EQ(group(joint, "contact solver scratch"), 0u);
  EXPECT_EQ(group(joint, "nets"), 0u);
  // A net: net buffers; its node contacts against the body need no rigid
  // contact scratch; nothing for joints.
  EXPECT_GT(group(net, "nets"), 0u);
  EXPECT_EQ(group(net, "joints"), 0u);
  EXPECT_EQ(group(net, "contact solver scratch"), 0u);
}

TEST(DataSize, ModelFootprintCountsItsArrays) {
  NUMEN_REQUIRE_DEFORMABLE();
  const core::Model rigid = make_lean_model(LeanPart::kNone);
  const core::Model net = make_lean_model(LeanPart::kNet);
  const core::ModelFootprint fr = core::model_footprint(rigid);
  const core::ModelFootprint fn = core::model_footprint(net);
  EXPECT_EQ(fr.sizeof_model, sizeof(core::Model));
  EXPECT_EQ(fr.groups[3].heap_bytes, 0u);  // nets
  EXPECT_EQ(fr.groups[2].heap_bytes,
            rigid.articulation.nodes.capacity() * sizeof(core::ArticulationNode) +
                (rigid.articulation.body_node.capacity() + rigid.articulation.body_tree.capacity()) *
                    sizeof(int));  // one-node trees, no joints
  EXPECT_GE(fn.groups[3].heap_bytes,
            static_cast<std::size_t>(net.num_nodes()) *
                (sizeof(core::Vec3) + 2 * sizeof(double) + sizeof(int)));
  EXPECT_EQ(fr.groups[4].heap_bytes, 0u);  // meshes: none
  EXPECT_EQ(fn.heap_bytes(), fn.groups[0].heap_bytes + fn.groups[1].heap_bytes +
                                 fn.groups[2].heap_bytes + fn.groups[3].heap_bytes +
                                 fn.groups[4].heap_bytes);
}
