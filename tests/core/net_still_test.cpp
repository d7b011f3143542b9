// Still neighbourhoods of an organ's net (core/src/net/net_still.cpp, the force pass of
// core/src/net/net_forces.cpp; docs/organs.md, "Resting nodes"): a node whose state and every
// neighbour's are those of the last force pass takes its force and energy from that pass, and
// the springs between such nodes are skipped — the same forces, energies, spring lengths and
// directions, and so the same steps, to the bit as computing them; a node moved by the caller
// is not still, nor are its neighbours; without the model's spring lists no node rests or is
// still; the nets that cannot rest have no still node.

#include "net/net_still.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <functional>
#include <vector>

#include "scratch/data_scratch.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "organ_indentation.hpp"

namespace numen {
namespace {

namespace still_organ = numen::test::organ;

/// The shipped organ turned and moved as the default scene's (rounding-size tie stretches), a
/// 2.5 mm sphere imposed (kDirect) 30 mm below it along the organ's z, nodes resting at the
/// default rest speed (`rest_speed` 0: off, the net cannot rest).
struct StillOrgan {
  core::Model model;
  core::Vec3 dir;      ///< The sphere's path (world).
  double touch = 0.0;  ///< Distance along dir to its first touch (m).
};

StillOrgan still_test_organ(double rest_speed) {
  StillOrgan o;
  o.model =
      still_organ::organ_model(still_organ::shipped_organ_mesh(), still_organ::OrganParams{}, 1e-3,
                               core::CouplingMode::kDirect, 0.0025, core::Vec3(0, 0, -0.03));
  o.model.nets[0].rest_speed = rest_speed;
  o.model.solver.tolerance = 1e-4;
  const core::Pose place{
      core::Vec3(0.01, -0.02, 0.035),
      core::Quat(Eigen::AngleAxisd(0.6, core::Vec3(0.3, -1.0, 0.2).normalized()))};
  o.model.bodies[0].initial_pose = place;
  o.model.bodies[1].initial_pose.position =
      place.position + place.orientation * core::Vec3(0, 0, -0.03);
  o.dir = place.orientation * core::Vec3::UnitZ();
  o.touch =
      still_organ::first_touch(o.model, o.model.bodies[1].initial_pose.position, o.dir, 0.0025);
  return o;
}

/// The sphere's target at step k: 5 mm short of the organ for the first 300 steps (the organ
/// comes to rest), then `press` past its first touch over 300 steps, then held there.
core::Vec3 still_target(const StillOrgan& o, int k, double press) {
  const double s = k < 300 ? -0.005 : std::min(1.0, (k - 300) / 300.0) * (o.touch + press);
  return o.model.bodies[1].initial_pose.position + s * o.dir;
}

/// Whether two arrays of doubles are the same bit for bit.
template <class T>
bool still_same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

/// Steps `o` twice side by side: `d` as the step runs, `full` with the stored states dropped
/// before each step (no node still: every force computed). Calls `between(d, full, k)` before
/// step k and checks after it that the two agree to the bit; returns the still nodes' count
/// summed over the steps.
long still_against_full(const StillOrgan& o, double press, int steps,
                        const std::function<void(core::Data&, core::Data&, int)>& between = {}) {
  core::Data d = core::make_data(o.model);
  core::Data full = core::make_data(o.model);
  long still = 0;
  for (int k = 0; k < steps; ++k) {
    for (core::Data* x : {&d, &full}) {
      x->target.position = still_target(o, k, press);
      x->target.orientation = core::Quat::Identity();
    }
    if (between) between(d, full, k);
    full.scratch->net.pass_stored = false;
    core::step(o.model, d);
    core::step(o.model, full);
    const core::NetScratch& a = d.scratch->net;
    const core::NetScratch& b = full.scratch->net;
    for (const std::uint8_t f : a.still_flags) still += f == 0 ? 1 : 0;
    std::vector<core::Vec3> pa, pb, va, vb;
    for (const core::NodeState& n : d.nodes) pa.push_back(n.position), va.push_back(n.velocity);
    for (const core::NodeState& n : full.nodes) pb.push_back(n.position), vb.push_back(n.velocity);
    const bool same =
        still_same_bits(a.force, b.force) && still_same_bits(a.spring_length, b.spring_length) &&
        still_same_bits(a.sweep_springs.direction_x, b.sweep_springs.direction_x) &&
        still_same_bits(a.sweep_springs.direction_y, b.sweep_springs.direction_y) &&
        still_same_bits(a.sweep_springs.direction_z, b.sweep_springs.direction_z) &&
        std::memcmp(&d.nets[0].start_energy, &full.nets[0].start_energy, sizeof(double)) == 0 &&
        still_same_bits(pa, pb) && still_same_bits(va, vb) &&
        d.nets[0].resting_nodes == full.nets[0].resting_nodes;
    EXPECT_TRUE(same) << "step " << k << ": energy " << d.nets[0].start_energy << " against "
                      << full.nets[0].start_energy;
    if (!same) break;
  }
  return still;
}

}  // namespace

TEST(NetStill, APressedOrgansStepsAreThoseThatComputeEveryForceToTheBit) {
  // At rest, then pressed 3 mm and held: the nodes the sphere reaches wake, most of the organ
  // stays still. Every step's forces, energy, spring lengths and directions, and the nodes'
  // states, are those of the force pass that computes every node (a still node skipping its
  // springs to a later node that is not still would leave that node without their force).
  const StillOrgan o = still_test_organ(core::NetSettings{}.rest_speed);
  const int steps = 900;
  const long still = still_against_full(o, 0.003, steps);
  // The reuse ran: on average more than half the organ still a step.
  EXPECT_GT(still, static_cast<long>(steps) * 1002 / 2);
}

TEST(NetStill, ANodeTheCallerMovesIsNotStillNorAreItsNeighbours) {
  // The organ at rest; before step 250 the caller moves one node by 1 µm (in both runs). That
  // node's and its neighbours' forces are computed again (the steps stay those of the full
  // pass to the bit), and a node far from it stays still.
  const StillOrgan o = still_test_organ(core::NetSettings{}.rest_speed);
  const int moved = 500;
  still_against_full(o, 0.003, 260, [&](core::Data& a, core::Data& b, int k) {
    if (k != 250) return;
    a.nodes[moved].position.x() += 1e-6;
    b.nodes[moved].position.x() += 1e-6;
  });
  // The flags of that step, on a run of its own.
  core::Data e = core::make_data(o.model);
  for (int k = 0; k < 251; ++k) {
    e.target.position = still_target(o, k, 0.003);
    e.target.orientation = core::Quat::Identity();
    if (k == 250) e.nodes[moved].position.x() += 1e-6;
    core::step(o.model, e);
    if (k == 249) {  // at rest before the move: most of the organ still
      long still = 0;
      for (const std::uint8_t f : e.scratch->net.still_flags) still += f == 0 ? 1 : 0;
      EXPECT_GT(still, 900);
    }
  }
  const std::vector<std::uint8_t>& f = e.scratch->net.still_flags;
  EXPECT_EQ(f[moved], core::detail::kStateChangedBit | core::detail::kNearChangeBit);
  int neighbours = 0;
  for (const core::NetSpring& sp : o.model.net_springs) {
    if (sp.node_a != moved && sp.node_b != moved) continue;
    const int other = sp.node_a == moved ? sp.node_b : sp.node_a;
    EXPECT_TRUE(f[static_cast<std::size_t>(other)] & core::detail::kNearChangeBit) << other;
    ++neighbours;
  }
  EXPECT_GE(neighbours, 3);
  // A node with no spring to the moved node or its neighbours is still.
  long still = 0;
  for (const std::uint8_t x : f) still += x == 0 ? 1 : 0;
  EXPECT_GT(still, 900);
}

TEST(NetStill, WithoutTheModelsSpringListsNoNodeRestsNorIsStill) {
  // The passes over a node's neighbours read Model::node_springs (finalize_model() makes them);
  // a model whose lists are gone (edited after finalize_model()) has no resting node and no
  // still one, and steps as the organ with rest_speed 0 does, to the bit.
  const StillOrgan o = still_test_organ(core::NetSettings{}.rest_speed);
  core::Model bare = o.model;
  bare.node_spring_begin.clear();
  bare.node_springs.clear();
  const StillOrgan off = still_test_organ(0.0);
  core::Data a = core::make_data(bare);
  core::Data b = core::make_data(off.model);
  for (int k = 0; k < 400; ++k) {
    for (core::Data* x : {&a, &b}) {
      x->target.position = still_target(o, k, 0.003);
      x->target.orientation = core::Quat::Identity();
    }
    core::step(bare, a);
    core::step(off.model, b);
    ASSERT_EQ(a.nets[0].resting_nodes, 0) << k;
    for (const std::uint8_t f : a.scratch->net.still_flags) ASSERT_NE(f, 0) << k;
    ASSERT_EQ(std::memcmp(&a.nets[0].start_energy, &b.nets[0].start_energy, sizeof(double)), 0)
        << k;
  }
  for (std::size_t i = 0; i < a.nodes.size(); ++i) {
    ASSERT_EQ(
        std::memcmp(a.nodes[i].position.data(), b.nodes[i].position.data(), 3 * sizeof(double)), 0)
        << i;
  }
}

TEST(NetStill, ANetThatCannotRestHasNoStillNode) {
  // rest_speed 0: the net keeps every node in the solve (net_can_rest() false), and none is
  // still, even where its nodes keep their states (the organ at rest without the velocity floor
  // still chases its rounding).
  const StillOrgan o = still_test_organ(0.0);
  core::Data d = core::make_data(o.model);
  for (int k = 0; k < 50; ++k) {
    d.target.position = still_target(o, k, 0.003);
    d.target.orientation = core::Quat::Identity();
    core::step(o.model, d);
  }
  for (const std::uint8_t f : d.scratch->net.still_flags)
    ASSERT_EQ(f, core::detail::kStateChangedBit | core::detail::kNearChangeBit);
  EXPECT_FALSE(core::detail::mark_still_nodes(o.model, d));
}

}  // namespace numen
