// A fine surface mapped onto a coarser net (core/src/net/net_surface_map.cpp;
// docs/fine-surface.md): the embeddings reproduce the fine vertices at rest and follow
// the net, bad input is refused with the model unchanged, every fine triangle is listed under the
// net triangles it rides on, and an organ with a fine surface meets the tool with it — where it
// stands off the net, with the net's own contacts where it is the net's own surface, its shares
// summing to one, without allocating while pressed.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/net_collision.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/step.hpp"

#include "alloc_counter.hpp"
#include "scratch/data_scratch.hpp"
#include "mesh/mesh_shape_query.hpp"
#include "scratch/net_scratch.hpp"
#include "organ_indentation.hpp"
#include "sanitizer.hpp"

namespace core = numen::core;
using core::Vec3;

namespace {

/// For each point of `fine`, the net-local triangle of net 0 of `m` nearest to it at rest
/// (every triangle tried: the reference search).
std::vector<int> surface_map_nearest_faces(const core::Model& m, const std::vector<Vec3>& fine) {
  const core::NetModel& net = m.nets[0];
  std::vector<int> out(fine.size(), 0);
  for (std::size_t i = 0; i < fine.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (int f = 0; f < net.face_count; ++f) {
      const auto& t = m.net_faces[static_cast<std::size_t>(net.face_begin + f)];
      int feature = 0;
      const Vec3 q = core::detail::closest_on_triangle(
          fine[i], m.node_rest[static_cast<std::size_t>(t[0])], m.node_rest[static_cast<std::size_t>(t[1])],
          m.node_rest[static_cast<std::size_t>(t[2])], feature);
      const double d = (fine[i] - q).squaredNorm();
      if (d < best) best = d, out[i] = f;
    }
  }
  return out;
}

/// The organ of organ_indentation.hpp (anchored at the origin, a one-sphere tool of `radius`
/// at `at`, imposed) on a net from `net_mesh`, carrying `fine` as its fine surface (none when
/// `fine` is empty).
core::Model surface_map_organ(const core::TriangleMesh& net_mesh, const core::TriangleMesh& fine,
                              double radius, const Vec3& at) {
  core::Model m = numen::test::organ::organ_model(net_mesh, numen::test::organ::OrganParams{}, 1e-3,
                                                  core::CouplingMode::kDirect, radius, at);
  if (!fine.vertices.empty()) {
    EXPECT_EQ(core::add_net_surface(m, 0, fine.vertices, fine.triangles,
                                    surface_map_nearest_faces(m, fine.vertices)),
              "");
  }
  return m;
}

/// Σ of the node contacts' shares per node, and their count of contact points (one per
/// distinct position).
std::map<int, double> surface_map_shares(const core::Data& d) {
  std::map<int, double> out;
  for (int c = 0; c < d.num_node_contacts; ++c)
    out[d.node_contacts[static_cast<std::size_t>(c)].node] += d.node_contacts[static_cast<std::size_t>(c)].share;
  return out;
}

}  // namespace

TEST(NetSurfaceMap, RestPositionsAreTheFineVerticesAndTheyFollowARigidMotion) {
  const core::TriangleMesh fine = core::make_icosphere(0.02, 4);
  const core::Model m =
      surface_map_organ(core::make_icosphere(0.02, 1), fine, 0.002, Vec3(0, 0, 0.05));
  ASSERT_EQ(m.nets[0].surface_point_count, fine.num_vertices());
  ASSERT_EQ(m.nets[0].surface_face_count, fine.num_triangles());
  core::Data d = core::make_data(m);
  std::vector<Vec3> x(fine.vertices.size());
  ASSERT_EQ(core::net_surface_positions(m, d, 0, x), fine.num_vertices());
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, (x[i] - fine.vertices[i]).norm());
  EXPECT_LT(worst, 1e-12) << "at rest the map gives the fine vertices back";
  // Icosphere of 42 nodes under a 2562-vertex sphere of the same radius: the fine surface
  // stands off the flat net triangles by up to r (1 − cos) of their circumradius' angle.
  const double off = core::net_surface_max_offset(m, 0);
  EXPECT_GT(off, 5e-4);
  EXPECT_LT(off, 2.5e-3);
  EXPECT_GT(m.nets[0].surface_reach, off);

  // A rigid motion of the nodes moves the fine surface with it.
  const core::Quat q = core::Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  const Vec3 t(0.1, -0.2, 0.05);
  for (core::NodeState& n : d.nodes) n.position = q * n.position + t;
  ASSERT_EQ(core::net_surface_positions(m, d, 0, x), fine.num_vertices());
  worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, (x[i] - (q * fine.vertices[i] + t)).norm());
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(core::net_surface_positions(m, d, 1, x), 0) << "no such net";
}

TEST(NetSurfaceMap, BadInputIsRefusedAndLeavesTheModelUnchanged) {
  const core::TriangleMesh fine = core::make_icosphere(0.02, 2);
  core::Model m = surface_map_organ(core::make_icosphere(0.02, 1), {}, 0.002, Vec3(0, 0, 0.05));
  const std::vector<int> nearest = surface_map_nearest_faces(m, fine.vertices);
  const auto refused = [&](const std::string& err, const char* says) {
    EXPECT_NE(err.find(says), std::string::npos) << err;
    EXPECT_TRUE(m.net_surface_points.empty());
    EXPECT_TRUE(m.net_surface_faces.empty());
    EXPECT_EQ(m.nets[0].surface_point_count, 0);
  };
  refused(core::add_net_surface(m, 1, fine.vertices, fine.triangles, nearest), "not a net");
  refused(core::add_net_surface(m, 0, fine.vertices, fine.triangles,
                                std::span<const int>(nearest).first(nearest.size() - 1)),
          "nearest triangles for");
  std::vector<int> bad_face = nearest;
  bad_face[5] = m.nets[0].face_count;
  refused(core::add_net_surface(m, 0, fine.vertices, fine.triangles, bad_face),
          "vertex 5: net triangle 80 out of range");
  std::vector<std::array<int, 3>> bad_tris = fine.triangles;
  bad_tris[3][1] = fine.num_vertices();
  refused(core::add_net_surface(m, 0, fine.vertices, bad_tris, nearest), "triangle 3: vertex index");
  bad_tris = fine.triangles;
  bad_tris[4][2] = bad_tris[4][0];
  refused(core::add_net_surface(m, 0, fine.vertices, bad_tris, nearest), "triangle 4 repeats a vertex");
  std::vector<Vec3> bad_verts = fine.vertices;
  bad_verts[7].y() = std::numeric_limits<double>::quiet_NaN();
  refused(core::add_net_surface(m, 0, bad_verts, fine.triangles, nearest), "vertex 7 is not finite");
  ASSERT_EQ(core::add_net_surface(m, 0, fine.vertices, fine.triangles, nearest), "");
  const auto points = m.net_surface_points.size();
  EXPECT_NE(core::add_net_surface(m, 0, fine.vertices, fine.triangles, nearest).find("has one already"),
            std::string::npos);
  EXPECT_EQ(m.net_surface_points.size(), points);
}

TEST(NetSurfaceMap, EveryFineTriangleIsListedUnderTheNetTrianglesItRidesOn) {
  const core::TriangleMesh fine = core::make_icosphere(0.02, 3);
  const core::Model m =
      surface_map_organ(core::make_icosphere(0.02, 1), fine, 0.002, Vec3(0, 0, 0.05));
  ASSERT_EQ(m.net_face_surface_begin.size(), m.net_faces.size() + 1);
  int listed = 0;
  for (int F = 0; F < static_cast<int>(m.net_surface_faces.size()); ++F) {
    const auto& t = m.net_surface_faces[static_cast<std::size_t>(F)];
    for (int k = 0; k < 3; ++k) {
      const int f = m.net_surface_points[static_cast<std::size_t>(t[static_cast<std::size_t>(k)])].face;
      const auto b = m.net_face_surface_faces.begin() + m.net_face_surface_begin[static_cast<std::size_t>(f)];
      const auto e = m.net_face_surface_faces.begin() + m.net_face_surface_begin[static_cast<std::size_t>(f) + 1];
      ASSERT_NE(std::find(b, e, F), e) << "fine triangle " << F << " under net triangle " << f;
      ++listed;
    }
    // Wound outward like the fine sphere.
    const Vec3& x0 = fine.vertices[static_cast<std::size_t>(t[0])];
    const Vec3 n = (fine.vertices[static_cast<std::size_t>(t[1])] - x0).cross(fine.vertices[static_cast<std::size_t>(t[2])] - x0);
    ASSERT_GT(n.dot(x0), 0.0);
  }
  EXPECT_LE(static_cast<int>(m.net_face_surface_faces.size()), listed) << "each once per net triangle";
  // Every embedding's weights are a foot point's: each ≥ 0, sum 1.
  for (const core::NetSurfacePoint& e : m.net_surface_points) {
    EXPECT_GE(e.weights.minCoeff(), 0.0);
    EXPECT_NEAR(e.weights.sum(), 1.0, 1e-12);
  }
}

TEST(NetSurfaceMap, AToolMeetsTheFineSurfaceWhereItStandsOffTheNet) {
  // A 2 mm sphere 0.5 mm into the fine sphere (radius 20 mm) over the middle of a net triangle
  // of the 42-node icosphere, whose plane lies ~2.5 mm below the fine surface there: without a
  // fine surface the sphere touches nothing; with it, a contact 0.5 mm deep (the fine sphere's
  // facets within 0.03 mm of its radius), whose shares go to that net triangle's nodes and sum
  // to 1, the normal into the organ.
  const double r = 0.002;
  const core::TriangleMesh net_mesh = core::make_icosphere(0.02, 1);
  const auto& t0 = net_mesh.triangles[7];
  const Vec3 dir = (net_mesh.vertices[static_cast<std::size_t>(t0[0])] + net_mesh.vertices[static_cast<std::size_t>(t0[1])] +
                    net_mesh.vertices[static_cast<std::size_t>(t0[2])])
                       .normalized();
  const Vec3 at = (0.02 + r - 5e-4) * dir;
  const core::Model bare = surface_map_organ(net_mesh, {}, r, at);
  core::Data db = core::make_data(bare);
  core::detect_contacts(bare, db);
  core::detect_node_contacts(bare, db);
  EXPECT_EQ(db.num_node_contacts, 0) << "the net's own triangle is beyond the sphere";

  const core::Model m = surface_map_organ(net_mesh, core::make_icosphere(0.02, 4), r, at);
  core::Data d = core::make_data(m);
  core::detect_contacts(m, d);
  core::detect_node_contacts(m, d);
  ASSERT_GT(d.num_node_contacts, 0);
  double shares = 0.0, deepest = 0.0;
  for (int c = 0; c < d.num_node_contacts; ++c) {
    const core::NodeContact& ct = d.node_contacts[static_cast<std::size_t>(c)];
    EXPECT_GE(ct.face, 0);
    EXPECT_NEAR(ct.face_weights.sum(), 1.0, 1e-12);
    EXPECT_LT(ct.normal.dot(dir), -0.95) << "into the organ";
    deepest = std::max(deepest, ct.depth);
    shares += ct.share;
    EXPECT_TRUE(ct.node == t0[0] || ct.node == t0[1] || ct.node == t0[2]) << ct.node;
  }
  EXPECT_NEAR(deepest, 5e-4, 3e-5);
  // One contact point per fine triangle of the dent or its nearest feature: the shares of each
  // point sum to 1.
  const double points = std::round(shares);
  EXPECT_NEAR(shares, points, 1e-9);
  EXPECT_GE(points, 1.0);
}

TEST(NetSurfaceMap, AFineSurfaceThatIsTheNetsOwnGivesTheNetsContacts) {
  // The net's own mesh as its fine surface (each vertex on a triangle through it, weight 1 at
  // that corner, no offset): for a sphere anywhere around the deformed organ, the same contacts
  // — the same depths, and per node the same share — as the net's own triangles.
  const double r = 0.002;
  const core::TriangleMesh mesh = core::make_icosphere(0.02, 2);
  const core::Model bare = surface_map_organ(mesh, {}, r, Vec3(0, 0, 0.05));
  const core::Model m = surface_map_organ(mesh, mesh, r, Vec3(0, 0, 0.05));
  core::Data db = core::make_data(bare), d = core::make_data(m);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (std::size_t i = 0; i < d.nodes.size(); ++i) {
    d.nodes[i].position += 3e-4 * Vec3(u(rng), u(rng), u(rng));
    db.nodes[i].position = d.nodes[i].position;
  }
  int touching = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Vec3 at = (0.02 + 3e-3 * u(rng)) * Vec3(u(rng), u(rng), u(rng)).normalized();
    db.bodies[1].position = d.bodies[1].position = at;
    core::detect_contacts(bare, db);
    core::detect_node_contacts(bare, db);
    core::detect_contacts(m, d);
    core::detect_node_contacts(m, d);
    const auto a = surface_map_shares(db), b = surface_map_shares(d);
    ASSERT_EQ(a.size(), b.size()) << "trial " << trial;
    for (const auto& [node, share] : a) {
      ASSERT_TRUE(b.count(node)) << "trial " << trial << " node " << node;
      EXPECT_NEAR(b.at(node), share, 1e-9) << "trial " << trial << " node " << node;
    }
    double da = 0.0, dm = 0.0;
    for (int c = 0; c < db.num_node_contacts; ++c) da = std::max(da, db.node_contacts[static_cast<std::size_t>(c)].depth);
    for (int c = 0; c < d.num_node_contacts; ++c) dm = std::max(dm, d.node_contacts[static_cast<std::size_t>(c)].depth);
    EXPECT_NEAR(da, dm, 1e-12) << "trial " << trial;
    touching += a.empty() ? 0 : 1;
  }
  EXPECT_GT(touching, 100);
}

TEST(NetSurfaceMap, PressingAFineSurfaceStepsWithoutAllocating) {
  // The tool coupled (god-object) and driven 3 mm past the fine surface of a 162-node net
  // carrying a 10 242-vertex surface: every step ok, contacts found, no allocation.
  const core::TriangleMesh fine = core::make_icosphere(0.02, 5);
  core::Model m = numen::test::organ::organ_model(core::make_icosphere(0.02, 2),
                                                  numen::test::organ::OrganParams{}, 1e-3,
                                                  core::CouplingMode::kGodObject, 0.0025,
                                                  Vec3(0, 0, 0.03));
  ASSERT_EQ(core::add_net_surface(m, 0, fine.vertices, fine.triangles,
                                  surface_map_nearest_faces(m, fine.vertices)),
            "");
  core::Data d = core::make_data(m);
  const int steps = numen::test::under_sanitizer() ? 200 : 800;
  int max_contacts = 0;
  std::int64_t count = 0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < steps; ++k) {
      const double s = std::min(1.0, k / (0.6 * steps));
      d.target.position = Vec3(0.003 * std::sin(0.01 * k), 0.0, 0.03 - s * (0.03 - 0.0225 + 0.003));
      core::step(m, d);
      ASSERT_EQ(d.status, core::kStepOk) << k;
      max_contacts = std::max(max_contacts, d.num_node_contacts);
    }
    count = guard.count();
  }
  EXPECT_EQ(count, 0);
  EXPECT_GT(max_contacts, 0);
  EXPECT_GT(d.nets[0].max_tie_stretch, 5e-4) << "the organ gave way under the tool";
}

TEST(NetSurfaceMap, ContactsAgainstEveryFineTriangle) {
  // A deformed 162-node organ carrying a 2 562-vertex surface, a 2 mm sphere at random places
  // around it: the contact points found (each a run of shares at one position) are those of a
  // search over every fine triangle at its vertices' mapped positions — one per triangle whose
  // closest point is inside it within r, with its depth, and one more at the nearest edge or
  // vertex point when that is nearer — so narrowing the candidates to the net triangles within
  // reach of a sphere misses none; each point's shares sum to 1.
  const double r = 0.002;
  const core::TriangleMesh fine = core::make_icosphere(0.02, 4);
  const core::Model m = surface_map_organ(core::make_icosphere(0.02, 2), fine, r, Vec3(0, 0, 0.05));
  core::Data d = core::make_data(m);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (core::NodeState& n : d.nodes) n.position += 4e-4 * Vec3(u(rng), u(rng), u(rng));
  std::vector<Vec3> x(fine.vertices.size());
  ASSERT_EQ(core::net_surface_positions(m, d, 0, x), fine.num_vertices());
  int touching = 0, several = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Vec3 at = (0.02 + 0.004 * u(rng)) * Vec3(u(rng), u(rng), u(rng)).normalized();
    d.bodies[1].position = at;
    core::detect_contacts(m, d);
    core::detect_node_contacts(m, d);
    // Reference over every fine triangle.
    std::vector<double> want;
    double face_distance = r, edge = r;
    for (const auto& t : m.net_surface_faces) {
      const Vec3 &a = x[static_cast<std::size_t>(t[0])], &b = x[static_cast<std::size_t>(t[1])],
                 &c = x[static_cast<std::size_t>(t[2])];
      int feature = 0;
      const Vec3 q = core::detail::closest_on_triangle(at, a, b, c, feature);
      const double dist = (at - q).norm();
      if (!(dist < r)) continue;
      if (feature == core::detail::kFace) {
        want.push_back(r - (b - a).cross(c - a).normalized().dot(at - q));
        face_distance = std::min(face_distance, dist);
      } else {
        edge = std::min(edge, dist);
      }
    }
    const bool with_edge = edge < face_distance;
    // Found: the distinct contact points, their depths and share sums.
    std::vector<double> got;
    std::vector<double> sums;
    for (int i = 0; i < d.num_node_contacts;) {
      const core::NodeContact& c0 = d.node_contacts[static_cast<std::size_t>(i)];
      double sum = 0.0;
      int j = i;
      for (; j < d.num_node_contacts && d.node_contacts[static_cast<std::size_t>(j)].position == c0.position; ++j)
        sum += d.node_contacts[static_cast<std::size_t>(j)].share;
      got.push_back(c0.depth);
      sums.push_back(sum);
      i = j;
    }
    ASSERT_EQ(got.size(), want.size() + (with_edge ? 1 : 0)) << "trial " << trial;
    // The triangles' contacts come first (in the candidates' order), the edge's last.
    std::sort(want.begin(), want.end());
    std::sort(got.begin(), got.begin() + static_cast<std::ptrdiff_t>(want.size()));
    for (std::size_t k = 0; k < want.size(); ++k) EXPECT_NEAR(got[k], want[k], 1e-12) << "trial " << trial;
    for (const double s : sums) EXPECT_NEAR(s, 1.0, 1e-12) << "trial " << trial;
    touching += got.empty() ? 0 : 1;
    several += got.size() > 1 ? 1 : 0;
  }
  std::printf("[fine surface] %d of 300 spheres touching, %d with several contact points\n", touching,
              several);
  EXPECT_GT(touching, 100);
  EXPECT_GT(several, 5);
}

TEST(NetSurfaceMap, PatchesSkipOnlyTheFineTrianglesNoSphereReaches) {
  // A 20 480-triangle surface on an 80-triangle net (every net triangle's riders in patches:
  // Model::net_face_surface_cluster), the net deformed (random moves of up to 1.5 mm and a 4 mm
  // dent), spheres of 1, 2.5 and 4 mm at random places around it: the contacts found are those
  // found without the patches (every rider of a near net triangle gathered), entry for entry and
  // to the bit, and the patches skip fine triangles on most calls that touch.
  const core::TriangleMesh fine = core::make_icosphere(0.02, 5);
  core::Model with = surface_map_organ(core::make_icosphere(0.02, 1), fine, 0.0025, Vec3(0, 0, 0.05));
  ASSERT_EQ(with.net_face_surface_cluster.size(), with.net_face_surface_faces.size());
  int multi = 0;
  for (const std::int32_t pc : with.net_face_surface_cluster) {
    ASSERT_GE(pc, 0) << "every rider is in a patch";
    multi += with.net_surface_clusters[static_cast<std::size_t>(pc)].parts > 1 ? 1 : 0;
  }
  EXPECT_GT(multi, 0) << "riders on two or three net triangles make patches of several records";
  // A patch's riders are consecutive, as many as its first record says, within one net triangle.
  std::vector<int> runs(with.net_surface_clusters.size(), 0);
  for (std::size_t f = 0; f + 1 < with.net_face_surface_begin.size(); ++f)
    for (auto k = static_cast<std::size_t>(with.net_face_surface_begin[f]);
         k < static_cast<std::size_t>(with.net_face_surface_begin[f + 1]);) {
      const std::int32_t pc = with.net_face_surface_cluster[k];
      const int riders = with.net_surface_clusters[static_cast<std::size_t>(pc)].riders;
      ASSERT_GT(riders, 0);
      ASSERT_LE(k + static_cast<std::size_t>(riders), static_cast<std::size_t>(with.net_face_surface_begin[f + 1]));
      for (int j = 0; j < riders; ++j) ASSERT_EQ(with.net_face_surface_cluster[k + static_cast<std::size_t>(j)], pc);
      ++runs[static_cast<std::size_t>(pc)];
      k += static_cast<std::size_t>(riders);
    }
  for (std::size_t pc = 0; pc < runs.size(); ++pc)
    EXPECT_EQ(runs[pc], with.net_surface_clusters[pc].parts > 0 ? 1 : 0) << "patch " << pc;
  EXPECT_LT(with.net_surface_clusters.size(), with.net_face_surface_faces.size() / 4);
  core::Model without = with;
  std::fill(without.net_face_surface_cluster.begin(), without.net_face_surface_cluster.end(), -1);
  core::Data dw = core::make_data(with), dn = core::make_data(without);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (std::size_t i = 0; i < dw.nodes.size(); ++i) {
    Vec3& x = dw.nodes[i].position;
    x += 1.5e-3 * Vec3(u(rng), u(rng), u(rng));
    if (x.z() < -0.015) x.z() += 4e-3;  // the dent at the lower pole
    dn.nodes[i].position = x;
  }
  const std::array<double, 3> radii{0.001, 0.0025, 0.004};
  int touching = 0, skipping = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const double r = radii[static_cast<std::size_t>(trial % 3)];
    with.body_spheres[0].radius = without.body_spheres[0].radius = r;
    const Vec3 at = (0.02 + 0.006 * u(rng)) * Vec3(u(rng), u(rng), u(rng)).normalized();
    dw.bodies[1].position = dn.bodies[1].position = at;
    for (auto [m, d] : {std::pair{&with, &dw}, std::pair{&without, &dn}}) {
      core::detect_contacts(*m, *d);
      core::detect_node_contacts(*m, *d);
    }
    ASSERT_EQ(dw.num_node_contacts, dn.num_node_contacts) << "trial " << trial;
    for (int c = 0; c < dw.num_node_contacts; ++c) {
      const core::NodeContact& a = dw.node_contacts[static_cast<std::size_t>(c)];
      const core::NodeContact& b = dn.node_contacts[static_cast<std::size_t>(c)];
      ASSERT_EQ(a.node, b.node) << "trial " << trial << " contact " << c;
      ASSERT_EQ(a.face, b.face) << "trial " << trial << " contact " << c;
      ASSERT_EQ(a.share, b.share) << "trial " << trial << " contact " << c;
      ASSERT_EQ(a.depth, b.depth) << "trial " << trial << " contact " << c;
      ASSERT_EQ(a.position, b.position) << "trial " << trial << " contact " << c;
      ASSERT_EQ(a.normal, b.normal) << "trial " << trial << " contact " << c;
      ASSERT_EQ(a.face_weights, b.face_weights) << "trial " << trial << " contact " << c;
    }
    if (dw.num_node_contacts == 0) continue;
    ++touching;
    skipping += dw.scratch->net.surface_patches_skipped > 0 ? 1 : 0;
    EXPECT_EQ(dn.scratch->net.surface_patches_skipped, 0) << "trial " << trial;
  }
  std::printf("[fine surface patches] %d of 600 spheres touching, %d of them skipping a patch\n",
              touching, skipping);
  EXPECT_GT(touching, 150);
  EXPECT_GT(skipping, touching / 2);
}

TEST(NetSurfaceMap, MultirateLoopsOnAFineSurfaceDoNotAllocate) {
  // The multirate god-object (10 kHz device loop, 1 ms scene loop) pressed 3 mm into a 162-node
  // organ carrying a 10 242-vertex surface and drawn along it: the scene loop's contacts are the
  // fine surface's (split on the net triangles its vertices ride on), the device loop's planes
  // and node carriers are built from them, and neither loop allocates.
  const double dt = 1e-4;
  const core::TriangleMesh fine = core::make_icosphere(0.02, 5);
  core::Model m = numen::test::organ::organ_model(core::make_icosphere(0.02, 2),
                                                  numen::test::organ::OrganParams{}, dt,
                                                  core::CouplingMode::kGodObject, 0.0025,
                                                  Vec3(0, 0, 0.03));
  ASSERT_EQ(core::add_net_surface(m, 0, fine.vertices, fine.triangles,
                                  surface_map_nearest_faces(m, fine.vertices)),
            "");
  auto owner = std::make_unique<core::MultirateGodObject>(m, 1, core::MultirateSettings{10, 0.002, {}});
  core::MultirateGodObject& mr = *owner;
  const int periods = numen::test::under_sanitizer() ? 1000 : 3000;
  int planes = 0;
  std::int64_t count = 0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < periods; ++k) {
      const double t = k * dt;
      mr.device_data().target.position =
          Vec3(0.03 * std::max(0.0, t - 0.1), 0.0, 0.03 - 0.105 * std::min(t, 0.1));  // to 19.5 mm
      mr.step();
      ASSERT_EQ(mr.device_data().status, core::kStepOk) << k;
      planes = std::max(planes, mr.planes().count);
    }
    count = guard.count();
  }
  std::printf("[fine surface multirate alloc] allocations %lld, planes <= %d\n",
              static_cast<long long>(count), planes);
  EXPECT_EQ(count, 0);
  EXPECT_GT(planes, 0) << "the fine surface's contacts reach the device loop";
}
