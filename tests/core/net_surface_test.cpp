// An organ's surface contacts (core/src/net/net_surface.cpp; docs/organs.md, "Surface
// contacts"): the tool's spheres against the organ's triangles through its node centres. The
// geometry against an every-triangle reference (depth, normal, barycentric shares; one sphere,
// and each sphere of a tool of twenty), a triangle turned over keeping its rest side, a centre
// below the surface pushed back out, a vertex or an edge shared by several triangles counted
// once, the forces' split and their sum, the capacity overflow counted once
// per triangle contact, and the shipped organ holding the jaws' small sphere at its surface
// where its node spheres let it through.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "numen/core/collision.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/net_forces.hpp"
#include "numen/core/step.hpp"

#include "mesh/mesh_shape_query.hpp"
#include "net/node_contact_sink.hpp"
#include "organ_indentation.hpp"
#include "sanitizer.hpp"

namespace core = numen::core;
using core::Vec3;
using namespace numen::test::organ;

namespace {

/// An organ from `mesh` (organ_indentation.hpp's model, the tool imposed) with the tool's
/// sphere of `radius` at `at`.
core::Model organ_with_tool(const core::TriangleMesh& mesh, double radius, const Vec3& at) {
  return organ_model(mesh, OrganParams{}, 1e-3, core::CouplingMode::kDirect, radius, at);
}

/// Runs the collision stages on `d` with the tool's body at `at`.
void detect(const core::Model& m, core::Data& d, const Vec3& at) {
  d.bodies[1].position = at;
  core::detect_contacts(m, d);
  core::detect_node_contacts(m, d);
}

/// Reference, over every triangle: the triangles whose closest point to p is inside them and
/// within r (depth r − o · (p − q), o the triangle's outward unit normal), and the nearest edge or
/// vertex point within r when it is nearer than all of those (`edge_distance`, its triangle and
/// weights; +∞ when there is none).
struct Reference {
  std::vector<std::pair<int, double>> faces;  ///< (triangle, depth).
  double edge_distance = std::numeric_limits<double>::infinity();
  Vec3 edge_weights = Vec3::Zero();
};
Reference reference(const core::Model& m, const core::Data& d, const Vec3& p, double r) {
  Reference ref;
  double face_distance = r, edge = r;
  for (int f = 0; f < static_cast<int>(m.net_faces.size()); ++f) {
    const auto& t = m.net_faces[static_cast<std::size_t>(f)];
    const Vec3& a = d.nodes[static_cast<std::size_t>(t[0])].position;
    const Vec3& b = d.nodes[static_cast<std::size_t>(t[1])].position;
    const Vec3& c = d.nodes[static_cast<std::size_t>(t[2])].position;
    int feature = 0;
    Vec3 w;
    const Vec3 q = core::detail::closest_on_triangle(p, a, b, c, feature, w);
    const double dist = (p - q).norm();
    if (!(dist < r)) continue;
    if (feature == core::detail::kFace) {
      const Vec3 o = (b - a).cross(c - a).normalized();
      ref.faces.emplace_back(f, r - o.dot(p - q));
      face_distance = std::min(face_distance, dist);
    } else if (dist < edge) {
      edge = dist;
      ref.edge_weights = w;
    }
  }
  if (edge < face_distance) ref.edge_distance = edge;
  return ref;
}

}  // namespace

TEST(NetSurface, AddNetKeepsTheMeshTrianglesWoundOutward) {
  core::TriangleMesh mesh = core::make_icosphere(0.02, 2);
  const core::Model a = organ_with_tool(mesh, 0.002, Vec3(0, 0, 0.05));
  ASSERT_EQ(a.nets[0].face_count, mesh.num_triangles());
  ASSERT_EQ(a.net_faces.size(), mesh.triangles.size());
  // Turned inside out, the faces come back outward.
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  const core::Model b = organ_with_tool(mesh, 0.002, Vec3(0, 0, 0.05));
  for (const core::Model* m : {&a, &b}) {
    for (const auto& t : m->net_faces) {
      const Vec3& x0 = m->node_rest[static_cast<std::size_t>(t[0])];
      const Vec3 n = (m->node_rest[static_cast<std::size_t>(t[1])] - x0)
                         .cross(m->node_rest[static_cast<std::size_t>(t[2])] - x0);
      ASSERT_GT(n.dot(x0), 0.0) << "outward normal on the sphere";
    }
  }
}

TEST(NetSurface, ContactsAgainstEveryTriangle) {
  // A deformed icosphere organ (radius 20 mm) and a 2 mm sphere at random places around its
  // surface, outside and inside: a contact per triangle whose closest point is inside it and
  // within r, and one at the nearest edge or vertex point when that is nearer (reference());
  // each written as its nodes' shares (summing to 1) with the same depth, normal from the sphere
  // into the organ (the tool pushed out).
  const double radius = 0.002;
  const core::Model m = organ_with_tool(core::make_icosphere(0.02, 3), radius, Vec3(0, 0, 0.05));
  core::Data d = core::make_data(m);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (core::NodeState& n : d.nodes) n.position += 4e-4 * Vec3(u(rng), u(rng), u(rng));
  int touching = 0, inside = 0, edges = 0, several = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Vec3 dir(u(rng), u(rng), u(rng));
    dir.normalize();
    const Vec3 at = (0.02 + 0.004 * u(rng)) * dir;
    detect(m, d, at);
    const Reference ref = reference(m, d, at, radius);
    const bool with_edge = std::isfinite(ref.edge_distance);
    // Group the entries by triangle (a contact's shares are consecutive).
    std::vector<std::pair<int, double>> got;
    double deepest = 0.0;
    for (int i = 0; i < d.num_node_contacts;) {
      const core::NodeContact& c0 = d.node_contacts[static_cast<std::size_t>(i)];
      ASSERT_GE(c0.face, 0);
      const auto& t = m.net_faces[static_cast<std::size_t>(c0.face)];
      double share_sum = 0.0;
      int j = i;
      for (; j < d.num_node_contacts && d.node_contacts[static_cast<std::size_t>(j)].face == c0.face &&
             d.node_contacts[static_cast<std::size_t>(j)].position == c0.position;
           ++j) {
        const core::NodeContact& c = d.node_contacts[static_cast<std::size_t>(j)];
        EXPECT_EQ(c.body_b, 1);
        EXPECT_EQ(c.depth, c0.depth);
        const int k = static_cast<int>(std::find(t.begin(), t.end(), c.node) - t.begin());
        ASSERT_LT(k, 3) << "a node of the triangle";
        EXPECT_GT(c.share, 0.0);
        EXPECT_DOUBLE_EQ(c.share, c.face_weights[k]);
        share_sum += c.share;
      }
      EXPECT_NEAR(share_sum, 1.0, 1e-12);
      // The tool is pushed out of the organ: −normal points away from its centre.
      EXPECT_GT(-c0.normal.dot(at.normalized()), 0.3) << trial;
      got.emplace_back(c0.face, c0.depth);
      deepest = std::max(deepest, c0.depth);
      i = j;
    }
    const std::size_t expected = ref.faces.size() + (with_edge ? 1 : 0);
    ASSERT_EQ(got.size(), expected) << trial;
    for (std::size_t k = 0; k < ref.faces.size(); ++k) {
      EXPECT_EQ(got[k].first, ref.faces[k].first) << trial;
      EXPECT_NEAR(got[k].second, ref.faces[k].second, 1e-12) << trial;
    }
    const bool clearly_inside = at.norm() < 0.02 * 0.95, clearly_outside = at.norm() > 0.02 * 1.05;
    if (with_edge && (clearly_inside || clearly_outside)) {
      const double signed_distance = clearly_inside ? -ref.edge_distance : ref.edge_distance;
      EXPECT_NEAR(got.back().second, radius - signed_distance, 1e-12) << trial;
    }
    if (expected > 0) {
      EXPECT_NEAR(d.nets[0].max_penetration, deepest, 1e-15);
    }
    touching += expected > 0 ? 1 : 0;
    inside += expected > 0 && clearly_inside ? 1 : 0;
    edges += with_edge ? 1 : 0;
    several += expected > 1 ? 1 : 0;
  }
  std::printf("[surface] %d spheres touching (%d with the centre well inside), %d on an edge or "
              "vertex, %d with several triangles\n", touching, inside, edges, several);
  EXPECT_GT(touching, 100);
  EXPECT_GT(inside, 10);
  EXPECT_GT(edges, 10);
}

TEST(NetSurface, EverySphereOfALongToolMeetsWhatTheReferenceFinds) {
  // A tool of 20 spheres (2 mm, 3 mm apart along its x: more than one run of a body's spheres,
  // net_surface.cpp's kSphereGroup) laid across a deformed icosphere organ (radius 20 mm) at
  // random places and turns: each sphere's triangle contacts are reference()'s, in its order, and
  // it has one more exactly where reference() has an edge or vertex point nearer than them.
  constexpr int kSpheres = 20;
  const double radius = 0.002;
  core::Model m = numen::test::organ::organ_bodies(1e-3, core::CouplingMode::kDirect, radius, Vec3(0, 0, 0.05));
  m.body_spheres.clear();
  for (int i = 0; i < kSpheres; ++i)
    m.body_spheres.push_back(core::Sphere{Vec3(0.003 * (i - 0.5 * (kSpheres - 1)), 0.0, 0.0), radius});
  m.bodies[1].sphere_count = kSpheres;
  const core::TriangleMesh mesh = core::make_icosphere(0.02, 3);
  ASSERT_EQ(core::add_net(m, mesh, organ_net_settings(mesh, OrganParams{})), "");
  ASSERT_EQ(core::finalize_model(m), "");
  core::Data d = core::make_data(m);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (core::NodeState& n : d.nodes) n.position += 4e-4 * Vec3(u(rng), u(rng), u(rng));
  int touching_spheres = 0, runs_touching = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Vec3 dir(u(rng), u(rng), u(rng));
    dir.normalize();
    const Vec3 axis(u(rng), u(rng), u(rng));
    d.bodies[1].orientation = core::Quat(Eigen::AngleAxisd(3.0 * u(rng), axis.normalized()));
    detect(m, d, (0.02 + 0.003 * u(rng)) * dir);
    std::array<bool, 3> run_touches{};
    for (int sp = 0; sp < kSpheres; ++sp) {
      const Vec3 centre = d.bodies[1].position + d.bodies[1].orientation * m.body_spheres[static_cast<std::size_t>(sp)].center;
      const Reference ref = reference(m, d, centre, radius);
      std::vector<std::pair<int, double>> got;  // one per contact: its first entry
      for (int i = 0; i < d.num_node_contacts; ++i) {
        const core::NodeContact& c = d.node_contacts[static_cast<std::size_t>(i)];
        if (c.sphere_b != sp) continue;
        if (i > 0) {
          const core::NodeContact& p = d.node_contacts[static_cast<std::size_t>(i - 1)];
          if (p.sphere_b == sp && p.face == c.face && p.position == c.position) continue;
        }
        got.emplace_back(c.face, c.depth);
      }
      const std::size_t expected = ref.faces.size() + (std::isfinite(ref.edge_distance) ? 1 : 0);
      ASSERT_EQ(got.size(), expected) << "trial " << trial << ", sphere " << sp;
      for (std::size_t k = 0; k < ref.faces.size(); ++k) {
        EXPECT_EQ(got[k].first, ref.faces[k].first) << "trial " << trial << ", sphere " << sp;
        EXPECT_NEAR(got[k].second, ref.faces[k].second, 1e-12) << "trial " << trial << ", sphere " << sp;
      }
      touching_spheres += expected > 0 ? 1 : 0;
      run_touches[static_cast<std::size_t>(sp / 8)] = run_touches[static_cast<std::size_t>(sp / 8)] || expected > 0;
    }
    runs_touching += (run_touches[0] ? 1 : 0) + (run_touches[1] ? 1 : 0) + (run_touches[2] ? 1 : 0) > 1 ? 1 : 0;
  }
  std::printf("[surface] %d spheres touching over 200 placements, %d placements touching in more than one run\n",
              touching_spheres, runs_touching);
  EXPECT_GT(touching_spheres, 200);
  EXPECT_GT(runs_touching, 20);
}

TEST(NetSurface, ATriangleTurnedOverKeepsItsRestSide) {
  // A triangle whose two corners have traded places is the same triangle turned over: its
  // normal points into the organ. A sphere 0.5 r outside it along its rest outward normal is
  // still pushed out, by r − 0.5 r along that normal, not by 1.5 r into the organ
  // (net_surface.cpp, kept_side()).
  const double radius = 0.002;
  const core::Model m = organ_with_tool(core::make_icosphere(0.02, 3), radius, Vec3(0, 0, 0.05));
  core::Data d = core::make_data(m);
  const int f = m.nets[0].face_begin + 7;
  const auto& t = m.net_faces[static_cast<std::size_t>(f)];
  const Vec3 a = d.nodes[static_cast<std::size_t>(t[0])].position;
  const Vec3 b = d.nodes[static_cast<std::size_t>(t[1])].position;
  const Vec3 c = d.nodes[static_cast<std::size_t>(t[2])].position;
  const Vec3 outward = (b - a).cross(c - a).normalized();
  const Vec3 centroid = (a + b + c) / 3.0;
  ASSERT_GT(outward.dot(centroid - d.bodies[0].position), 0.0) << "wound outward at rest";
  std::swap(d.nodes[static_cast<std::size_t>(t[1])].position, d.nodes[static_cast<std::size_t>(t[2])].position);
  detect(m, d, centroid + 0.5 * radius * outward);
  int entries = 0;
  for (int i = 0; i < d.num_node_contacts; ++i) {
    const core::NodeContact& ct = d.node_contacts[static_cast<std::size_t>(i)];
    if (ct.face != f) continue;
    ++entries;
    EXPECT_NEAR(ct.normal.dot(outward), -1.0, 1e-12) << "from the tool into the organ";
    EXPECT_NEAR(ct.depth, 0.5 * radius, 1e-12);
  }
  EXPECT_EQ(entries, 3) << "the triangle's contact, one entry a node";
}

TEST(NetSurface, AVertexOrEdgeSharedByTrianglesIsOneContact) {
  // The flat patch (2.5 mm cells): a sphere straight above a vertex touches the six triangles
  // around it at that vertex, and above an edge the two triangles at the edge's point: one
  // contact, on the vertex alone (share 1) or on the edge's two nodes (½ each).
  const double radius = 0.005;
  const core::Model m = organ_with_tool(flat_patch(16, 0.0025), radius, Vec3(0, 0, 0.05));
  core::Data d = core::make_data(m);
  detect(m, d, Vec3(0.0, 0.0, radius - 0.001));  // the patch's centre vertex, 1 mm deep
  ASSERT_EQ(d.num_node_contacts, 1);
  EXPECT_DOUBLE_EQ(d.node_contacts[0].share, 1.0);
  EXPECT_NEAR(d.node_contacts[0].depth, 0.001, 1e-12);
  EXPECT_NEAR(d.node_contacts[0].normal.z(), -1.0, 1e-12);
  EXPECT_NEAR((d.nodes[static_cast<std::size_t>(d.node_contacts[0].node)].position).norm(), 0.0, 1e-12);
  detect(m, d, Vec3(0.00125, 0.0, radius - 0.001));  // the middle of an axis-aligned edge
  ASSERT_EQ(d.num_node_contacts, 2);
  EXPECT_NEAR(d.node_contacts[0].share, 0.5, 1e-12);
  EXPECT_NEAR(d.node_contacts[1].share, 0.5, 1e-12);
  detect(m, d, Vec3(0.0016, 0.0004, radius - 0.001));  // inside a triangle
  ASSERT_EQ(d.num_node_contacts, 3);
}

TEST(NetSurface, TheSharesSplitTheLawAtTheTrianglesPointAndSumToIt) {
  // A sphere 1 mm into a triangle of the patch, the nodes moving: the shares' forces are w_m f
  // with f the penalty law at the triangle's point velocity Σ w_m v_m, their sum f, and the
  // tool's body takes −f.
  const double radius = 0.005;
  const core::Model m = organ_with_tool(flat_patch(16, 0.0025), radius, Vec3(0, 0, 0.05));
  core::Data d = core::make_data(m);
  for (std::size_t i = 0; i < d.nodes.size(); ++i)
    d.nodes[i].velocity = Vec3(0.01 * std::sin(static_cast<double>(i)), 0.0, 0.02 * std::cos(0.7 * static_cast<double>(i)));
  d.bodies[1].linear_velocity = Vec3(0.0, 0.0, -0.01);
  detect(m, d, Vec3(0.0016, 0.0004, radius - 0.001));
  ASSERT_EQ(d.num_node_contacts, 3);
  for (core::Wrench& w : d.body_wrench) w = core::Wrench{};
  core::compute_net_forces(m, d);
  const core::NodeContact& c0 = d.node_contacts[0];
  Vec3 v_point = Vec3::Zero();
  const auto& t = m.net_faces[static_cast<std::size_t>(c0.face)];
  for (int k = 0; k < 3; ++k) v_point += c0.face_weights[k] * d.nodes[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])].velocity;
  const Vec3 v_rel = v_point - d.bodies[1].linear_velocity;
  const core::ContactForceResult law = core::contact_penalty_force(c0.normal, c0.depth, v_rel, m.material_pairs[0]);
  ASSERT_TRUE(law.active);
  Vec3 sum = Vec3::Zero();
  for (int i = 0; i < 3; ++i) {
    const core::NodeContact& c = d.node_contacts[static_cast<std::size_t>(i)];
    EXPECT_TRUE(c.active);
    EXPECT_NEAR((c.force - c.share * law.force).norm(), 0.0, 1e-12 * law.force.norm());
    EXPECT_NEAR(c.stiffness, c.share * law.stiffness, 1e-9 * law.stiffness);
    // The implicit step's h² K v₀ term: the node's own velocity (the lumped Jacobian).
    EXPECT_NEAR(c.normal_velocity,
                c.normal.dot(d.nodes[static_cast<std::size_t>(c.node)].velocity - d.bodies[1].linear_velocity), 1e-15);
    sum += c.force;
  }
  EXPECT_NEAR((sum - law.force).norm(), 0.0, 1e-12 * law.force.norm());
  EXPECT_NEAR((d.body_wrench[1].force + law.force).norm(), 0.0, 1e-12 * law.force.norm());
}

TEST(NetSurface, ATriangleContactThatDoesNotFitWholeIsDroppedAndCountedOnce) {
  std::array<core::NodeContact, 4> out{};
  core::detail::NodeContactSink sink{out.data(), 4};
  core::ContactGeometry g;
  g.depth = 1e-3;
  sink.add_face(0, {0, 1, 2}, Vec3(0.2, 0.3, 0.5), 1, 0, 0, g, Vec3::Zero());
  EXPECT_EQ(sink.count, 3);
  sink.add_face(1, {1, 2, 3}, Vec3(0.2, 0.3, 0.5), 1, 0, 0, g, Vec3::Zero());  // 3 > 1 left
  EXPECT_EQ(sink.count, 3);
  EXPECT_EQ(sink.dropped, 1);
  sink.add_face(2, {4, 5, 6}, Vec3(0.0, 1.0, 0.0), 1, 0, 0, g, Vec3::Zero());  // a vertex: fits
  EXPECT_EQ(sink.count, 4);
  EXPECT_EQ(out[3].node, 5);
  EXPECT_EQ(sink.dropped, 1);
}

TEST(NetSurface, TheShippedOrganHoldsTheJawsSphereAtItsSurface) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "compares the held force with the coupling over 1 000 organ steps (0.7 s natively, minutes "
      "under ASan); the triangle contacts' path runs there in "
      "NetOrgan.StepsPressingTheShippedOrganDoNotAllocate");
  // A god-object with the jaws' 1.5 mm sphere (coupled at 1000 N/m), its target driven at
  // 20 mm/s from −z into the shipped organ's convex face to 10 mm past the sphere's first touch
  // of the rest surface, then held for 0.5 s: the coupling pulls it in with up to ~10 N (the
  // device's feedback saturates at 8 N on the shipped scene). The sphere stays on the deformed
  // surface (its deepest contact well under a millimetre, its centre never below the surface)
  // and, at rest, the organ's push holds the coupling's pull. With node spheres this sphere slipped through the net at a few millimetres
  // (docs/organs.md, "Organs").
  const core::TriangleMesh mesh = shipped_organ_mesh();
  ASSERT_EQ(mesh.num_vertices(), 1002) << "sim/data/organ_lobe.obj";
  const double radius = 0.0015;
  const Vec3 from(0.004, -0.003, -0.03), dir(0, 0, 1);
  const core::Model m =
      organ_model(mesh, OrganParams{}, 1e-3, core::CouplingMode::kGodObject, radius, from);
  const double touch = first_touch(m, from, dir, radius);
  ASSERT_TRUE(std::isfinite(touch));
  core::Data d = core::make_data(m);
  double deepest = 0.0;
  const auto steps = static_cast<long>(std::ceil((touch + 0.010) / 0.02 / m.dt)) + 500;
  for (long k = 0; k <= steps; ++k) {
    const double s = std::min(touch + 0.010, 0.02 * static_cast<double>(k) * m.dt);
    d.target.position = from + s * dir;
    core::step(m, d);
    ASSERT_EQ(d.status, core::kStepOk) << k;
    deepest = std::max(deepest, d.nets[0].max_penetration);
  }
  const double force = organ_force_on_tool(d, dir);
  const double past = (d.bodies[1].position - from).dot(dir) - touch;
  std::printf("[surface] jaws sphere pulled 10 mm past the touch: deepest contact %.3f mm, "
              "sphere %.3f mm past the touch, organ push %.3f N, dent %.3f mm\n",
              1e3 * deepest, 1e3 * past, force, 1e3 * d.nets[0].max_tie_stretch);
  EXPECT_LT(deepest, 0.5e-3) << "the sphere stays at the deformed surface";
  EXPECT_GT(past, 5e-3) << "the organ gives way under the pull";
  EXPECT_NEAR(force, d.coupling_wrench.force.dot(dir), 1e-3 * force) << "the organ holds the pull";
  EXPECT_GT(force, 2.0);
}
