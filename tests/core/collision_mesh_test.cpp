// Mesh obstacles in the collision stage (core/src/contact/collision.cpp, sphere_mesh in
// narrowphase.cpp)
// and in the nets' node contacts (net_collision.cpp): each contact's depth is r − the brute-force
// signed distance of the sphere's centre in the mesh frame, the overflow is counted, nothing
// allocates.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/model.hpp"

namespace numen::core {
namespace {

/// One body of `spheres` at the origin and a torus obstacle (R 4 cm, r 1.5 cm, 4096 triangles)
/// placed at `pose`.
Model torus_scene(const std::vector<Sphere>& spheres, const Pose& pose) {
  Model m;
  m.material_names = {"a"};
  m.material_pairs.assign(1, MaterialPair{});
  m.initial_held_body = -1;
  BodyModel b;
  b.name = "tool";
  b.sphere_count = static_cast<int>(spheres.size());
  m.body_spheres = spheres;
  m.bodies.push_back(b);
  m.meshes.emplace_back();
  EXPECT_EQ(build_mesh_shape(make_torus(0.04, 0.015, 64, 32), m.meshes.back()), "");
  Obstacle o;
  o.name = "torus";
  o.type = ShapeType::kMesh;
  o.mesh = 0;
  o.pose = pose;
  m.obstacles.push_back(o);
  EXPECT_EQ(finalize_model(m), "");
  return m;
}

std::vector<Sphere> random_spheres(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.06, 0.06), r(0.001, 0.01);
  std::vector<Sphere> s(static_cast<std::size_t>(n));
  for (Sphere& sp : s) sp = Sphere{Vec3(u(rng), u(rng), u(rng) / 2.0), r(rng)};
  return s;
}

TEST(CollisionMesh, DepthIsRadiusMinusTheExactSignedDistance) {
  const Pose pose{Vec3(0.01, -0.02, 0.005),
                  Quat(Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, 0.5).normalized()))};
  const std::vector<Sphere> spheres = random_spheres(800, 7);
  // Centres given in the body frame = world frame (body at the origin, identity): map them.
  Model m = torus_scene(spheres, pose);
  Data d = make_data(m);
  detect_contacts(m, d);
  const MeshShape& shape = m.meshes[0];
  int expected = 0;
  int k = 0;
  for (int s = 0; s < static_cast<int>(spheres.size()); ++s) {
    const Sphere& sp = spheres[static_cast<std::size_t>(s)];
    const Vec3 local = pose.orientation.conjugate() * (sp.center - pose.position);
    const MeshDistance ref = mesh_signed_distance_brute(shape, local);
    if (!(ref.distance < sp.radius)) continue;
    ++expected;
    ASSERT_LT(k, d.num_contacts);
    const Contact& c = d.contacts[static_cast<std::size_t>(k++)];
    ASSERT_EQ(c.sphere_a, s);
    EXPECT_EQ(c.obstacle, 0);
    EXPECT_NEAR(c.depth, sp.radius - ref.distance, 1e-12);
    EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
    // The surface point lies on the mesh, depth/2 beyond the contact position along −n.
    const Vec3 surface = pose.position + pose.orientation * ref.point;
    EXPECT_NEAR((c.position + 0.5 * c.depth * c.normal - surface).norm(), 0.0, 1e-12);
  }
  EXPECT_EQ(d.num_contacts, expected);
  EXPECT_GT(expected, 100);  // the test sees contacts
  EXPECT_EQ(d.contacts_dropped, 0);
}

TEST(CollisionMesh, OverflowIsCounted) {
  // More spheres inside the tube than the contact array holds: every one is a contact.
  const int n = kMaxContacts + 77;
  std::vector<Sphere> spheres;
  for (int i = 0; i < n; ++i) {
    const double u = 2.0 * M_PI * i / n;
    spheres.push_back(Sphere{Vec3(0.04 * std::cos(u), 0.04 * std::sin(u), 0.0), 0.002});
  }
  Model m = torus_scene(spheres, Pose{});
  Data d = make_data(m);
  detect_contacts(m, d);
  EXPECT_EQ(d.num_contacts, kMaxContacts);
  EXPECT_EQ(d.contacts_dropped, 77);
  EXPECT_EQ(d.contact_overflow_steps, 1);
  EXPECT_NE(d.status & kContactOverflow, 0u);
  EXPECT_NEAR(d.max_penetration, 0.017, 1e-3);  // centre on the tube's axis: r + 1.5 cm
}

TEST(CollisionMesh, DetectionDoesNotAllocate) {
  Model m = torus_scene(random_spheres(300, 8), Pose{});
  Data d = make_data(m);
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 200; ++i) {
    d.bodies[0].position = Vec3(0.0005 * (i % 20), 0.0, 0.0);
    detect_contacts(m, d);
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(d.num_contacts, 0);
}

TEST(CollisionMesh, MeshIndexIsValidated) {
  Model m = torus_scene({Sphere{Vec3::Zero(), 0.01}}, Pose{});
  m.obstacles[0].mesh = 3;
  const std::string err = finalize_model(m);
  EXPECT_NE(err.find("obstacle 'torus'"), std::string::npos) << err;
  EXPECT_NE(err.find("Model::meshes"), std::string::npos) << err;
}

}  // namespace
}  // namespace numen::core
