// Collision stage of the deformable nets (core/src/net/net_collision.cpp):
// detect_node_contacts against an every-node-against-everything reference on
// random scenes (every obstacle shape, sphere sets, other bodies' spheres),
// the documented order, exclusion of the net's own articulation, coincident
// centres, penetration outputs, capacity overflow, zero allocation and
// determinism.
#include "numen/core/net_collision.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"

#include "scratch/data_scratch.hpp"
#include "contact/narrowphase.hpp"
#include "build_features.hpp"

namespace numen::core {
namespace {
// Its own namespace: collision_test.cpp has helpers of the same names (Ref, Key,
// brute_force, random_scene) and the test programs compile as unity builds.
namespace net_collision_test {

/// A model with `materials` materials and, as body 0, the rigid component of
/// the nets (no spheres) at the origin.
Model net_model_base(int materials = 3) {
  Model m;
  m.initial_held_body = -1;
  for (int i = 0; i < materials; ++i) m.material_names.push_back("mat" + std::to_string(i));
  m.material_pairs.assign(static_cast<std::size_t>(materials * materials), MaterialPair{});
  BodyModel tool;
  tool.name = "tool";
  m.bodies.push_back(tool);
  return m;
}

/// Appends a body with `spheres` (body frame) at `position`; returns its index.
int add_sphere_body(Model& m, const Vec3& position, const std::vector<Sphere>& spheres,
                    int material = 0) {
  BodyModel b;
  b.name = "body" + std::to_string(m.bodies.size());
  b.sphere_begin = static_cast<int>(m.body_spheres.size());
  b.sphere_count = static_cast<int>(spheres.size());
  b.material = material;
  b.initial_pose.position = position;
  m.body_spheres.insert(m.body_spheres.end(), spheres.begin(), spheres.end());
  m.bodies.push_back(b);
  return m.num_bodies() - 1;
}

/// Appends an obstacle of `type`; the caller fills the shape's fields.
Obstacle& add_obstacle(Model& m, ShapeType type, const Vec3& position, const Quat& q,
                       int material) {
  Obstacle o;
  o.name = "obstacle" + std::to_string(m.obstacles.size());
  o.type = type;
  o.pose = Pose{position, q};
  o.material = material;
  m.obstacles.push_back(o);
  return m.obstacles.back();
}

/// Appends a sphere-set obstacle over [begin, begin + count) of static_spheres.
void add_sphere_range(Model& m, int begin, int count, int material) {
  Obstacle& o = add_obstacle(m, ShapeType::kSphereSet, Vec3::Zero(), Quat::Identity(), material);
  o.sphere_begin = begin;
  o.sphere_count = count;
}

/// Appends a net on body 0: an icosphere of `radius` and `subdivisions`.
void add_icosphere_net(Model& m, double radius, int subdivisions, int material = 1,
                       double node_radius = 0.0) {
  NetSettings s;
  s.name = "net" + std::to_string(m.nets.size());
  s.body = 0;
  s.material = material;
  s.mass = 0.1;
  s.stiffness = 100.0;
  s.tie_stiffness = 50.0;
  s.node_radius = node_radius;
  ASSERT_EQ(add_net(m, make_icosphere(radius, subdivisions), s), "");
}

void finalize(Model& m) { ASSERT_EQ(finalize_model(m), ""); }

Quat random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Quat q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q;
}

std::vector<Sphere> random_ball(std::mt19937& rng, int n, const Vec3& centre, double radius,
                                double rmin, double rmax) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> rad(rmin, rmax);
  std::vector<Sphere> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec3 p(u(rng), u(rng), u(rng));
    if (p.squaredNorm() <= 1.0) out.push_back(Sphere{centre + radius * p, rad(rng)});
  }
  return out;
}

/// Places every node of net `k` at its rest position on the pose (x, q) of
/// the rigid component, plus a random offset of at most `noise` per axis, and
/// moves the rigid component there.
void place_net(const Model& m, Data& d, int k, const Vec3& x, const Quat& q, std::mt19937& rng,
               double noise) {
  std::uniform_real_distribution<double> u(-noise, noise);
  const NetModel& net = m.nets[static_cast<std::size_t>(k)];
  d.bodies[static_cast<std::size_t>(net.body)].position = x;
  d.bodies[static_cast<std::size_t>(net.body)].orientation = q;
  for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i)
    d.nodes[static_cast<std::size_t>(i)].position =
        x + q * m.node_rest[static_cast<std::size_t>(i)] + Vec3(u(rng), u(rng), u(rng));
}

// node, body_b, obstacle, sphere_b, material_pair
using Key = std::tuple<int, int, int, int, int>;

struct Ref {
  Key key;
  ContactGeometry g;
  Vec3 r_b = Vec3::Zero();
  bool operator<(const Ref& o) const { return key < o.key; }
};

/// Reference: every node sphere against every obstacle (every sphere of every
/// sphere set) and every sphere of every body outside the net's articulation,
/// with the narrow-phase functions directly.
std::vector<Ref> brute_force(const Model& m, const Data& d) {
  std::vector<Ref> out;
  const int nm = m.num_materials();
  ContactGeometry g;
  for (const NetModel& net : m.nets) {
    const int mat = net.material * nm;
    const Vec3& com = d.bodies[static_cast<std::size_t>(net.body)].position;
    const int own_tree = m.articulation.body_tree[static_cast<std::size_t>(net.body)];
    for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
      const Vec3& c = d.nodes[static_cast<std::size_t>(i)].position;
      const double r = m.node_radius[static_cast<std::size_t>(i)];
      const Vec3 fb = c - com;
      auto add = [&](int body, int o, int sb, int mp, const Vec3& r_b) {
        out.push_back(Ref{Key{i, body, o, sb, mp}, g, r_b});
      };
      for (int o = 0; o < static_cast<int>(m.obstacles.size()); ++o) {
        const Obstacle& ob = m.obstacles[static_cast<std::size_t>(o)];
        const Vec3 z = ob.pose.orientation * Vec3::UnitZ();
        const Vec3& p = ob.pose.position;
        const int mp = mat + ob.material;
        switch (ob.type) {
          case ShapeType::kPlane:
            if (sphere_plane(c, r, p, z, g)) add(-1, o, -1, mp, Vec3::Zero());
            break;
          case ShapeType::kBox:
            if (sphere_box(c, r, p, ob.pose.orientation.toRotationMatrix(), ob.half_extents, g))
              add(-1, o, -1, mp, Vec3::Zero());
            break;
          case ShapeType::kSphere:
            if (sphere_sphere(c, r, p, ob.radius, fb, g)) add(-1, o, -1, mp, Vec3::Zero());
            break;
          case ShapeType::kCapsule:
            if (sphere_capsule(c, r, p, z, ob.half_length, ob.radius, g))
              add(-1, o, -1, mp, Vec3::Zero());
            break;
          case ShapeType::kSphereSet:
            for (int s = ob.sphere_begin; s < ob.sphere_begin + ob.sphere_count; ++s) {
              const Sphere& ss = m.static_spheres[static_cast<std::size_t>(s)];
              if (sphere_sphere(c, r, ss.center, ss.radius, fb, g)) add(-1, o, s, mp, Vec3::Zero());
            }
            break;
          case ShapeType::kMesh:
            if (sphere_mesh(c, r, m.meshes[static_cast<std::size_t>(ob.mesh)], ob.pose, g))
              add(-1, o, -1, mp, Vec3::Zero());
            break;
        }
      }
      for (int b = 0; b < m.num_bodies(); ++b) {
        if (m.articulation.body_tree[static_cast<std::size_t>(b)] == own_tree) continue;
        const BodyModel& bm = m.bodies[static_cast<std::size_t>(b)];
        const BodyState& st = d.bodies[static_cast<std::size_t>(b)];
        const Mat3 rot = st.orientation.toRotationMatrix();
        for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
          const Sphere& sp = m.body_spheres[static_cast<std::size_t>(s)];
          if (sphere_sphere(c, r, st.position + rot * sp.center, sp.radius, fb, g))
            add(b, -1, s, mat + bm.material, g.position - st.position);
        }
      }
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Ref> detected(const Data& d) {
  std::vector<Ref> out;
  for (int i = 0; i < d.num_node_contacts; ++i) {
    const NodeContact& c = d.node_contacts[static_cast<std::size_t>(i)];
    ContactGeometry g;
    g.position = c.position;
    g.normal = c.normal;
    g.depth = c.depth;
    out.push_back(Ref{Key{c.node, c.body_b, c.obstacle, c.sphere_b, c.material_pair}, g, c.r_b});
  }
  std::sort(out.begin(), out.end());
  return out;
}

void expect_same(const std::vector<Ref>& got, const std::vector<Ref>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].key, want[i].key) << "contact " << i;
    EXPECT_NEAR(got[i].g.depth, want[i].g.depth, 1e-14);
    EXPECT_LT((got[i].g.normal - want[i].g.normal).norm(), 1e-12);
    EXPECT_LT((got[i].g.position - want[i].g.position).norm(), 1e-12);
    EXPECT_LT((got[i].r_b - want[i].r_b).norm(), 1e-12);
  }
}

/// The documented order: per node; for a node, primitive obstacles in
/// increasing index, then sphere-set spheres, then bodies in index order.
void expect_documented_order(const Model& m, const Data& d) {
  auto rank = [&](const NodeContact& c) {
    if (c.body_b >= 0) return std::tuple<int, int, int>(c.node, 2, c.body_b);
    if (m.obstacles[static_cast<std::size_t>(c.obstacle)].type == ShapeType::kSphereSet)
      return std::tuple<int, int, int>(c.node, 1, 0);
    return std::tuple<int, int, int>(c.node, 0, c.obstacle);
  };
  for (int i = 1; i < d.num_node_contacts; ++i) {
    const auto a = rank(d.node_contacts[static_cast<std::size_t>(i - 1)]);
    const auto b = rank(d.node_contacts[static_cast<std::size_t>(i)]);
    ASSERT_TRUE(a < b || (a == b && std::get<1>(a) > 0)) << "contact " << i;
  }
}

/// The random scenes' mesh obstacle (icosphere, 320 triangles), built once for every scene: its
/// narrow band's build, once a scene, took most of NetCollision.EqualsBruteForceOnRandomScenes
/// under ASan+UBSan.
const MeshShape& mesh_obstacle_shape() {
  static const MeshShape shape = [] {
    MeshShape s;
    EXPECT_EQ(build_mesh_shape(make_icosphere(0.04, 2), s), "");
    return s;
  }();
  return shape;
}

/// Random scene: two nets on body 0 (material 1 and 2); a tilted plane, boxes,
/// spheres and capsules; two sphere sets sharing a range (an organ) and an
/// empty one; body 1 with spheres jointed to body 0 (never collides with the
/// nets), free bodies 2 and 3 with spheres, body 4 without spheres.
Model random_scene(std::uint32_t seed) {
  std::mt19937 rng(seed);
  Model m = net_model_base(3);
  add_icosphere_net(m, 0.04, 2, 1);
  add_icosphere_net(m, 0.025, 1, 2);
  const std::vector<Sphere> organ =
      random_ball(rng, 300, Vec3(0.0, 0.0, -0.05), 0.07, 0.004, 0.012);
  m.static_spheres = organ;
  add_sphere_range(m, 0, 300, 0);
  add_sphere_range(m, 120, 40, 2);  // spheres listed by two sets: two entries
  add_sphere_range(m, 0, 0, 1);
  add_obstacle(m, ShapeType::kPlane, Vec3(0, 0, -0.1),
               rotation_between(Vec3::UnitZ(), Vec3(0.1, -0.05, 1.0).normalized()), 0);
  std::uniform_real_distribution<double> at(-0.12, 0.12);
  std::uniform_real_distribution<double> size(0.01, 0.04);
  for (int i = 0; i < 3; ++i) {
    add_obstacle(m, ShapeType::kBox, Vec3(at(rng), at(rng), at(rng)), random_rotation(rng), 2)
        .half_extents = Vec3(size(rng), size(rng), size(rng));
    add_obstacle(m, ShapeType::kSphere, Vec3(at(rng), at(rng), at(rng)), Quat::Identity(), 1)
        .radius = size(rng);
    Obstacle& cap = add_obstacle(m, ShapeType::kCapsule, Vec3(at(rng), at(rng), at(rng)),
                                 random_rotation(rng), 0);
    cap.half_length = size(rng);
    cap.radius = 0.5 * size(rng);
  }
  m.meshes.push_back(mesh_obstacle_shape());  // a closed mesh obstacle
  add_obstacle(m, ShapeType::kMesh, Vec3(0.02, -0.03, 0.01), random_rotation(rng), 1).mesh = 0;
  const int jointed = add_sphere_body(m, Vec3(0.05, 0, 0),
                                      random_ball(rng, 12, Vec3::Zero(), 0.03, 0.005, 0.01), 2);
  add_sphere_body(m, Vec3(-0.06, 0.03, 0), random_ball(rng, 20, Vec3::Zero(), 0.03, 0.004, 0.01),
                  1);
  add_sphere_body(m, Vec3(0.03, -0.07, 0.02), random_ball(rng, 15, Vec3::Zero(), 0.03, 0.004, 0.01),
                  0);
  add_sphere_body(m, Vec3(0.1, 0.1, 0.1), {}, 0);
  JointModel hinge;
  hinge.name = "hinge";
  hinge.type = JointType::kRevolute;
  hinge.parent = 0;
  hinge.child = jointed;
  hinge.frame_parent = Pose{Vec3(0.025, 0, 0), Quat::Identity()};
  hinge.frame_child = Pose{Vec3(-0.025, 0, 0), Quat::Identity()};
  m.joints.push_back(hinge);
  finalize(m);
  return m;
}

/// Random poses: the two nets and the free bodies wander over the scene, the
/// nodes are perturbed around their rest shape.
void scramble(const Model& m, Data& d, std::mt19937& rng) {
  std::uniform_real_distribution<double> at(-0.12, 0.12);
  place_net(m, d, 0, Vec3(at(rng), at(rng), at(rng)), random_rotation(rng), rng, 0.004);
  // The second net shares the rigid component: place it relative to the same pose.
  const BodyState tool = d.bodies[0];
  place_net(m, d, 1, Vec3(at(rng), at(rng), at(rng)), random_rotation(rng), rng, 0.004);
  d.bodies[0] = tool;  // rigid component (fallback reference) at the first net's pose
  for (int b = 1; b < m.num_bodies(); ++b) {
    BodyState& s = d.bodies[static_cast<std::size_t>(b)];
    // Bodies near the first net's rigid component so that they meet its nodes.
    s.position = tool.position + Vec3(at(rng), at(rng), at(rng)) * 0.5;
    s.orientation = random_rotation(rng);
  }
}

TEST(NetCollision, EqualsBruteForceOnRandomScenes) {
  NUMEN_REQUIRE_ARTICULATION();
  int by_kind[7] = {0, 0, 0, 0, 0, 0, 0};  // plane, box, sphere, capsule, sphere set, mesh, body
  for (std::uint32_t seed : {1u, 2u, 3u, 4u}) {
    const Model m = random_scene(seed);
    Data d = make_data(m);
    if (seed == 2u) {  // wrap the grid query stamp, with stamps left from long ago
      d.scratch->collision.stamp = std::numeric_limits<std::uint32_t>::max() - 100;
      std::fill(d.scratch->collision.entry_stamp.begin(), d.scratch->collision.entry_stamp.end(), 1u);
    }
    std::mt19937 rng(seed * 104729u);
    for (int t = 0; t < 40; ++t) {
      scramble(m, d, rng);
      detect_contacts(m, d);
      detect_node_contacts(m, d);
      SCOPED_TRACE(testing::Message() << "seed " << seed << " step " << t);
      ASSERT_EQ(d.status & kContactOverflow, 0u);
      const std::vector<Ref> want = brute_force(m, d);
      expect_same(detected(d), want);
      expect_documented_order(m, d);
      double deepest[2] = {0.0, 0.0};
      for (const Ref& r : want) {
        const int node = std::get<0>(r.key);
        const int net = m.node_net[static_cast<std::size_t>(node)];
        deepest[net] = std::max(deepest[net], r.g.depth);
        const int o = std::get<2>(r.key);
        ++by_kind[o < 0 ? 6 : static_cast<int>(m.obstacles[static_cast<std::size_t>(o)].type)];
        EXPECT_NE(std::get<1>(r.key), 1) << "body 1 is jointed to the rigid component";
        EXPECT_EQ(std::get<4>(r.key) / m.num_materials(),
                  m.nets[static_cast<std::size_t>(net)].material);
      }
      EXPECT_EQ(d.nets[0].max_penetration, deepest[0]);
      EXPECT_EQ(d.nets[1].max_penetration, deepest[1]);
      EXPECT_GE(d.max_penetration, std::max(deepest[0], deepest[1]));
    }
  }
  std::printf("[net collision] contacts compared: plane %d, box %d, sphere %d, capsule %d, "
              "sphere set %d, mesh %d, body %d\n",
              by_kind[0], by_kind[1], by_kind[2], by_kind[3], by_kind[4], by_kind[5], by_kind[6]);
  for (int k = 0; k < 7; ++k) EXPECT_GT(by_kind[k], 10) << "kind " << k << " barely exercised";
}

TEST(NetCollision, PlaneContactsOfASunkenNet) {
  Model m = net_model_base(2);
  add_icosphere_net(m, 0.05, 2, 1, 0.01);
  add_obstacle(m, ShapeType::kPlane, Vec3::Zero(), Quat::Identity(), 0);
  finalize(m);
  Data d = make_data(m);
  std::mt19937 rng(3);
  place_net(m, d, 0, Vec3(0, 0, 0.045), Quat::Identity(), rng, 0.0);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  int below = 0;
  for (int i = 0; i < m.num_nodes(); ++i)
    below += d.nodes[static_cast<std::size_t>(i)].position.z() < 0.01;
  EXPECT_GT(below, 5);
  ASSERT_EQ(d.num_node_contacts, below);
  for (int k = 0; k < d.num_node_contacts; ++k) {
    const NodeContact& c = d.node_contacts[static_cast<std::size_t>(k)];
    const double z = d.nodes[static_cast<std::size_t>(c.node)].position.z();
    EXPECT_EQ(c.normal, Vec3::UnitZ());
    EXPECT_NEAR(c.depth, 0.01 - z, 1e-15);
    EXPECT_EQ(c.obstacle, 0);
    EXPECT_EQ(c.body_b, -1);
    EXPECT_EQ(c.sphere_b, -1);
    EXPECT_EQ(c.material_pair, 1 * 2 + 0);
    EXPECT_EQ(c.force, Vec3::Zero());
    EXPECT_EQ(c.r_b, Vec3::Zero());
    EXPECT_FALSE(c.active);
  }
  EXPECT_NEAR(d.nets[0].max_penetration, 0.015, 1e-12);  // bottom node at z = −0.005
  EXPECT_NEAR(d.max_penetration, 0.015, 1e-12);
}

TEST(NetCollision, NodeAgainstAnotherBodysSpheres) {
  Model m = net_model_base(3);
  add_icosphere_net(m, 0.05, 1, 2, 0.01);  // 42 nodes
  const int other =
      add_sphere_body(m, Vec3(0.07, 0, 0), {{Vec3(0, 0, 0), 0.015}, {Vec3(0, 0, 0.5), 0.01}}, 1);
  finalize(m);
  Data d = make_data(m);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  // The node at (0.05, 0, 0) at least (an edge midpoint of the icosahedron).
  const std::vector<Ref> want = brute_force(m, d);
  ASSERT_FALSE(want.empty());
  expect_same(detected(d), want);
  for (int k = 0; k < d.num_node_contacts; ++k) {
    const NodeContact& c = d.node_contacts[static_cast<std::size_t>(k)];
    EXPECT_EQ(c.body_b, other);
    EXPECT_EQ(c.obstacle, -1);
    EXPECT_EQ(c.sphere_b, m.bodies[static_cast<std::size_t>(other)].sphere_begin);
    EXPECT_EQ(c.material_pair, 2 * 3 + 1);
    EXPECT_LT((c.r_b - (c.position - d.bodies[static_cast<std::size_t>(other)].position)).norm(),
              1e-15);
    EXPECT_LT(c.normal.x(), 0.0) << "pushes the node away from the body (on its −x side)";
  }
  // Moved away: no contact, max penetration back to 0.
  d.bodies[static_cast<std::size_t>(other)].position = Vec3(0.5, 0, 0);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  EXPECT_EQ(d.num_node_contacts, 0);
  EXPECT_EQ(d.nets[0].max_penetration, 0.0);
}

// The contacts' buffer is shared: the held springs (a grasp's, a needle's puncture ties, a
// thread's eyelets on tissue: NodeContact::held) go after the node contacts, so a later step's
// contact lands in a slot an earlier step's spring filled. It is a penalty contact all the same,
// every field as in a fresh buffer: a stale `held` made it a spring of no force that the tool
// went through (the suturing scene's needle tunnelled into its pad, docs/suturing.md).
TEST(NetCollision, AContactInASlotAnEarlierHeldSpringFilledIsAPenaltyContact) {
  Model m = net_model_base(3);
  add_icosphere_net(m, 0.05, 1, 2, 0.01);  // 42 nodes
  add_sphere_body(m, Vec3(0.07, 0, 0), {{Vec3(0, 0, 0), 0.015}}, 1);
  finalize(m);
  Data fresh = make_data(m);
  Data reused = make_data(m);
  for (NodeContact& c : reused.node_contacts) {  // an earlier step's springs everywhere
    c.held = true;
    c.active = true;
    c.engaged = true;
    c.primary = true;
    c.blend = 0.5;
    c.stiffness = 1000.0;
    c.damping = 1.0;
    c.friction = 2.0;
    c.weight_normal = 3.0;
    c.weight_isotropic = 4.0;
    c.force = Vec3(1, 2, 3);
    c.normal_velocity = 0.1;
  }
  for (Data* d : {&fresh, &reused}) {
    detect_contacts(m, *d);
    detect_node_contacts(m, *d);
  }
  ASSERT_GT(fresh.num_node_contacts, 0);
  ASSERT_EQ(reused.num_node_contacts, fresh.num_node_contacts);
  for (int k = 0; k < fresh.num_node_contacts; ++k) {
    const NodeContact& a = reused.node_contacts[static_cast<std::size_t>(k)];
    const NodeContact& b = fresh.node_contacts[static_cast<std::size_t>(k)];
    EXPECT_FALSE(a.held) << "contact " << k << ": a penalty contact, not a spring";
    EXPECT_EQ(std::tie(a.active, a.engaged, a.primary, a.node, a.body_b, a.sphere_b, a.face),
              std::tie(b.active, b.engaged, b.primary, b.node, b.body_b, b.sphere_b, b.face))
        << "contact " << k;
    EXPECT_EQ(std::tie(a.blend, a.stiffness, a.damping, a.friction, a.weight_normal, a.weight_isotropic,
                       a.normal_velocity, a.depth, a.share),
              std::tie(b.blend, b.stiffness, b.damping, b.friction, b.weight_normal, b.weight_isotropic,
                       b.normal_velocity, b.depth, b.share))
        << "contact " << k;
    EXPECT_EQ(a.force, b.force) << "contact " << k;
  }
}

TEST(NetCollision, IgnoresItsRigidComponentAndItsArticulation) {
  NUMEN_REQUIRE_ARTICULATION();
  Model m = net_model_base(1);
  // The rigid component itself carries a sphere overlapping its own net.
  m.bodies[0].sphere_begin = 0;
  m.bodies[0].sphere_count = 1;
  m.body_spheres.push_back(Sphere{Vec3(0.05, 0, 0), 0.02});
  add_icosphere_net(m, 0.05, 2, 0, 0.01);
  const std::vector<Sphere> ball = {{Vec3::Zero(), 0.02}};
  const int jointed = add_sphere_body(m, Vec3(0, 0.05, 0), ball);     // hinged to body 0
  const int grandchild = add_sphere_body(m, Vec3(0, 0, 0.05), ball);  // hinged to `jointed`
  const int free_body = add_sphere_body(m, Vec3(-0.05, 0, 0), ball);
  JointModel hinge;
  hinge.name = "hinge";
  hinge.type = JointType::kRevolute;
  hinge.parent = 0;
  hinge.child = jointed;
  hinge.frame_parent = Pose{Vec3(0, 0.05, 0), Quat::Identity()};
  hinge.frame_child = Pose{Vec3::Zero(), Quat::Identity()};
  m.joints.push_back(hinge);
  hinge.name = "hinge2";
  hinge.parent = jointed;
  hinge.child = grandchild;
  hinge.frame_parent = Pose{Vec3(0, -0.05, 0.05), Quat::Identity()};
  m.joints.push_back(hinge);
  finalize(m);
  Data d = make_data(m);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  ASSERT_GT(d.num_node_contacts, 0);
  for (int k = 0; k < d.num_node_contacts; ++k)
    EXPECT_EQ(d.node_contacts[static_cast<std::size_t>(k)].body_b, free_body) << "contact " << k;
  expect_same(detected(d), brute_force(m, d));
}

TEST(NetCollision, CoincidentCentresPushFromTheRigidComponent) {
  Model m = net_model_base(1);
  add_icosphere_net(m, 0.05, 0, 0, 0.01);  // 12 nodes
  add_obstacle(m, ShapeType::kSphere, Vec3(2, 0, 0), Quat::Identity(), 0).radius = 0.03;
  m.static_spheres = {{Vec3(0, 2, 0), 0.03}};
  add_sphere_range(m, 0, 1, 0);
  const int other = add_sphere_body(m, Vec3(0, 0, 2), {{Vec3::Zero(), 0.03}});
  finalize(m);
  Data d = make_data(m);
  d.bodies[0].position = Vec3(1, 1, 1);
  d.nodes[0].position = Vec3(2, 0, 0);  // on the sphere obstacle's centre
  d.nodes[1].position = Vec3(0, 2, 0);  // on the sphere-set sphere's centre
  d.nodes[2].position = Vec3(0, 0, 2);  // on the other body's sphere centre
  for (std::size_t i = 3; i < d.nodes.size(); ++i) d.nodes[i].position = Vec3(-5, -5, -5);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  ASSERT_EQ(d.num_node_contacts, 3);
  for (int k = 0; k < 3; ++k) {
    const NodeContact& c = d.node_contacts[static_cast<std::size_t>(k)];
    EXPECT_EQ(c.node, k);
    const Vec3 want = (d.nodes[static_cast<std::size_t>(k)].position - Vec3(1, 1, 1)).normalized();
    EXPECT_LT((c.normal - want).norm(), 1e-15) << "contact " << k;
    EXPECT_NEAR(c.depth, 0.04, 1e-15);
  }
  EXPECT_EQ(d.node_contacts[2].body_b, other);
  // The rigid component's COM on the node too: +z.
  d.bodies[0].position = Vec3(2, 0, 0);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  ASSERT_EQ(d.num_node_contacts, 3);
  EXPECT_EQ(d.node_contacts[0].normal, Vec3::UnitZ());
}

TEST(NetCollision, RaisesMaxPenetrationAndFillsEachNet) {
  Model m = net_model_base(1);
  add_icosphere_net(m, 0.05, 1, 0, 0.01);
  add_icosphere_net(m, 0.05, 1, 0, 0.01);
  add_obstacle(m, ShapeType::kPlane, Vec3::Zero(), Quat::Identity(), 0);
  add_sphere_body(m, Vec3(5, 0, 0.0), {{Vec3::Zero(), 0.1}});  // a body 0.1 deep in the plane
  finalize(m);
  Data d = make_data(m);
  std::mt19937 rng(1);
  place_net(m, d, 0, Vec3(0, 0, 0.05), Quat::Identity(), rng, 0.0);  // bottom node 0.01 deep
  place_net(m, d, 1, Vec3(0, 0, 1.0), Quat::Identity(), rng, 0.0);   // clear
  detect_contacts(m, d);
  ASSERT_NEAR(d.max_penetration, 0.1, 1e-15);
  detect_node_contacts(m, d);
  EXPECT_NEAR(d.max_penetration, 0.1, 1e-15) << "not lowered by shallower node contacts";
  EXPECT_NEAR(d.nets[0].max_penetration, 0.01, 1e-15);
  EXPECT_EQ(d.nets[1].max_penetration, 0.0);
  place_net(m, d, 1, Vec3(0, 0, -0.1), Quat::Identity(), rng, 0.0);  // deepest node 0.16
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  EXPECT_NEAR(d.nets[1].max_penetration, 0.16, 1e-15);
  EXPECT_NEAR(d.max_penetration, 0.16, 1e-15);
}

TEST(NetCollision, OverflowKeepsTheFirstAndCountsOncePerStep) {
  const int nodes_per_net = 2562;
  const int nets = kMaxNodeContacts / nodes_per_net + 1;
  const int total = nets * nodes_per_net;
  Model m = net_model_base(1);
  for (int k = 0; k < nets; ++k) add_icosphere_net(m, 0.05, 4, 0, 0.01);
  add_obstacle(m, ShapeType::kPlane, Vec3::Zero(), Quat::Identity(), 0);
  // A body whose own contacts overflow kMaxContacts when it is lowered.
  std::vector<Sphere> slab;
  for (int i = 0; i <= kMaxContacts; ++i) slab.push_back(Sphere{Vec3(0.01 * i, 5, 0), 0.005});
  const int slab_body = add_sphere_body(m, Vec3(0, 0, 1.0), slab);
  finalize(m);
  Data d = make_data(m);
  std::mt19937 rng(1);
  for (int k = 0; k < nets; ++k) place_net(m, d, k, Vec3(0, 0, -1.0), Quat::Identity(), rng, 0.0);
  d.status = kSolverNotConverged;  // set by another stage: must survive

  detect_contacts(m, d);
  detect_node_contacts(m, d);
  EXPECT_EQ(d.num_node_contacts, kMaxNodeContacts);
  EXPECT_EQ(d.contacts_dropped, total - kMaxNodeContacts);
  EXPECT_EQ(d.contact_overflow_steps, 1);
  EXPECT_EQ(d.status, static_cast<std::uint32_t>(kSolverNotConverged | kContactOverflow));
  for (int i = 0; i < kMaxNodeContacts; ++i)
    ASSERT_EQ(d.node_contacts[static_cast<std::size_t>(i)].node, i) << "the first ones are kept";
  // Dropped contacts still count in the penetration: the last net is as deep.
  EXPECT_NEAR(d.nets[static_cast<std::size_t>(nets - 1)].max_penetration, 1.06, 1e-12);

  // Bodies overflow too in the same step: still one overflow step.
  d.bodies[static_cast<std::size_t>(slab_body)].position.z() = 0.0;
  detect_contacts(m, d);
  EXPECT_EQ(d.contact_overflow_steps, 2);
  detect_node_contacts(m, d);
  EXPECT_EQ(d.contact_overflow_steps, 2);
  EXPECT_EQ(d.contacts_dropped, 1 + total - kMaxNodeContacts);

  // Nodes lifted clear: the bodies' overflow alone.
  for (int k = 0; k < nets; ++k) place_net(m, d, k, Vec3(0, 0, 1.0), Quat::Identity(), rng, 0.0);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  EXPECT_EQ(d.num_node_contacts, 0);
  EXPECT_EQ(d.contacts_dropped, 1);
  EXPECT_EQ(d.contact_overflow_steps, 3);

  // Everything clear: the overflow bit goes, the others stay.
  d.bodies[static_cast<std::size_t>(slab_body)].position.z() = 1.0;
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  EXPECT_EQ(d.contacts_dropped, 0);
  EXPECT_EQ(d.contact_overflow_steps, 3);
  EXPECT_EQ(d.status, static_cast<std::uint32_t>(kSolverNotConverged));
}

TEST(NetCollision, NothingToDoWithoutNetsOrWithNonFiniteNodes) {
  Model m = net_model_base(1);
  add_obstacle(m, ShapeType::kPlane, Vec3::Zero(), Quat::Identity(), 0);
  finalize(m);
  Data d = make_data(m);
  detect_contacts(m, d);
  detect_node_contacts(m, d);
  EXPECT_EQ(d.num_node_contacts, 0);
  EXPECT_TRUE(d.node_contacts.empty());

  Model m2 = net_model_base(1);
  add_icosphere_net(m2, 0.05, 1, 0, 0.01);
  add_obstacle(m2, ShapeType::kPlane, Vec3::Zero(), Quat::Identity(), 0);
  finalize(m2);
  Data d2 = make_data(m2);
  std::mt19937 rng(1);
  place_net(m2, d2, 0, Vec3(0, 0, -1), Quat::Identity(), rng, 0.0);  // all under the plane
  d2.nodes[3].position.x() = std::numeric_limits<double>::quiet_NaN();
  d2.nodes[5].position.z() = -std::numeric_limits<double>::infinity();
  detect_contacts(m2, d2);
  detect_node_contacts(m2, d2);
  EXPECT_EQ(d2.num_node_contacts, m2.num_nodes() - 2) << "non-finite nodes are skipped";
  for (int k = 0; k < d2.num_node_contacts; ++k)
    EXPECT_TRUE(d2.node_contacts[static_cast<std::size_t>(k)].position.allFinite());
}

// ---- real-time properties -------------------------------------------------------

TEST(NetCollisionRealTime, NoHeapAllocation) {
  NUMEN_REQUIRE_ARTICULATION();
  const Model m = random_scene(7);
  Data d = make_data(m);
  std::mt19937 rng(11);
  std::int64_t contacts = 0;
  std::int64_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int t = 0; t < 2000; ++t) {
      scramble(m, d, rng);
      detect_contacts(m, d);
      detect_node_contacts(m, d);
      contacts += d.num_node_contacts;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(contacts, 2000);
}

TEST(NetCollisionRealTime, DeterministicWhateverTheScratchHistory) {
  NUMEN_REQUIRE_ARTICULATION();
  const Model m = random_scene(5);
  Data d1 = make_data(m);
  Data d2 = make_data(m);
  std::mt19937 other(99);
  for (int t = 0; t < 30; ++t) {  // d2 visits other poses first (stamps, sweep order, scratch)
    scramble(m, d2, other);
    detect_contacts(m, d2);
    detect_node_contacts(m, d2);
  }
  std::mt19937 rng(5);
  int with_contacts = 0;
  for (int t = 0; t < 30; ++t) {
    scramble(m, d1, rng);
    d2.bodies = d1.bodies;
    d2.nodes = d1.nodes;
    for (Data* d : {&d1, &d2}) {
      detect_contacts(m, *d);
      detect_node_contacts(m, *d);
    }
    ASSERT_EQ(d1.num_node_contacts, d2.num_node_contacts) << "step " << t;
    EXPECT_EQ(d1.max_penetration, d2.max_penetration);
    for (int i = 0; i < d1.num_node_contacts; ++i) {
      const NodeContact& a = d1.node_contacts[static_cast<std::size_t>(i)];
      const NodeContact& b = d2.node_contacts[static_cast<std::size_t>(i)];
      ASSERT_EQ(std::tie(a.node, a.body_b, a.obstacle, a.sphere_b, a.material_pair),
                std::tie(b.node, b.body_b, b.obstacle, b.sphere_b, b.material_pair))
          << "step " << t << " contact " << i;
      EXPECT_EQ(a.position, b.position);  // bitwise equal
      EXPECT_EQ(a.normal, b.normal);
      EXPECT_EQ(a.depth, b.depth);
      EXPECT_EQ(a.r_b, b.r_b);
    }
    with_contacts += d1.num_node_contacts > 0;
  }
  EXPECT_GT(with_contacts, 20);
}

}  // namespace net_collision_test
}  // namespace
}  // namespace numen::core
