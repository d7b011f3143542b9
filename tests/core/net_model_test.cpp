// Tests of core/net_model (add_net) and of the nets' part of finalize_model:
// node and spring counts and ranges, area-lumped masses summing to the
// setting, default node radius (mean incident edge / √3), spring constants,
// initial node states from make_data, each documented error of add_net
// leaving the model untouched, and finalize_model's net validation messages.
#include "numen/core/net_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"

#include "scratch/data_scratch.hpp"
#include "net_states.hpp"

namespace core = numen::core;
using core::Vec3;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kNetInf = std::numeric_limits<double>::infinity();

using numen::test::at;

/// Two materials, two bodies (the second one will carry the nets), no spheres.
core::Model base_model() {
  core::Model m;
  m.material_names = {"steel", "rubber"};
  m.material_pairs.assign(4, core::MaterialPair{});
  core::BodyModel a;
  a.name = "handle";
  core::BodyModel b;
  b.name = "bag_core";
  b.initial_pose.position = Vec3(0.1, -0.2, 0.3);
  b.initial_pose.orientation = core::Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, -1).normalized()));
  b.initial_twist.linear = Vec3(0.2, 0.0, -0.1);
  b.initial_twist.angular = Vec3(1.0, -2.0, 0.5);
  m.bodies = {a, b};
  m.initial_held_body = -1;
  return m;
}

core::NetSettings settings(const std::string& name = "bag") {
  core::NetSettings s;
  s.name = name;
  s.body = 1;
  s.material = 1;
  s.mass = 0.25;
  s.stiffness = 40.0;
  s.damping = 0.3;
  s.bending_stiffness = 4.0;
  s.bending_damping = 0.03;
  s.tie_stiffness = 120.0;
  s.tie_damping = 0.5;
  return s;
}

/// An open strip of two triangles sharing the edge 1–2 (vertices not all
/// alike: the lumped areas differ).
core::TriangleMesh strip() {
  core::TriangleMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0.05, 0), Vec3(0.12, 0.09, 0.01)};
  m.triangles = {{0, 1, 2}, {1, 3, 2}};
  return m;
}

/// base_model() with two nets: "a", a 42-node icosphere on body 1, then "b", strip() on body 0.
core::Model icosphere_and_strip_nets() {
  core::Model m = base_model();
  EXPECT_EQ(core::add_net(m, core::make_icosphere(0.05, 1), settings("a")), "");
  core::NetSettings s = settings("b");
  s.body = 0;
  s.material = 0;
  EXPECT_EQ(core::add_net(m, strip(), s), "");
  return m;
}

/// Every net array of the model, to check that a rejected net leaves it untouched.
struct NetArrays {
  std::size_t nets, springs, rest, mass, radius, net;
  explicit NetArrays(const core::Model& m)
      : nets(m.nets.size()), springs(m.net_springs.size()), rest(m.node_rest.size()),
        mass(m.node_mass.size()), radius(m.node_radius.size()), net(m.node_net.size()) {}
  bool operator==(const NetArrays&) const = default;
};

}  // namespace

TEST(NetModel, IcosphereCountsRangesAndConstants) {
  core::Model m = base_model();
  const core::TriangleMesh mesh = core::make_icosphere(0.05, 1);
  const core::MeshTopology topo = core::build_mesh_topology(mesh);
  ASSERT_EQ(core::add_net(m, mesh, settings()), "");
  ASSERT_EQ(m.num_nets(), 1);
  const core::NetModel& net = m.nets[0];
  EXPECT_EQ(net.name, "bag");
  EXPECT_EQ(net.body, 1);
  EXPECT_EQ(net.material, 1);
  EXPECT_EQ(net.node_begin, 0);
  EXPECT_EQ(net.node_count, 42);
  EXPECT_EQ(m.num_nodes(), 42);
  EXPECT_EQ(net.spring_begin, 0);
  EXPECT_EQ(net.structural_count, 120);  // V − E + F = 2 with V = 42, F = 80
  EXPECT_EQ(net.structural_count, static_cast<int>(topo.edges.size()));
  EXPECT_EQ(net.bending_count, static_cast<int>(topo.bending_pairs.size()));
  EXPECT_GT(net.bending_count, 0);
  EXPECT_EQ(m.net_springs.size(), at(net.structural_count + net.bending_count));
  EXPECT_EQ(net.tie_stiffness, 120.0);
  EXPECT_EQ(net.tie_damping, 0.5);
  for (int i = 0; i < 42; ++i) {
    EXPECT_EQ(m.node_rest[at(i)], mesh.vertices[at(i)]) << i;  // body frame, unchanged
    EXPECT_EQ(m.node_net[at(i)], 0);
  }
  for (int e = 0; e < net.structural_count + net.bending_count; ++e) {
    const core::NetSpring& s = m.net_springs[at(e)];
    const bool structural = e < net.structural_count;
    const auto& pair = structural ? topo.edges[at(e)] : topo.bending_pairs[at(e - net.structural_count)];
    EXPECT_EQ(s.node_a, pair.first) << e;
    EXPECT_EQ(s.node_b, pair.second) << e;
    EXPECT_LT(s.node_a, s.node_b) << e;
    EXPECT_DOUBLE_EQ(s.rest_length, (mesh.vertices[at(s.node_b)] - mesh.vertices[at(s.node_a)]).norm());
    EXPECT_EQ(s.stiffness, structural ? 40.0 : 4.0) << e;
    EXPECT_EQ(s.damping, structural ? 0.3 : 0.03) << e;
  }
  EXPECT_EQ(core::finalize_model(m), "");
}

TEST(NetModel, MassesAreAreaLumpedAndSumToTheSetting) {
  for (const core::TriangleMesh& mesh : {core::make_icosphere(0.05, 1), core::make_icosphere(0.05, 2),
                                         core::make_capsule(0.02, 0.05, 8, 3, 2), strip()}) {
    core::Model m = base_model();
    ASSERT_EQ(core::add_net(m, mesh, settings()), "");
    const std::vector<double> area = core::vertex_areas(mesh);
    double total_area = 0.0;
    for (double a : area) total_area += a;
    double sum = 0.0;
    for (int i = 0; i < m.num_nodes(); ++i) {
      EXPECT_NEAR(m.node_mass[at(i)], 0.25 * area[at(i)] / total_area, 1e-15) << i;
      EXPECT_GT(m.node_mass[at(i)], 0.0);
      sum += m.node_mass[at(i)];
    }
    EXPECT_NEAR(sum, 0.25, 1e-14);
    EXPECT_NEAR(m.nets[0].mass, 0.25, 1e-14);
  }
  // The icosahedron's vertices all have the same area: equal masses.
  core::Model m = base_model();
  ASSERT_EQ(core::add_net(m, core::make_icosphere(0.05, 0), settings()), "");
  ASSERT_EQ(m.num_nodes(), 12);
  for (double mass : m.node_mass) EXPECT_NEAR(mass, 0.25 / 12, 1e-15);
  // The strip's four vertices have different lumped areas (not a uniform split).
  core::Model ms = base_model();
  ASSERT_EQ(core::add_net(ms, strip(), settings()), "");
  EXPECT_GT(std::abs(ms.node_mass[0] - ms.node_mass[1]), 1e-3);
}

TEST(NetModel, DefaultNodeRadiusIsTheMeanIncidentEdgeOverRootThree) {
  const core::TriangleMesh mesh = core::make_capsule(0.02, 0.04, 10, 3, 1);
  const std::vector<double> edge = core::mean_incident_edge_length(mesh, core::build_mesh_topology(mesh));
  core::Model m = base_model();
  ASSERT_EQ(core::add_net(m, mesh, settings()), "");
  for (int i = 0; i < m.num_nodes(); ++i)
    EXPECT_NEAR(m.node_radius[at(i)], edge[at(i)] / std::sqrt(3.0), 1e-15) << i;
  // By hand on the strip: vertex 0 has edges of 0.1 and 0.05.
  core::Model ms = base_model();
  ASSERT_EQ(core::add_net(ms, strip(), settings()), "");
  EXPECT_NEAR(ms.node_radius[0], 0.075 / std::sqrt(3.0), 1e-15);
  // An explicit radius is used as is.
  core::NetSettings s = settings();
  s.node_radius = 0.004;
  core::Model me = base_model();
  ASSERT_EQ(core::add_net(me, mesh, s), "");
  for (double r : me.node_radius) EXPECT_EQ(r, 0.004);
}

TEST(NetModel, SecondNetFollowsTheFirstInEveryArray) {
  core::Model m = icosphere_and_strip_nets();
  ASSERT_EQ(m.num_nets(), 2);
  const core::NetModel& b = m.nets[1];
  EXPECT_EQ(b.node_begin, 42);
  EXPECT_EQ(b.node_count, 4);
  EXPECT_EQ(b.spring_begin, m.nets[0].structural_count + m.nets[0].bending_count);
  EXPECT_EQ(b.structural_count, 5);
  EXPECT_EQ(b.bending_count, 1);  // the pair 0–3 across the shared edge 1–2
  const core::NetSpring& bend = m.net_springs[at(b.spring_begin + 5)];
  EXPECT_EQ(bend.node_a, 42 + 0);
  EXPECT_EQ(bend.node_b, 42 + 3);
  for (int e = b.spring_begin; e < b.spring_begin + 6; ++e) {
    EXPECT_GE(m.net_springs[at(e)].node_a, 42);
    EXPECT_LT(m.net_springs[at(e)].node_b, 46);
  }
  for (int i = 42; i < 46; ++i) EXPECT_EQ(m.node_net[at(i)], 1);
  EXPECT_EQ(m.num_nodes(), 46);
  EXPECT_EQ(core::finalize_model(m), "");
}

TEST(NetModel, FinalizeListsEachSpringAtBothItsNodesInAscendingOrder) {
  core::Model m = icosphere_and_strip_nets();
  ASSERT_EQ(m.num_nets(), 2);
  ASSERT_EQ(core::finalize_model(m), "");
  ASSERT_EQ(m.node_spring_begin.size(), at(m.num_nodes() + 1));
  ASSERT_EQ(m.node_springs.size(), 2 * m.net_springs.size());
  EXPECT_EQ(m.node_spring_begin.front(), 0);
  EXPECT_EQ(m.node_spring_begin.back(), static_cast<std::int32_t>(m.node_springs.size()));
  // Brute force: node i's springs are exactly those with i as an end, ascending.
  for (int i = 0; i < m.num_nodes(); ++i) {
    std::vector<std::int32_t> expected;
    for (std::size_t e = 0; e < m.net_springs.size(); ++e)
      if (m.net_springs[e].node_a == i || m.net_springs[e].node_b == i)
        expected.push_back(static_cast<std::int32_t>(e));
    const std::vector<std::int32_t> listed(m.node_springs.begin() + m.node_spring_begin[at(i)],
                                           m.node_springs.begin() + m.node_spring_begin[at(i + 1)]);
    EXPECT_EQ(listed, expected) << "node " << i;
  }
  // The icosphere's node 0 has 5 structural springs and 5 bending (one across each edge).
  EXPECT_EQ(m.node_spring_begin[1] - m.node_spring_begin[0], 10);
  core::Model none = base_model();
  ASSERT_EQ(core::finalize_model(none), "");
  EXPECT_TRUE(none.node_spring_begin.empty());
  EXPECT_TRUE(none.node_springs.empty());
}

TEST(NetModel, NodesStartAtTheirRestPositionsMovingWithTheRigidComponent) {
  core::Model m = base_model();
  ASSERT_EQ(core::add_net(m, core::make_icosphere(0.05, 1), settings()), "");
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  const core::BodyModel& b = m.bodies[1];
  for (int i = 0; i < m.num_nodes(); ++i) {
    const Vec3 lever = b.initial_pose.orientation * m.node_rest[at(i)];
    EXPECT_TRUE(d.nodes[at(i)].position.isApprox(b.initial_pose.position + lever, 1e-14)) << i;
    EXPECT_TRUE(d.nodes[at(i)].velocity.isApprox(
        b.initial_twist.linear + b.initial_twist.angular.cross(lever), 1e-14))
        << i;
  }
  EXPECT_EQ(d.nets.size(), 1u);
  EXPECT_EQ(d.node_contacts.size(), static_cast<std::size_t>(core::kMaxNodeContacts));
  // A model without nets pays nothing.
  core::Model plain = base_model();
  ASSERT_EQ(core::finalize_model(plain), "");
  const core::Data dp = core::make_data(plain);
  EXPECT_TRUE(dp.nodes.empty());
  EXPECT_TRUE(dp.node_contacts.empty());
  EXPECT_TRUE(dp.scratch->net.force.empty());
  EXPECT_TRUE(dp.scratch->net.body_schur.empty());
}

TEST(NetModel, EachErrorNamesTheNetAndTheSettingAndLeavesTheModelUntouched) {
  struct Case {
    const char* what;
    void (*edit)(core::NetSettings&, core::TriangleMesh&);
    const char* expect;  // substring of the message
  };
  const Case cases[] = {
      {"body -1", [](core::NetSettings& s, core::TriangleMesh&) { s.body = -1; }, "body index -1"},
      {"body 2", [](core::NetSettings& s, core::TriangleMesh&) { s.body = 2; }, "body index 2"},
      {"material -1", [](core::NetSettings& s, core::TriangleMesh&) { s.material = -1; },
       "material"},
      {"material 2", [](core::NetSettings& s, core::TriangleMesh&) { s.material = 2; }, "material"},
      {"mass 0", [](core::NetSettings& s, core::TriangleMesh&) { s.mass = 0.0; }, "mass"},
      {"mass -1", [](core::NetSettings& s, core::TriangleMesh&) { s.mass = -1.0; }, "mass"},
      {"mass NaN", [](core::NetSettings& s, core::TriangleMesh&) { s.mass = kNaN; }, "mass"},
      {"mass inf", [](core::NetSettings& s, core::TriangleMesh&) { s.mass = kNetInf; }, "mass"},
      {"tie 0", [](core::NetSettings& s, core::TriangleMesh&) { s.tie_stiffness = 0.0; },
       "tie_stiffness"},
      {"tie NaN", [](core::NetSettings& s, core::TriangleMesh&) { s.tie_stiffness = kNaN; },
       "tie_stiffness"},
      {"tie inf", [](core::NetSettings& s, core::TriangleMesh&) { s.tie_stiffness = kNetInf; },
       "tie_stiffness"},
      {"stiffness", [](core::NetSettings& s, core::TriangleMesh&) { s.stiffness = -1.0; },
       "stiffness"},
      {"stiffness NaN", [](core::NetSettings& s, core::TriangleMesh&) { s.stiffness = kNaN; },
       "stiffness"},
      {"damping", [](core::NetSettings& s, core::TriangleMesh&) { s.damping = -0.1; }, "damping"},
      {"bending_stiffness",
       [](core::NetSettings& s, core::TriangleMesh&) { s.bending_stiffness = -1.0; },
       "bending_stiffness"},
      {"bending_damping",
       [](core::NetSettings& s, core::TriangleMesh&) { s.bending_damping = kNetInf; },
       "bending_damping"},
      {"tie_damping", [](core::NetSettings& s, core::TriangleMesh&) { s.tie_damping = -1.0; },
       "tie_damping"},
      {"node_radius", [](core::NetSettings& s, core::TriangleMesh&) { s.node_radius = -0.01; },
       "node_radius"},
      {"node_radius NaN", [](core::NetSettings& s, core::TriangleMesh&) { s.node_radius = kNaN; },
       "node_radius"},
      {"empty mesh", [](core::NetSettings&, core::TriangleMesh& m) { m = core::TriangleMesh{}; },
       "mesh: "},
      {"index out of range",
       [](core::NetSettings&, core::TriangleMesh& m) { m.triangles[0][1] = 99; }, "mesh: "},
      {"degenerate",
       [](core::NetSettings&, core::TriangleMesh& m) { m.vertices[3] = m.vertices[1]; }, "mesh: "},
      {"unused vertex",
       [](core::NetSettings&, core::TriangleMesh& m) { m.vertices.push_back(Vec3(1, 1, 1)); },
       "mesh: "},
      // Each triangle's area is finite, their sum is not: the masses would be NaN.
      {"area overflow",
       [](core::NetSettings&, core::TriangleMesh& m) {
         for (Vec3& v : m.vertices) v *= 1.3e154;
       },
       "area must be finite"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    core::Model m = base_model();
    ASSERT_EQ(core::add_net(m, core::make_icosphere(0.05, 0), settings("first")), "");
    const NetArrays before(m);
    const std::vector<double> masses = m.node_mass;
    core::NetSettings s = settings("second");
    core::TriangleMesh mesh = strip();
    c.edit(s, mesh);
    const std::string err = core::add_net(m, mesh, s);
    EXPECT_NE(err.find("net 'second': "), std::string::npos) << err;
    EXPECT_NE(err.find(c.expect), std::string::npos) << err;
    EXPECT_EQ(NetArrays(m), before) << err;
    EXPECT_EQ(m.node_mass, masses);
    EXPECT_EQ(m.nets[0].name, "first");
    EXPECT_EQ(core::finalize_model(m), "") << "the model is still valid after a rejected net";
  }
}

TEST(NetModel, ZeroStiffnessAndDampingAreAllowed) {
  core::Model m = base_model();
  core::NetSettings s = settings();
  s.stiffness = s.damping = s.bending_stiffness = s.bending_damping = s.tie_damping = 0.0;
  EXPECT_EQ(core::add_net(m, strip(), s), "");
  EXPECT_EQ(core::finalize_model(m), "");
}

TEST(NetModel, FinalizeModelValidatesTheNetArrays) {
  struct Case {
    const char* what;
    void (*edit)(core::Model&);
    const char* expect;
  };
  const Case cases[] = {
      {"array sizes", [](core::Model& m) { m.node_mass.pop_back(); }, "must have the same size"},
      {"radius size", [](core::Model& m) { m.node_radius.push_back(0.01); },
       "must have the same size"},
      {"body", [](core::Model& m) { m.nets[1].body = 5; }, "net 'b': rigid component out of range"},
      {"material", [](core::Model& m) { m.nets[0].material = 7; },
       "net 'a': material index out of range"},
      {"node range gap", [](core::Model& m) { m.nets[1].node_begin = 13; }, "net 'b': node range"},
      {"empty node range", [](core::Model& m) { m.nets[0].node_count = 0; }, "net 'a': node range"},
      {"spring range", [](core::Model& m) { m.nets[1].spring_begin += 1; },
       "net 'b': spring range"},
      {"tie stiffness", [](core::Model& m) { m.nets[0].tie_stiffness = 0.0; },
       "net 'a': tie_stiffness"},
      {"tie damping", [](core::Model& m) { m.nets[1].tie_damping = kNaN; },
       "net 'b': tie_stiffness"},
      {"node mass", [](core::Model& m) { m.node_mass[3] = 0.0; }, "net 'a': node 3 needs"},
      {"node radius", [](core::Model& m) { m.node_radius[13] = -1.0; }, "net 'b': node 1 needs"},
      {"node rest", [](core::Model& m) { m.node_rest[2].x() = kNaN; }, "net 'a': node 2 needs"},
      {"node net", [](core::Model& m) { m.node_net[12] = 0; }, "net 'b': node 0 needs"},
      {"spring node", [](core::Model& m) { m.net_springs[0].node_b = 20; },
       "net 'a': spring 0 needs"},
      {"spring same node",
       [](core::Model& m) { m.net_springs[1].node_b = m.net_springs[1].node_a; },
       "net 'a': spring 1 needs"},
      {"spring rest", [](core::Model& m) { m.net_springs.back().rest_length = 0.0; },
       "net 'b': spring 5 needs"},
      {"spring k", [](core::Model& m) { m.net_springs[2].stiffness = -1.0; },
       "net 'a': spring 2 needs"},
      {"spring gamma", [](core::Model& m) { m.net_springs[2].damping = kNetInf; },
       "net 'a': spring 2 needs"},
      {"unowned node",
       [](core::Model& m) {
         m.node_rest.push_back(Vec3::Zero());
         m.node_mass.push_back(1.0);
         m.node_radius.push_back(1.0);
         m.node_net.push_back(1);
       },
       "entries no net owns"},
      {"unowned spring", [](core::Model& m) { m.net_springs.push_back(m.net_springs.back()); },
       "entries no net owns"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    core::Model m = base_model();
    ASSERT_EQ(core::add_net(m, core::make_icosphere(0.05, 0), settings("a")), "");
    ASSERT_EQ(core::add_net(m, strip(), settings("b")), "");
    c.edit(m);
    const std::string err = core::finalize_model(m);
    EXPECT_NE(err.find(c.expect), std::string::npos) << "got: " << err;
  }
}
