// Collision stage (core/src/contact/collision.cpp): detect_contacts against an O(n²)
// reference on random scenes, contact conventions, obstacle bounds, capacity
// overflow, zero allocation and determinism.
#include "numen/core/collision.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

#include "scratch/data_scratch.hpp"
#include "contact/narrowphase.hpp"

namespace numen::core {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Builds a Model piece by piece.
struct Scene {
  Model model;

  explicit Scene(int num_materials = 1) {
    model.material_names.clear();
    for (int i = 0; i < num_materials; ++i) model.material_names.push_back(std::to_string(i));
    model.material_pairs.assign(static_cast<std::size_t>(num_materials * num_materials),
                                MaterialPair{});
    model.initial_held_body = -1;
  }
  int body(const Vec3& position, const Quat& orientation, const std::vector<Sphere>& spheres,
           int material = 0) {
    BodyModel b;
    b.name = std::to_string(model.bodies.size());
    b.sphere_begin = static_cast<int>(model.body_spheres.size());
    b.sphere_count = static_cast<int>(spheres.size());
    b.material = material;
    b.initial_pose = Pose{position, orientation};
    model.body_spheres.insert(model.body_spheres.end(), spheres.begin(), spheres.end());
    model.bodies.push_back(b);
    return static_cast<int>(model.bodies.size()) - 1;
  }
  int obstacle(ShapeType type, const Vec3& position, const Quat& orientation, int material = 0) {
    Obstacle o;
    o.name = std::to_string(model.obstacles.size());
    o.type = type;
    o.pose = Pose{position, orientation};
    o.material = material;
    model.obstacles.push_back(o);
    return static_cast<int>(model.obstacles.size()) - 1;
  }
  int plane(const Vec3& point, const Vec3& normal, int material = 0) {
    return obstacle(ShapeType::kPlane, point, rotation_between(Vec3::UnitZ(), normal.normalized()),
                    material);
  }
  int box(const Vec3& centre, const Quat& q, const Vec3& half, int material = 0) {
    const int o = obstacle(ShapeType::kBox, centre, q, material);
    model.obstacles.back().half_extents = half;
    return o;
  }
  int sphere(const Vec3& centre, double radius, int material = 0) {
    const int o = obstacle(ShapeType::kSphere, centre, Quat::Identity(), material);
    model.obstacles.back().radius = radius;
    return o;
  }
  int capsule(const Vec3& centre, const Quat& q, double half_length, double radius,
              int material = 0) {
    const int o = obstacle(ShapeType::kCapsule, centre, q, material);
    model.obstacles.back().half_length = half_length;
    model.obstacles.back().radius = radius;
    return o;
  }
  int sphere_set(const std::vector<Sphere>& spheres, int material = 0) {
    const int o = obstacle(ShapeType::kSphereSet, Vec3::Zero(), Quat::Identity(), material);
    model.obstacles.back().sphere_begin = static_cast<int>(model.static_spheres.size());
    model.obstacles.back().sphere_count = static_cast<int>(spheres.size());
    model.static_spheres.insert(model.static_spheres.end(), spheres.begin(), spheres.end());
    return o;
  }
  /// A sphere set over an existing range of Model::static_spheres.
  int sphere_range(int begin, int count, int material = 0) {
    const int o = obstacle(ShapeType::kSphereSet, Vec3::Zero(), Quat::Identity(), material);
    model.obstacles.back().sphere_begin = begin;
    model.obstacles.back().sphere_count = count;
    return o;
  }
  void finalize() {
    const std::string err = finalize_model(model);
    ASSERT_EQ(err, "");
  }
};

using Key = std::tuple<int, int, int, int, int,
                       int>;  // body_a, body_b, obstacle, sphere_a, sphere_b, material_pair

struct Ref {
  Key key;
  ContactGeometry g;
  bool operator<(const Ref& o) const { return key < o.key; }
};

/// O(n²) reference: every body sphere against every obstacle (every sphere of
/// every sphere set) and every sphere of every other body.
std::vector<Ref> brute_force(const Model& m, const Data& d) {
  std::vector<Ref> out;
  std::vector<Vec3> world(m.body_spheres.size());
  for (int b = 0; b < m.num_bodies(); ++b) {
    const BodyModel& bm = m.bodies[static_cast<std::size_t>(b)];
    const BodyState& st = d.bodies[static_cast<std::size_t>(b)];
    const Mat3 rot = st.orientation.toRotationMatrix();
    for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s)
      world[static_cast<std::size_t>(s)] =
          st.position + rot * m.body_spheres[static_cast<std::size_t>(s)].center;
  }
  const int nm = m.num_materials();
  ContactGeometry g;
  for (int b = 0; b < m.num_bodies(); ++b) {
    const BodyModel& bm = m.bodies[static_cast<std::size_t>(b)];
    const Vec3& x = d.bodies[static_cast<std::size_t>(b)].position;
    for (int o = 0; o < static_cast<int>(m.obstacles.size()); ++o) {
      const Obstacle& ob = m.obstacles[static_cast<std::size_t>(o)];
      const int mat = bm.material * nm + ob.material;
      for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
        const Vec3& c = world[static_cast<std::size_t>(s)];
        const double r = m.body_spheres[static_cast<std::size_t>(s)].radius;
        auto add = [&](int sb) { out.push_back(Ref{Key{b, -1, o, s, sb, mat}, g}); };
        switch (ob.type) {
          case ShapeType::kPlane:
            if (sphere_plane(c, r, ob.pose.position, ob.pose.orientation * Vec3::UnitZ(), g))
              add(-1);
            break;
          case ShapeType::kBox:
            if (sphere_box(c, r, ob.pose.position, ob.pose.orientation.toRotationMatrix(),
                           ob.half_extents, g))
              add(-1);
            break;
          case ShapeType::kSphere:
            if (sphere_sphere(c, r, ob.pose.position, ob.radius, x - ob.pose.position, g)) add(-1);
            break;
          case ShapeType::kCapsule:
            if (sphere_capsule(c, r, ob.pose.position, ob.pose.orientation * Vec3::UnitZ(),
                               ob.half_length, ob.radius, g))
              add(-1);
            break;
          case ShapeType::kSphereSet:
            for (int k = ob.sphere_begin; k < ob.sphere_begin + ob.sphere_count; ++k) {
              const Sphere& ss = m.static_spheres[static_cast<std::size_t>(k)];
              if (sphere_sphere(c, r, ss.center, ss.radius, x - ss.center, g)) add(k);
            }
            break;
          case ShapeType::kMesh:
            if (sphere_mesh(c, r, m.meshes[static_cast<std::size_t>(ob.mesh)], ob.pose, g))
              add(-1);
            break;
        }
      }
    }
  }
  for (int a = 0; a < m.num_bodies(); ++a)
    for (int b = a + 1; b < m.num_bodies(); ++b) {
      const BodyModel& ba = m.bodies[static_cast<std::size_t>(a)];
      const BodyModel& bb = m.bodies[static_cast<std::size_t>(b)];
      const Vec3 fb = d.bodies[static_cast<std::size_t>(a)].position -
                      d.bodies[static_cast<std::size_t>(b)].position;
      for (int sa = ba.sphere_begin; sa < ba.sphere_begin + ba.sphere_count; ++sa)
        for (int sb = bb.sphere_begin; sb < bb.sphere_begin + bb.sphere_count; ++sb)
          if (sphere_sphere(world[static_cast<std::size_t>(sa)],
                            m.body_spheres[static_cast<std::size_t>(sa)].radius,
                            world[static_cast<std::size_t>(sb)],
                            m.body_spheres[static_cast<std::size_t>(sb)].radius, fb, g))
            out.push_back(Ref{Key{a, b, -1, sa, sb, ba.material * nm + bb.material}, g});
    }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Ref> detected(const Data& d) {
  std::vector<Ref> out;
  for (int i = 0; i < d.num_contacts; ++i) {
    const Contact& c = d.contacts[static_cast<std::size_t>(i)];
    ContactGeometry g;
    g.position = c.position;
    g.normal = c.normal;
    g.depth = c.depth;
    out.push_back(
        Ref{Key{c.body_a, c.body_b, c.obstacle, c.sphere_a, c.sphere_b, c.material_pair}, g});
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Sphere> ball_of_spheres(std::mt19937& rng, int n, const Vec3& centre, double radius,
                                    double rmin, double rmax) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> rad(rmin, rmax);
  std::vector<Sphere> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec3 p(u(rng), u(rng), u(rng));
    if (p.squaredNorm() > 1.0) continue;
    out.push_back(Sphere{centre + radius * p, rad(rng)});
  }
  return out;
}

Quat random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Quat q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q;
}

/// Random scene: two organs (sphere sets, one sharing spheres with a third
/// set), an empty sphere set, a tilted plane, a box, a sphere, a capsule and
/// several bodies (one without spheres) with three materials.
Scene random_scene(std::uint32_t seed) {
  std::mt19937 rng(seed);
  Scene sc(3);
  const int organ_a = static_cast<int>(sc.model.static_spheres.size());
  sc.sphere_set(ball_of_spheres(rng, 350, Vec3(0, 0, 0), 0.08, 0.004, 0.012), 1);
  sc.sphere_set(ball_of_spheres(rng, 200, Vec3(0.13, 0.0, 0.02), 0.05, 0.003, 0.01), 2);
  sc.sphere_range(organ_a + 100, 40, 0);  // overlaps organ A's range
  sc.sphere_set({}, 1);
  sc.plane(Vec3(0, 0, -0.12), Vec3(0.1, -0.05, 1.0), 0);
  std::uniform_real_distribution<double> at(-0.15, 0.15);
  std::uniform_real_distribution<double> size(0.01, 0.04);
  for (int i = 0; i < 3; ++i) {
    sc.box(Vec3(at(rng), at(rng), at(rng)), random_rotation(rng),
           Vec3(size(rng), size(rng), size(rng)), 2);
    sc.sphere(Vec3(at(rng), at(rng), at(rng)), size(rng), 1);
    sc.capsule(Vec3(at(rng), at(rng), at(rng)), random_rotation(rng), size(rng), 0.5 * size(rng),
               2);
  }
  std::uniform_int_distribution<int> count(5, 30);
  std::uniform_int_distribution<int> mat(0, 2);
  std::uniform_real_distribution<double> pos(-0.15, 0.15);
  for (int b = 0; b < 7; ++b) {
    const int n = (b == 3) ? 0 : count(rng);
    sc.body(Vec3(pos(rng), pos(rng), pos(rng)), random_rotation(rng),
            ball_of_spheres(rng, n, Vec3::Zero(), 0.04, 0.003, 0.01), mat(rng));
  }
  sc.finalize();
  return sc;
}

/// Moves every body by a small random displacement and rotation, kept in the box.
void jiggle(std::mt19937& rng, Data& d, double step) {
  std::uniform_real_distribution<double> u(-step, step);
  for (BodyState& s : d.bodies) {
    s.position += Vec3(u(rng), u(rng), u(rng));
    s.position = s.position.cwiseMax(Vec3::Constant(-0.16)).cwiseMin(Vec3::Constant(0.16));
    s.orientation = (s.orientation * Quat(Eigen::AngleAxisd(
                                         10.0 * step, Vec3(u(rng), u(rng), u(rng)).normalized())))
                        .normalized();
  }
}

void expect_same_contacts(const std::vector<Ref>& got, const std::vector<Ref>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].key, want[i].key) << "contact " << i;
    EXPECT_NEAR(got[i].g.depth, want[i].g.depth, 1e-14);
    EXPECT_LT((got[i].g.normal - want[i].g.normal).norm(), 1e-12);
    EXPECT_LT((got[i].g.position - want[i].g.position).norm(), 1e-12);
  }
}

// ---- broad phase == brute force --------------------------------------------

TEST(CollisionBroadphase, EqualsBruteForceOnRandomScenes) {
  int by_kind[6] = {0, 0, 0, 0, 0, 0};  // plane, box, sphere, capsule, sphere set, body–body
  std::int64_t total = 0;
  for (std::uint32_t seed : {1u, 2u, 3u, 4u, 5u}) {
    Scene sc = random_scene(seed);
    const Model& m = sc.model;
    Data d = make_data(m);
    if (seed == 3u) {  // wrap the query stamp, with stamps left from long ago
      d.scratch->collision.stamp = std::numeric_limits<std::uint32_t>::max() - 50;
      std::fill(d.scratch->collision.entry_stamp.begin(), d.scratch->collision.entry_stamp.end(), 1u);
    }
    std::mt19937 rng(seed * 7919u);
    for (int t = 0; t < 60; ++t) {
      jiggle(rng, d, 0.01);
      detect_contacts(m, d);
      ASSERT_EQ(d.contacts_dropped, 0) << "scene too dense for an exact comparison";
      ASSERT_EQ(d.status & kContactOverflow, 0u);
      const std::vector<Ref> want = brute_force(m, d);
      SCOPED_TRACE(testing::Message() << "seed " << seed << " step " << t);
      expect_same_contacts(detected(d), want);
      double deepest = 0.0;
      for (const Ref& r : want) {
        deepest = std::max(deepest, r.g.depth);
        const int o = std::get<2>(r.key);
        if (o < 0) {
          ++by_kind[5];
        } else {
          ++by_kind[static_cast<int>(m.obstacles[static_cast<std::size_t>(o)].type)];
        }
      }
      EXPECT_EQ(d.max_penetration, deepest);
      total += static_cast<std::int64_t>(want.size());
    }
  }
  // The scenes really exercise every path.
  for (int k = 0; k < 6; ++k) EXPECT_GT(by_kind[k], 0) << "kind " << k;
  EXPECT_GT(total, 2000);
}

TEST(CollisionBroadphase, EqualsBruteForceOnADenseCluster) {
  // Hundreds of overlapping spheres per cell: rows of cells hold far more
  // items than one prefilter chunk.
  std::mt19937 rng(42);
  Scene sc;
  sc.sphere_set(ball_of_spheres(rng, 600, Vec3::Zero(), 0.02, 0.008, 0.012));
  sc.body(Vec3(0.03, 0, 0), Quat::Identity(),
          ball_of_spheres(rng, 20, Vec3::Zero(), 0.02, 0.002, 0.006));
  sc.finalize();
  const StaticSphereGrid& grid = sc.model.static_grid;
  int longest_row = 0;
  for (int z = 0; z < grid.dims.z(); ++z)
    for (int y = 0; y < grid.dims.y(); ++y)
      longest_row = std::max(
          longest_row,
          grid.cell_start[static_cast<std::size_t>(grid.cell_index(grid.dims.x() - 1, y, z)) + 1] -
              grid.cell_start[static_cast<std::size_t>(grid.cell_index(0, y, z))]);
  EXPECT_GT(longest_row, 200);
  Data d = make_data(sc.model);
  std::mt19937 move(1);
  int total = 0;
  for (int t = 0; t < 40; ++t) {
    jiggle(move, d, 0.005);
    d.bodies[0].position =
        d.bodies[0].position.cwiseMax(Vec3::Constant(-0.04)).cwiseMin(Vec3::Constant(0.04));
    detect_contacts(sc.model, d);
    ASSERT_EQ(d.contacts_dropped, 0);
    SCOPED_TRACE(testing::Message() << "step " << t);
    expect_same_contacts(detected(d), brute_force(sc.model, d));
    total += d.num_contacts;
  }
  EXPECT_GT(total, 400);
}

TEST(CollisionBroadphase, ContactsFollowTheConvention) {
  Scene sc = random_scene(11);
  Data d = make_data(sc.model);
  std::mt19937 rng(3);
  for (int t = 0; t < 20; ++t) {
    jiggle(rng, d, 0.01);
    detect_contacts(sc.model, d);
    for (int i = 0; i < d.num_contacts; ++i) {
      const Contact& c = d.contacts[static_cast<std::size_t>(i)];
      EXPECT_GT(c.depth, 0.0);
      EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
      EXPECT_TRUE(c.position.allFinite());
      EXPECT_EQ(c.force, Vec3::Zero());
      ASSERT_GE(c.body_a, 0);
      EXPECT_NE(c.body_a, c.body_b);
      const BodyModel& ba = sc.model.bodies[static_cast<std::size_t>(c.body_a)];
      EXPECT_GE(c.sphere_a, ba.sphere_begin);
      EXPECT_LT(c.sphere_a, ba.sphere_begin + ba.sphere_count);
      if (c.body_b >= 0) {
        EXPECT_LT(c.body_a, c.body_b);
        EXPECT_EQ(c.obstacle, -1);
        // Separating a along +normal reduces the overlap of the two spheres.
        const Vec3 ca = d.scratch->collision.sphere_world[static_cast<std::size_t>(c.sphere_a)];
        const Vec3 cb = d.scratch->collision.sphere_world[static_cast<std::size_t>(c.sphere_b)];
        EXPECT_GT((ca + 1e-6 * c.normal - cb).norm(), (ca - cb).norm());
      } else {
        EXPECT_GE(c.obstacle, 0);
      }
    }
  }
}

// ---- pipeline specifics -------------------------------------------------------

TEST(CollisionStage, WorldCentresAndPlaneContactFields) {
  Scene sc(3);
  const Quat q(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()));
  sc.body(Vec3(1, 2, 0.05), q, {{Vec3(0.1, 0, 0), 0.1}, {Vec3(-0.1, 0, 0.5), 0.1}}, 1);
  sc.plane(Vec3(0, 0, 0), Vec3::UnitZ(), 2);
  sc.finalize();
  Data d = make_data(sc.model);
  detect_contacts(sc.model, d);
  EXPECT_LT((d.scratch->collision.sphere_world[0] - Vec3(1, 2.1, 0.05)).norm(), 1e-15);
  EXPECT_LT((d.scratch->collision.sphere_world[1] - Vec3(1, 1.9, 0.55)).norm(), 1e-15);
  ASSERT_EQ(d.num_contacts, 1);
  const Contact& c = d.contacts[0];
  EXPECT_EQ(c.body_a, 0);
  EXPECT_EQ(c.body_b, -1);
  EXPECT_EQ(c.obstacle, 0);
  EXPECT_EQ(c.sphere_a, 0);
  EXPECT_EQ(c.sphere_b, -1);
  EXPECT_EQ(c.material_pair, 1 * 3 + 2);
  EXPECT_NEAR(c.depth, 0.05, 1e-15);
  EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_LT((c.position - Vec3(1, 2.1, -0.025)).norm(), 1e-15);
  EXPECT_NEAR(d.max_penetration, 0.05, 1e-15);
}

TEST(CollisionStage, BodyDeepBelowAPlaneCollidesWithEverySphere) {
  Scene sc;
  sc.body(Vec3(0, 0, -10), Quat::Identity(),
          {{Vec3(0, 0, 0), 0.1}, {Vec3(0, 0, 0.2), 0.1}, {Vec3(0, 0.2, 0), 0.1}});
  sc.body(Vec3(0, 0, 10), Quat::Identity(), {{Vec3(0, 0, 0), 0.1}});
  sc.plane(Vec3::Zero(), Vec3::UnitZ());
  sc.finalize();
  Data d = make_data(sc.model);
  detect_contacts(sc.model, d);
  ASSERT_EQ(d.num_contacts, 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(d.contacts[static_cast<std::size_t>(i)].body_a, 0);
    EXPECT_EQ(d.contacts[static_cast<std::size_t>(i)].sphere_a, i);
  }
  EXPECT_NEAR(d.max_penetration, 10.1, 1e-12);
}

TEST(CollisionStage, BodiesCollideWithEachOtherButNeverWithThemselves) {
  Scene sc(2);
  // Body 0 has overlapping spheres of its own: they never collide together.
  sc.body(Vec3(0, 0, 0), Quat::Identity(), {{Vec3(0, 0, 0), 0.1}, {Vec3(0.05, 0, 0), 0.1}}, 0);
  sc.body(Vec3(0, 0, 0.15), Quat::Identity(), {{Vec3(0, 0, 0), 0.1}}, 1);
  sc.finalize();
  Data d = make_data(sc.model);
  detect_contacts(sc.model, d);
  ASSERT_EQ(d.num_contacts, 2);
  for (int i = 0; i < 2; ++i) {
    const Contact& c = d.contacts[static_cast<std::size_t>(i)];
    EXPECT_EQ(c.body_a, 0);
    EXPECT_EQ(c.body_b, 1);
    EXPECT_EQ(c.obstacle, -1);
    EXPECT_EQ(c.sphere_b, 2);
    EXPECT_EQ(c.material_pair, 0 * 2 + 1);
    EXPECT_LT(c.normal.z(), 0.0);  // from body 1 (above) towards body 0
  }
  EXPECT_EQ(d.contacts[0].sphere_a, 0);
  EXPECT_NEAR(d.contacts[0].depth, 0.05, 1e-15);
  EXPECT_LT((d.contacts[0].normal + Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_LT((d.contacts[0].position - Vec3(0, 0, 0.075)).norm(), 1e-15);
}

TEST(CollisionStage, CoincidentCentresOfTwoBodiesSeparateAlongTheirCentresOfMass) {
  Scene sc;
  sc.body(Vec3(0, 0, 0), Quat::Identity(), {{Vec3(0.3, 0.4, 0), 0.1}});
  sc.body(Vec3(0.3, 0.4, 0.0) - Vec3(0.0, 0.0, -0.2), Quat::Identity(), {{Vec3(0, 0, -0.2), 0.1}});
  sc.finalize();
  Data d = make_data(sc.model);
  detect_contacts(sc.model, d);
  ASSERT_EQ(d.num_contacts, 1);
  const Contact& c = d.contacts[0];
  ASSERT_TRUE(c.normal.allFinite());
  // COM of body 0 minus COM of body 1 = (−0.3, −0.4, −0.2).
  EXPECT_LT((c.normal - Vec3(-0.3, -0.4, -0.2).normalized()).norm(), 1e-12);
  EXPECT_NEAR(c.depth, 0.2, 1e-12);
}

// ---- crossing (collision.hpp, "Crossing"; issue 70) ------------------------------------------

/// Two bodies of one 1.5 mm sphere each, body 0 at x = +x0 and body 1 at −x0 (centres 2 x0 apart
/// along x, body 0 on the +x side), moving along x at +v and −v.
void place_pair(Data& d, double x0, double v) {
  d.bodies[0].position = Vec3(x0, 0, 0);
  d.bodies[1].position = Vec3(-x0, 0, 0);
  d.bodies[0].linear_velocity = Vec3(v, 0, 0);
  d.bodies[1].linear_velocity = Vec3(-v, 0, 0);
}

Scene jaw_tip_pair() {
  Scene sc;
  sc.body(Vec3(0.01, 0, 0), Quat::Identity(), {{Vec3::Zero(), 0.0015}});
  sc.body(Vec3(-0.01, 0, 0), Quat::Identity(), {{Vec3::Zero(), 0.0015}});
  sc.model.dt = 1e-3;
  sc.finalize();
  return sc;
}

/// place_pair(d, x0, v), then one detect_contacts() call: the pair's one contact (a failure, and
/// a default Contact, when there is not exactly one).
Contact pair_contact(const Scene& sc, Data& d, double x0, double v) {
  place_pair(d, x0, v);
  detect_contacts(sc.model, d);
  EXPECT_EQ(d.num_contacts, 1) << "x0 " << x0 << " v " << v;
  return d.num_contacts == 1 ? d.contacts[0] : Contact{};
}

TEST(CollisionCrossing, SpheresThatCrossedWithinAStepArePushedBackTheWayTheyCame) {
  // Two jaw-tip spheres (1.5 mm) closing at 2.5 m/s each: 5 mm in the 1 ms step, from 4 mm apart
  // (centres) to 1 mm past each other. The overlap's own normal (+x on body 0) would push them
  // on through; the approach's (−x) pushes them back, 3 + 1 mm deep.
  const Scene sc = jaw_tip_pair();
  Data d = make_data(sc.model);
  const Contact c = pair_contact(sc, d, 0.0005, 2.5);
  EXPECT_EQ(c.body_a, 0);
  EXPECT_EQ(c.body_b, 1);
  EXPECT_LT((c.normal - Vec3(-1, 0, 0)).norm(), 1e-12) << "pushed back, not on through";
  EXPECT_NEAR(c.depth, 0.004, 1e-12);
  EXPECT_LT(c.position.norm(), 1e-12) << "the middle of the overlap";
  EXPECT_EQ(d.max_penetration, c.depth) << "reported deeper than the spheres' radii";
  EXPECT_EQ(d.crossed_contacts, 1);
  EXPECT_EQ(d.crossed_contact_steps, 1);
  EXPECT_EQ(d.pass_throughs, 0);

  // Next step, still past each other and now at rest: held back along the same normal.
  const Contact held = pair_contact(sc, d, 0.0008, 0.0);
  EXPECT_LT((held.normal - Vec3(-1, 0, 0)).norm(), 1e-12);
  EXPECT_NEAR(held.depth, 0.0046, 1e-12);
  EXPECT_EQ(d.crossed_contact_steps, 2);

  // Then apart on the far side: they went through, counted once.
  place_pair(d, 0.002, 0.0);
  detect_contacts(sc.model, d);
  EXPECT_EQ(d.num_contacts, 0);
  EXPECT_EQ(d.crossed_contacts, 0);
  EXPECT_EQ(d.pass_throughs, 1);
  detect_contacts(sc.model, d);
  EXPECT_EQ(d.pass_throughs, 1);
  reset_data(sc.model, d);
  EXPECT_EQ(d.pass_throughs, 0);
  EXPECT_EQ(d.crossed_contact_steps, 0);
}

TEST(CollisionCrossing, AnOverlapThatGoesPastTheCentreIsHeldBackAndReleasedInFront) {
  // Overlapping at the step's start (centres 0.6 mm, body 0 on the −x side) and 0.4 mm past each
  // other at its end: the start's normal (−x) holds; back in front, the overlap's own normal.
  const Scene sc = jaw_tip_pair();
  Data d = make_data(sc.model);
  const Contact past = pair_contact(sc, d, 0.0002, 0.5);
  EXPECT_LT((past.normal - Vec3(-1, 0, 0)).norm(), 1e-12);
  EXPECT_NEAR(past.depth, 0.0034, 1e-12);
  const Contact back = pair_contact(sc, d, -0.0005, -0.7);  // pushed back to −x: 1 mm in front
  EXPECT_LT((back.normal - Vec3(-1, 0, 0)).norm(), 1e-12);
  EXPECT_NEAR(back.depth, 0.002, 1e-12);
  EXPECT_EQ(d.crossed_contacts, 0);
  EXPECT_EQ(d.crossed_contact_steps, 1);
  EXPECT_EQ(d.pass_throughs, 0);
}

TEST(CollisionCrossing, SlowOrRestingPairsKeepTheirOwnNormal) {
  // The same offset (body 0 1 mm on the +x side) at rest and approaching slowly: the overlap's
  // own normal, +x; nothing counted.
  const Scene sc = jaw_tip_pair();
  Data d = make_data(sc.model);
  for (const double v : {0.0, -0.1, 0.1}) {
    const Contact c = pair_contact(sc, d, 0.0005, v);
    EXPECT_LT((c.normal - Vec3(1, 0, 0)).norm(), 1e-12) << v;
    EXPECT_NEAR(c.depth, 0.002, 1e-12) << v;
  }
  EXPECT_EQ(d.crossed_contact_steps, 0);
}

TEST(CollisionStage, SphereSetContactsNameTheStaticSphereAndObstacle) {
  Scene sc(2);
  sc.plane(Vec3(0, 0, -5), Vec3::UnitZ());
  sc.sphere_set({{Vec3(10, 0, 0), 0.5}}, 0);
  sc.sphere_set({{Vec3(0, 0, 0), 0.5}, {Vec3(1, 0, 0), 0.5}, {Vec3(2, 0, 0), 0.5}}, 1);
  sc.body(Vec3(1, 0, 0.8), Quat::Identity(), {{Vec3::Zero(), 0.5}});
  sc.finalize();
  Data d = make_data(sc.model);
  detect_contacts(sc.model, d);
  ASSERT_EQ(d.num_contacts, 1);
  const Contact& c = d.contacts[0];
  EXPECT_EQ(c.obstacle, 2);
  EXPECT_EQ(c.sphere_b, 2);  // index into Model::static_spheres
  EXPECT_EQ(c.material_pair, 1);
  EXPECT_NEAR(c.depth, 0.2, 1e-12);
  EXPECT_LT((c.normal - Vec3::UnitZ()).norm(), 1e-12);
  EXPECT_LT((c.position - Vec3(1, 0, 0.4)).norm(), 1e-12);
}

TEST(CollisionStage, CullingKeepsContactsAtTheRimOfTheBoundingSphere) {
  // One sphere offset from the COM: bounding radius 0.15. Each obstacle's box
  // starts 0.14 from the COM, and its shape overlaps the sphere by 0.01 (the
  // capsule's axis is 0.195 from the COM: within 0.15 + its radius 0.055).
  Scene sc;
  sc.body(Vec3::Zero(), Quat::Identity(), {{Vec3(0.1, 0, 0), 0.05}});
  sc.sphere(Vec3(0.2, 0, 0), 0.06);
  sc.box(Vec3(0.0, 0.19, 0.0), Quat::Identity(), Vec3(0.2, 0.05, 0.2));
  sc.capsule(Vec3(0.1, 0, -0.195), rotation_between(Vec3::UnitZ(), Vec3::UnitX()), 0.2, 0.055);
  sc.finalize();
  Data d = make_data(sc.model);
  for (const Quat& q : {Quat::Identity(), Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ())),
                        Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()))}) {
    d.bodies[0].orientation = q;
    detect_contacts(sc.model, d);
    ASSERT_EQ(d.num_contacts, 1) << q.coeffs().transpose();
    EXPECT_NEAR(d.contacts[0].depth, 0.01, 1e-12);
  }
}

TEST(CollisionStage, StampWrapForgetsOldStamps) {
  Scene sc;
  sc.sphere_set({{Vec3(0, 0, 0), 0.1}, {Vec3(0.05, 0, 0), 0.1}});
  sc.body(Vec3(0, 0, 0.15), Quat::Identity(), {{Vec3::Zero(), 0.1}});
  sc.finalize();
  Data d = make_data(sc.model);
  d.scratch->collision.stamp = std::numeric_limits<std::uint32_t>::max();  // next query wraps to 1
  std::fill(d.scratch->collision.entry_stamp.begin(), d.scratch->collision.entry_stamp.end(), 1u);  // hit long ago
  detect_contacts(sc.model, d);
  EXPECT_EQ(d.num_contacts, 2);
  EXPECT_EQ(d.scratch->collision.stamp, 1u);
}

TEST(CollisionStage, ObstacleBoundsAreComputedAtFinalize) {
  Scene sc;
  const int plane = sc.plane(Vec3::Zero(), Vec3::UnitZ());
  const int box =
      sc.box(Vec3(1, 1, 1), Quat(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ())), Vec3(1, 2, 3));
  const int sphere = sc.sphere(Vec3(1, 2, 3), 0.5);
  const int capsule =
      sc.capsule(Vec3(0, 0, 1), rotation_between(Vec3::UnitZ(), Vec3::UnitX()), 2.0, 0.5);
  const int set = sc.sphere_set({{Vec3(0, 0, 0), 1.0}, {Vec3(3, 1, 0), 0.5}});
  const int empty = sc.sphere_set({});
  sc.finalize();
  auto expect_box = [&](int o, const Vec3& lo, const Vec3& hi) {
    const Obstacle& ob = sc.model.obstacles[static_cast<std::size_t>(o)];
    EXPECT_LT((ob.aabb_min - lo).norm(), 1e-12) << ob.name << ": " << ob.aabb_min.transpose();
    EXPECT_LT((ob.aabb_max - hi).norm(), 1e-12) << ob.name << ": " << ob.aabb_max.transpose();
  };
  EXPECT_EQ(sc.model.obstacles[static_cast<std::size_t>(plane)].aabb_min, Vec3::Constant(-kInf));
  EXPECT_EQ(sc.model.obstacles[static_cast<std::size_t>(plane)].aabb_max, Vec3::Constant(kInf));
  expect_box(box, Vec3(-1, 0, -2), Vec3(3, 2, 4));
  expect_box(sphere, Vec3(0.5, 1.5, 2.5), Vec3(1.5, 2.5, 3.5));
  expect_box(capsule, Vec3(-2.5, -0.5, 0.5), Vec3(2.5, 0.5, 1.5));
  expect_box(set, Vec3(-1, -1, -1), Vec3(3.5, 1.5, 1));
  const Obstacle& e = sc.model.obstacles[static_cast<std::size_t>(empty)];
  EXPECT_FALSE((e.aabb_min.array() <= e.aabb_max.array()).any());  // inverted: overlaps nothing
  EXPECT_EQ(sc.model.static_grid.num_entries, 2);
}

TEST(CollisionStage, NoObstaclesNoContacts) {
  Scene sc;
  sc.body(Vec3::Zero(), Quat::Identity(), {{Vec3::Zero(), 0.1}});
  sc.body(Vec3(5, 0, 0), Quat::Identity(), {});
  sc.finalize();
  Data d = make_data(sc.model);
  d.max_penetration = 3.0;
  d.num_contacts = 7;
  detect_contacts(sc.model, d);
  EXPECT_EQ(d.num_contacts, 0);
  EXPECT_EQ(d.max_penetration, 0.0);
  EXPECT_EQ(d.contacts_dropped, 0);
}

// ---- capacity ---------------------------------------------------------------

TEST(CollisionCapacity, OverflowIsCountedAndReportedWithoutWritingPastTheArray) {
  const int n = kMaxContacts + 300;
  std::vector<Sphere> spheres;
  for (int i = 0; i < n; ++i)
    spheres.push_back(Sphere{Vec3(0.01 * (i % 50), 0.01 * (i / 50), 0.0), 0.1});
  Scene sc;
  sc.body(Vec3(0, 0, 0), Quat::Identity(), spheres);
  sc.plane(Vec3::Zero(), Vec3::UnitZ());
  sc.finalize();
  Data d = make_data(sc.model);
  d.status = kSolverNotConverged;  // set by another stage: must survive
  const Vec3 sentinel(1.25, -2.5, 3.75);
  d.coupling_wrench.force = sentinel;  // members laid out after the contact array
  d.feedback_wrench.torque = sentinel;

  detect_contacts(sc.model, d);
  EXPECT_EQ(d.num_contacts, kMaxContacts);
  EXPECT_EQ(d.contacts_dropped, 300);
  EXPECT_EQ(d.contact_overflow_steps, 1);
  EXPECT_EQ(d.status, static_cast<std::uint32_t>(kSolverNotConverged | kContactOverflow));
  EXPECT_NEAR(d.max_penetration, 0.1, 1e-15);
  EXPECT_EQ(d.coupling_wrench.force, sentinel);
  EXPECT_EQ(d.feedback_wrench.torque, sentinel);
  for (int i = 0; i < kMaxContacts; ++i)
    ASSERT_EQ(d.contacts[static_cast<std::size_t>(i)].sphere_a, i);

  detect_contacts(sc.model, d);  // once more: counted once per call
  EXPECT_EQ(d.contact_overflow_steps, 2);
  EXPECT_EQ(d.contacts_dropped, 300);

  d.bodies[0].position.z() = 1.0;  // lifted clear: the overflow bit goes, the others stay
  detect_contacts(sc.model, d);
  EXPECT_EQ(d.num_contacts, 0);
  EXPECT_EQ(d.contacts_dropped, 0);
  EXPECT_EQ(d.contact_overflow_steps, 2);
  EXPECT_EQ(d.status, static_cast<std::uint32_t>(kSolverNotConverged));
}

// ---- real-time properties -------------------------------------------------------

TEST(CollisionRealTime, NoHeapAllocationOverTenThousandSteps) {
  Scene sc = random_scene(21);
  Data d = make_data(sc.model);
  std::vector<Vec3> base;
  for (const BodyState& s : d.bodies) base.push_back(s.position);
  std::int64_t contacts = 0;
  std::int64_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int t = 0; t < 10000; ++t) {
      for (std::size_t b = 0; b < d.bodies.size(); ++b) {
        const double phase = 1e-3 * t + static_cast<double>(b);
        d.bodies[b].position =
            base[b] + 0.05 * Vec3(std::sin(phase), std::cos(1.3 * phase), std::sin(0.7 * phase));
        d.bodies[b].orientation = Quat(Eigen::AngleAxisd(phase, Vec3::UnitZ()));
      }
      detect_contacts(sc.model, d);
      contacts += d.num_contacts;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(contacts, 10000);
}

TEST(CollisionRealTime, StepsWithCrossedPairsAllocateNothing) {
  // The crossing's records in the step (collision.hpp, "Crossing"): two jaw-tip spheres (1 kg
  // each, no gravity) closing at 2.5 m/s each from 4 mm apart, four steps a cycle: the first
  // moves them 1 mm past each other, the second holds the pair back (a record made), the third
  // finds it apart behind the held normal (a pass-through: the 40 N push is too weak to turn
  // 1 kg round) and the fourth has nothing. 500 cycles, none allocating.
  Scene sc = jaw_tip_pair();
  sc.model.gravity = Vec3::Zero();
  Data d = make_data(sc.model);
  constexpr int kCycles = 500;
  std::int64_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int k = 0; k < kCycles; ++k) {
      place_pair(d, 0.002, -2.5);  // body 0 on the +x side, moving towards −x
      for (int s = 0; s < 4; ++s) step(sc.model, d);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(d.crossed_contact_steps, kCycles);
  EXPECT_EQ(d.pass_throughs, kCycles);
  EXPECT_EQ(d.nonfinite_steps, 0);
}

void expect_identical_contacts(const Data& d1, const Data& d2, int step) {
  ASSERT_EQ(d1.num_contacts, d2.num_contacts) << "step " << step;
  EXPECT_EQ(d1.max_penetration, d2.max_penetration);
  for (int i = 0; i < d1.num_contacts; ++i) {
    const Contact& a = d1.contacts[static_cast<std::size_t>(i)];
    const Contact& b = d2.contacts[static_cast<std::size_t>(i)];
    ASSERT_EQ(std::tie(a.body_a, a.body_b, a.obstacle, a.sphere_a, a.sphere_b, a.material_pair),
              std::tie(b.body_a, b.body_b, b.obstacle, b.sphere_a, b.sphere_b, b.material_pair))
        << "step " << step << " contact " << i;
    EXPECT_EQ(a.position, b.position);  // bitwise equal
    EXPECT_EQ(a.normal, b.normal);
    EXPECT_EQ(a.depth, b.depth);
  }
}

TEST(CollisionRealTime, DeterministicWhateverTheScratchHistory) {
  Scene sc = random_scene(8);
  const Model& m = sc.model;
  Data d1 = make_data(m);
  Data d2 = make_data(m);
  std::mt19937 scramble(77);
  for (int t = 0; t < 50; ++t) {  // d2 visits other poses first (sweep order, stamps)
    jiggle(scramble, d2, 0.05);
    detect_contacts(m, d2);
  }
  std::mt19937 rng(5);
  int with_contacts = 0;
  for (int t = 0; t < 40; ++t) {
    jiggle(rng, d1, 0.01);
    for (std::size_t b = 0; b < d1.bodies.size(); ++b) d2.bodies[b] = d1.bodies[b];
    detect_contacts(m, d1);
    detect_contacts(m, d2);
    expect_identical_contacts(d1, d2, t);
    with_contacts += d1.num_contacts > 0;
  }
  EXPECT_GT(with_contacts, 30);
}

TEST(CollisionRealTime, DeterministicWithTiesOnTheSweepAxis) {
  // Identical bodies in a column along y at the same x: every sweep key ties,
  // and each overlaps its neighbours.
  Scene sc;
  const std::vector<Sphere> shape = {
      {Vec3(0, 0, 0), 0.1}, {Vec3(0, 0.1, 0), 0.1}, {Vec3(0, 0, 0.1), 0.08}};
  for (int b = 0; b < 6; ++b) sc.body(Vec3(0, 0.25 * b, 0), Quat::Identity(), shape);
  sc.finalize();
  const Model& m = sc.model;
  Data d1 = make_data(m);
  Data d2 = make_data(m);
  // d2's sweep order is left reversed by a previous configuration.
  for (int b = 0; b < 6; ++b) d2.bodies[static_cast<std::size_t>(b)].position.x() = -1.0 * b;
  detect_contacts(m, d2);
  EXPECT_EQ(d2.num_contacts, 0);
  for (int b = 0; b < 6; ++b)
    d2.bodies[static_cast<std::size_t>(b)] = d1.bodies[static_cast<std::size_t>(b)];
  detect_contacts(m, d1);
  detect_contacts(m, d2);
  EXPECT_EQ(d1.num_contacts, 5 * 1);  // sphere 1 of body b overlaps sphere 0 of body b+1 only
  expect_identical_contacts(d1, d2, 0);
}

}  // namespace
}  // namespace numen::core
