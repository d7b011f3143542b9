// Resting nodes of an organ's net (core/src/net/net_rest.cpp; docs/organs.md, "Resting nodes"):
// the shipped organ at rest rests whole and stays exactly where it was; pressed by a sphere,
// the nodes it reaches wake, and the forces on the tool and the organ's energy are those of
// the solve with every node in it; the lists the solve runs on follow the rules; the step
// does not allocate while nodes rest and wake.

#include "net/net_rest.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "scratch/data_scratch.hpp"
#include "numen/core/step.hpp"
#include "organ_indentation.hpp"

namespace numen {
namespace {

namespace rest_organ = numen::test::organ;

/// The shipped organ placed as the default scene places it (turned and moved: its ties hold
/// rounding-size stretches) and a 2.5 mm sphere imposed (kDirect: the net solve without joints)
/// 30 mm below it along the organ's z, nodes resting at `rest_speed` (0: off; the default
/// core::NetSettings::rest_speed in the tests that rest).
core::Model rest_test_organ(double rest_speed) {
  core::Model m =
      rest_organ::organ_model(rest_organ::shipped_organ_mesh(), rest_organ::OrganParams{}, 1e-3,
                              core::CouplingMode::kDirect, 0.0025, core::Vec3(0, 0, -0.03));
  m.nets[0].rest_speed = rest_speed;
  return m;
}

const core::Pose kRestTestPlace{
    core::Vec3(0.01, -0.02, 0.035),
    core::Quat(Eigen::AngleAxisd(0.6, core::Vec3(0.3, -1.0, 0.2).normalized()))};

/// One run of rest_test_organ(): the sphere from 30 mm below the organ to `press` past its first
/// touch over the first `approach` steps, then held there, `steps` steps in all.
struct RestRun {
  std::vector<double> force;    ///< Per step: the organ's force on the tool along its path (N).
  std::vector<double> energy;   ///< Per step: NetOutput::start_energy (J).
  std::vector<int> resting;     ///< Per step: NetOutput::resting_nodes.
  std::vector<int> iterations;  ///< Per step: the solve's CG iterations.
  std::vector<core::Vec3> nodes_mid,
      nodes_end;         ///< Node positions after step steps/2 and the last.
  long allocations = 0;  ///< While stepping, after the first 20 steps.
};

/// Called after each step of run_rest_organ() with the step's index.
using RestStepObserver = std::function<void(const core::Model&, const core::Data&, int)>;

RestRun run_rest_organ(double rest_speed, double velocity_floor, double press, int approach,
                       int steps, const RestStepObserver& observe = {}) {
  core::Model m = rest_test_organ(rest_speed);
  m.solver.tolerance = 1e-4;
  m.solver.velocity_floor = velocity_floor;
  m.bodies[0].initial_pose = kRestTestPlace;
  m.bodies[1].initial_pose.position =
      kRestTestPlace.position + kRestTestPlace.orientation * core::Vec3(0, 0, -0.03);
  const core::Vec3 dir = kRestTestPlace.orientation * core::Vec3::UnitZ();
  const double touch = rest_organ::first_touch(m, m.bodies[1].initial_pose.position, dir, 0.0025);
  core::Data d = core::make_data(m);
  RestRun r;
  for (std::vector<double>* v : {&r.force, &r.energy}) v->reserve(static_cast<std::size_t>(steps));
  r.resting.reserve(static_cast<std::size_t>(steps));
  r.iterations.reserve(static_cast<std::size_t>(steps));
  r.nodes_mid.reserve(d.nodes.size());
  numen::test::AllocationGuard guard;
  long before = 0;
  for (int k = 0; k < steps; ++k) {
    if (k == 20) before = guard.count();
    d.target.position = m.bodies[1].initial_pose.position +
                        std::min(1.0, static_cast<double>(k) / approach) * (touch + press) * dir;
    d.target.orientation = core::Quat::Identity();
    core::step(m, d);
    EXPECT_EQ(d.status, core::kStepOk) << k;
    r.force.push_back(rest_organ::organ_force_on_tool(d, dir));
    r.energy.push_back(d.nets[0].start_energy);
    r.resting.push_back(d.nets[0].resting_nodes);
    r.iterations.push_back(d.solver_iterations);
    if (observe) observe(m, d, k);
    if (k + 1 == steps / 2)
      for (const core::NodeState& n : d.nodes) r.nodes_mid.push_back(n.position);
  }
  r.allocations = guard.count() - before;
  for (const core::NodeState& n : d.nodes) r.nodes_end.push_back(n.position);
  return r;
}

double rest_largest_distance(const std::vector<core::Vec3>& a, const std::vector<core::Vec3>& b) {
  double most = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) most = std::max(most, (a[i] - b[i]).norm());
  return most;
}

}  // namespace

TEST(NetRest, TheShippedOrganAtRestRestsWholeAndDoesNotCreep) {
  // The sphere stops 5 mm short of the organ. Without the velocity floor the solve chases the
  // rounding of the organ's right-hand side every step (NetOrgan.AnOrganAtRestTakesNoSolver
  // IterationAboveTheVelocityFloor); resting, the whole organ is out of the solve after
  // kRestSteps quiet steps, and held: its nodes do not move by one bit from then on, and stand
  // within 1e-12 m of where the solve with every node leaves them.
  const RestRun off = run_rest_organ(0.0, 0.0, -0.005, 200, 400);
  const RestRun on = run_rest_organ(core::NetSettings{}.rest_speed, 0.0, -0.005, 200, 400);
  const int first =
      static_cast<int>(std::find(on.resting.begin(), on.resting.end(), 1002) - on.resting.begin());
  int iterations_on = 0, iterations_off = 0;
  for (std::size_t k = 0; k < on.iterations.size(); ++k) {
    iterations_on += on.iterations[k];
    iterations_off += off.iterations[k];
  }
  std::printf(
      "[organ at rest] all 1002 nodes resting from step %d; CG iterations over 400 steps: "
      "%d resting, %d every node in the solve; nodes apart by %.3g m\n",
      first + 1, iterations_on, iterations_off, rest_largest_distance(on.nodes_end, off.nodes_end));
  EXPECT_LE(first + 1, 2 * core::detail::kRestSteps + 2) << "the organ comes to rest";
  for (std::size_t k = static_cast<std::size_t>(first); k < on.resting.size(); ++k)
    ASSERT_EQ(on.resting[k], 1002) << "stays at rest, step " << k;
  EXPECT_EQ(rest_largest_distance(on.nodes_mid, on.nodes_end), 0.0) << "resting nodes do not creep";
  EXPECT_LT(rest_largest_distance(on.nodes_end, off.nodes_end), 1e-12);
  EXPECT_GE(iterations_off, 300) << "the relative rule alone chases the rounding";
  EXPECT_LE(iterations_on, iterations_off / 10);
  for (std::size_t k = static_cast<std::size_t>(first); k < on.iterations.size(); ++k)
    ASSERT_EQ(on.iterations[k], 0) << "an organ at rest takes no iteration, step " << k;
}

TEST(NetRest, APressedOrganGivesTheForceAndEnergyOfTheSolveWithEveryNode) {
  // The sphere reaches the resting organ and presses 3 mm into it, then is held: the nodes it
  // reaches wake, those far from it rest, and every step's force on the tool and the organ's
  // energy are those of the run without resting nodes, within 1e-5 and 1e-6 of their largest
  // values (the accuracy tests allow 3 %);
  // the steps after the first 20 do not allocate.
  const RestRun off = run_rest_organ(0.0, 1e-6, 0.003, 400, 700);
  const RestRun on = run_rest_organ(core::NetSettings{}.rest_speed, 1e-6, 0.003, 400, 700);
  double peak = 0.0, force_diff = 0.0, energy_peak = 0.0, energy_diff = 0.0;
  int fewest = 1002, most = 0;
  for (std::size_t k = 0; k < on.force.size(); ++k) {
    peak = std::max(peak, std::abs(off.force[k]));
    force_diff = std::max(force_diff, std::abs(on.force[k] - off.force[k]));
    energy_peak = std::max(energy_peak, std::abs(off.energy[k]));
    energy_diff = std::max(energy_diff, std::abs(on.energy[k] - off.energy[k]));
    if (off.force[k] > 0.0) {  // in contact
      fewest = std::min(fewest, on.resting[k]);
      most = std::max(most, on.resting[k]);
    }
  }
  std::printf(
      "[organ pressed 3 mm] force on the tool up to %.4f N, resting nodes in contact "
      "%d-%d of 1002; largest differences against every node in the solve: force %.3g N, "
      "energy %.3g J (of %.3g J), nodes %.3g m\n",
      peak, fewest, most, force_diff, energy_diff, energy_peak,
      rest_largest_distance(on.nodes_end, off.nodes_end));
  EXPECT_GT(peak, 1.0) << "the sphere presses the organ";
  EXPECT_GT(most, 500) << "the organ away from the sphere rests";
  EXPECT_LT(fewest, 1002) << "the nodes the sphere reaches are awake";
  EXPECT_LT(force_diff, 1e-5 * peak);
  EXPECT_LT(energy_diff, 1e-6 * energy_peak);
  EXPECT_LT(rest_largest_distance(on.nodes_end, off.nodes_end), 1e-7);
  EXPECT_EQ(on.allocations, 0);
}

TEST(NetRest, EveryUnquietNodeAndItsNeighboursAreSolvedAndTheEdgeOfTheRestIsPassed) {
  // The lists the solve runs on, against the rules recomputed by brute force after every step
  // of the pressed organ: a node not quiet for kRestSteps steps (NetScratch::rest_count), and
  // each of its spring neighbours (Model::node_springs), is in the solve (active_nodes, and the
  // same nodes' sweep positions ascending in active_positions); the springs' passes visit
  // exactly the nodes in the solve and the resting nodes next to one (pass_positions).
  int checked = 0, with_edge = 0;
  const auto check = [&](const core::Model& m, const core::Data& d, int k) {
    const core::NetScratch& ns = d.scratch->net;
    const auto n = static_cast<std::size_t>(m.num_nodes());
    std::vector<char> active(n, 0);
    for (int a = 0; a < ns.active_count[0]; ++a)
      active[static_cast<std::size_t>(ns.active_nodes[static_cast<std::size_t>(a)])] = 1;
    const auto neighbour = [&](std::size_t i, std::int32_t e) {
      const core::NetSpring& sp = m.net_springs[static_cast<std::size_t>(e)];
      return static_cast<std::size_t>(sp.node_a == static_cast<int>(i) ? sp.node_b : sp.node_a);
    };
    std::vector<std::int32_t> positions, passed;
    for (std::size_t p = 0; p < n; ++p) {
      const auto i = static_cast<std::size_t>(m.node_sweep_order[p]);
      bool near_active = false;
      for (std::int32_t e = m.node_spring_begin[i]; e < m.node_spring_begin[i + 1]; ++e) {
        const std::size_t j = neighbour(i, m.node_springs[static_cast<std::size_t>(e)]);
        near_active = near_active || active[j];
        if (ns.rest_count[i] < core::detail::kRestSteps) {
          ASSERT_TRUE(active[j]) << "step " << k << ": node " << j << " beside unquiet node " << i;
        }
      }
      if (ns.rest_count[i] < core::detail::kRestSteps) {
        ASSERT_TRUE(active[i]) << "step " << k << ": unquiet node " << i;
      }
      if (active[i]) positions.push_back(static_cast<std::int32_t>(p));
      if (active[i] || near_active) passed.push_back(static_cast<std::int32_t>(p));
    }
    ASSERT_EQ(std::vector<std::int32_t>(ns.active_positions.begin(),
                                        ns.active_positions.begin() + ns.active_count[0]),
              positions) << "step " << k;
    ASSERT_EQ(std::vector<std::int32_t>(ns.pass_positions.begin(),
                                        ns.pass_positions.begin() + ns.pass_count[0]),
              passed) << "step " << k;
    ++checked;
    if (ns.active_count[0] > 0 && ns.pass_count[0] > ns.active_count[0]) ++with_edge;
  };
  run_rest_organ(core::NetSettings{}.rest_speed, 1e-6, 0.003, 400, 700, check);
  std::printf("[organ rest lists] %d steps checked, %d with nodes resting at the edge of the solve\n",
              checked, with_edge);
  EXPECT_EQ(checked, 700);
  EXPECT_GE(with_edge, 100) << "the organ rests in part while pressed";
}

TEST(NetRest, NoNodeRestsOnANetThatIsNotAnOrganOrWithRestSpeedZero) {
  // rest_speed = 0 switches resting off; a net on a body that is not anchored never rests.
  for (const double rest_speed : {0.0, core::NetSettings{}.rest_speed}) {
    core::Model m = rest_test_organ(rest_speed);
    EXPECT_EQ(core::detail::net_can_rest(m, m.nets[0]), rest_speed > 0.0);
    m.bodies[0].anchored = false;
    EXPECT_FALSE(core::detail::net_can_rest(m, m.nets[0]));
  }
  core::Model m = rest_test_organ(core::NetSettings{}.rest_speed);
  core::Data d = core::make_data(m);
  m.nets[0].rest_speed = 0.0;
  for (int k = 0; k < 30; ++k) {
    core::step(m, d);
    ASSERT_EQ(d.nets[0].resting_nodes, 0) << k;
  }
}

}  // namespace numen
