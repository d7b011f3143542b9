// Mesh shapes on bodies (BodyModel::mesh; core/src/contact/collision.cpp, step 4 of
// detect_contacts):
// the spheres of a body against another body's mesh. An anchored mesh body gives the contacts and
// the motion of the same mesh as an obstacle; a free one is pushed (equal and opposite forces, the
// momentum kept) under every integrator; a body's own spheres do not touch its mesh; nothing
// allocates; a bad mesh index or pose is refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "alloc_counter.hpp"
#include "numen/core/collision.hpp"
#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"
#include "numen/core/step.hpp"

namespace numen::core {
namespace {

/// Where the mesh goes in the world (an obstacle placed there, or a body whose mesh_pose puts it
/// there).
const Pose kMeshPose{Vec3(0.01, -0.02, 0.1),
                     Quat(Eigen::AngleAxisd(0.3, Vec3(1.0, 0.5, 0.0).normalized()))};

/// Gravity along the mesh frame's −z.
const Vec3 kGravity = -9.81 * (kMeshPose.orientation * Vec3::UnitZ());

/// A ball (one sphere of 5 mm, 50 g) 10 mm above the top of the torus's tube at x = R (mesh
/// frame; the slab's top face there too), moving at `speed` (m/s) towards it.
BodyModel ball(Model& m, double speed) {
  BodyModel b;
  b.name = "ball";
  b.mass = 0.05;
  b.inertia_body = Mat3::Identity() * (0.4 * 0.05 * 0.005 * 0.005);
  b.sphere_begin = static_cast<int>(m.body_spheres.size());
  b.sphere_count = 1;
  m.body_spheres.push_back(Sphere{Vec3::Zero(), 0.005});
  const Vec3 up = kMeshPose.orientation * Vec3::UnitZ();
  b.initial_pose.position = kMeshPose.position + kMeshPose.orientation * Vec3(0.04, 0.0, 0.015) +
                            0.015 * up;
  b.initial_twist.linear = -speed * up;
  return b;
}

/// The torus of R 4 cm, r 1.5 cm (4096 triangles).
TriangleMesh torus_mesh() { return make_torus(0.04, 0.015, 64, 32); }

/// A slab of 12 × 12 × 3 cm (subdivided box): its top face, where the ball comes to rest, is
/// flat (on the torus's tube the rest is unstable, and rounding grows along the fall off it).
TriangleMesh slab_mesh() { return make_box(Vec3(0.06, 0.06, 0.015), 4); }

/// Materials, `mesh` in m.meshes[0], nothing held.
Model base(Integrator integrator, const Vec3& gravity, const TriangleMesh& mesh = torus_mesh()) {
  Model m;
  m.integrator = integrator;
  m.gravity = gravity;
  m.material_names = {"a"};
  m.material_pairs.assign(1, MaterialPair{3000.0, 3.0, 0.2});
  m.initial_held_body = -1;
  m.meshes.emplace_back();
  EXPECT_EQ(build_mesh_shape(mesh, m.meshes.back()), "");
  return m;
}

/// The slab as a mesh obstacle at kMeshPose, and the ball.
Model obstacle_scene(Integrator integrator) {
  Model m = base(integrator, kGravity, slab_mesh());
  m.bodies.push_back(ball(m, 0.0));
  Obstacle o;
  o.name = "torus";
  o.type = ShapeType::kMesh;
  o.mesh = 0;
  o.pose = kMeshPose;
  m.obstacles.push_back(o);
  EXPECT_EQ(finalize_model(m), "");
  return m;
}

/// A body "mesh" carrying m.meshes[0] at some other pose, its mesh_pose composing to kMeshPose.
BodyModel mesh_body(const Pose& body_pose, double mass) {
  BodyModel t;
  t.name = "mesh";
  t.mass = mass;
  t.inertia_body = Vec3(1e-4, 1e-4, 2e-4).asDiagonal();
  t.mesh = 0;
  t.initial_pose = body_pose;
  t.mesh_pose.orientation = body_pose.orientation.conjugate() * kMeshPose.orientation;
  t.mesh_pose.position = body_pose.orientation.conjugate() * (kMeshPose.position - body_pose.position);
  return t;
}

const Pose kBodyPose{Vec3(0.03, 0.0, 0.09), Quat(Eigen::AngleAxisd(-1.1, Vec3(0.2, 1.0, 0.4).normalized()))};

TEST(CollisionMeshBody, AnAnchoredMeshBodyMatchesTheSameMeshAsAnObstacle) {
  // The slab placed at kMeshPose either way.
  for (Integrator integrator : {Integrator::kLinearlyImplicitEuler, Integrator::kSymplecticEuler}) {
    const Model a = obstacle_scene(integrator);
    Model b = base(integrator, kGravity, slab_mesh());
    BodyModel anchor = mesh_body(kBodyPose, 1.0);
    anchor.anchored = true;
    b.bodies.push_back(anchor);
    b.bodies.push_back(ball(b, 0.0));
    ASSERT_EQ(finalize_model(b), "");
    Data da = make_data(a);
    Data db = make_data(b);
    int touching = 0;
    for (int i = 0; i < 800; ++i) {  // falls 10 mm, lands, settles pressed on the top face
      step(a, da);
      step(b, db);
      ASSERT_EQ(da.num_contacts, db.num_contacts) << "step " << i;
      for (int k = 0; k < da.num_contacts; ++k) {
        const Contact& ca = da.contacts[static_cast<std::size_t>(k)];
        const Contact& cb = db.contacts[static_cast<std::size_t>(k)];
        EXPECT_EQ(cb.body_a, 1);
        EXPECT_EQ(cb.body_b, 0);
        EXPECT_EQ(cb.sphere_b, -1);
        EXPECT_EQ(cb.obstacle, -1);
        EXPECT_NEAR(ca.depth, cb.depth, 1e-10);
        EXPECT_NEAR((ca.normal - cb.normal).norm(), 0.0, 1e-9);
        EXPECT_NEAR((ca.position - cb.position).norm(), 0.0, 1e-10);
      }
      touching += da.num_contacts > 0;
      ASSERT_NEAR((da.bodies[0].position - db.bodies[1].position).norm(), 0.0, 1e-10) << "step " << i;
    }
    EXPECT_GT(touching, 500);
    // Pressed on the top face by its weight: depth m g / k.
    EXPECT_NEAR(da.max_penetration, 0.05 * 9.81 / 3000.0, 2e-6);
    // The anchored body stays where it is.
    EXPECT_NEAR((db.bodies[0].position - kBodyPose.position).norm(), 0.0, 1e-15);
  }
}

/// A free torus body (200 g, no gravity) hit by the ball at 0.5 m/s; its own sphere inside its tube.
Model push_scene(Integrator integrator) {
  Model m = base(integrator, Vec3::Zero());
  BodyModel t = mesh_body(kBodyPose, 0.2);
  t.sphere_begin = 0;
  t.sphere_count = 1;
  m.body_spheres.push_back(
      Sphere{t.mesh_pose.position + t.mesh_pose.orientation * Vec3(-0.04, 0.0, 0.0), 0.01});
  m.bodies.push_back(t);
  m.bodies.push_back(ball(m, 0.5));
  EXPECT_EQ(finalize_model(m), "");
  return m;
}

TEST(CollisionMeshBody, AFreeMeshBodyIsPushedWithEqualAndOppositeForcesUnderEveryIntegrator) {
  for (Integrator integrator : {Integrator::kLinearlyImplicitEuler, Integrator::kSymplecticEuler,
                                Integrator::kTrapezoidal, Integrator::kTrBdf2}) {
    SCOPED_TRACE(static_cast<int>(integrator));
    const Model m = push_scene(integrator);
    Data d = make_data(m);
    const auto momentum = [&]() {
      return Vec3(m.bodies[0].mass * d.bodies[0].linear_velocity +
                  m.bodies[1].mass * d.bodies[1].linear_velocity);
    };
    const Vec3 p0 = momentum();
    const Vec3 up = kMeshPose.orientation * Vec3::UnitZ();
    int touching = 0;
    for (int i = 0; i < 100; ++i) {
      step(m, d);
      if (d.num_contacts == 0) continue;
      ++touching;
      for (int k = 0; k < d.num_contacts; ++k) {
        const Contact& c = d.contacts[static_cast<std::size_t>(k)];
        EXPECT_EQ(c.body_a, 1);  // only the ball against the torus: not its own sphere
        EXPECT_EQ(c.body_b, 0);
      }
      // The contact's force on the ball (+f) and on the torus (−f) leave the sum unchanged.
      EXPECT_NEAR((momentum() - p0).norm(), 0.0, 1e-9 * p0.norm()) << "step " << i;
    }
    EXPECT_GT(touching, 5);
    EXPECT_NEAR((momentum() - p0).norm(), 0.0, 1e-9 * p0.norm());
    // The torus moves away along −up, the ball has turned back or slowed.
    EXPECT_LT(d.bodies[0].linear_velocity.dot(up), -0.05);
    EXPECT_GT(d.bodies[1].linear_velocity.dot(up), -0.25);
    EXPECT_EQ(d.contacts_dropped, 0);
  }
}

TEST(CollisionMeshBody, ItsOwnSpheresDoNotTouchABodysMesh) {
  Model m = push_scene(Integrator::kLinearlyImplicitEuler);
  // The torus's own sphere lies inside its tube: still no contact once the ball is away.
  Data d = make_data(m);
  d.bodies[1].position += Vec3(1.0, 0.0, 0.0);
  detect_contacts(m, d);
  EXPECT_EQ(d.num_contacts, 0);
  // The ball inside the tube: a contact with the torus's mesh.
  d.bodies[1].position = kMeshPose.position + kMeshPose.orientation * Vec3(0.04, 0.0, 0.0);
  detect_contacts(m, d);
  ASSERT_EQ(d.num_contacts, 1);
  EXPECT_NEAR(d.contacts[0].depth, 0.005 + 0.015, 1e-3);
}

TEST(CollisionMeshBody, SteppingDoesNotAllocate) {
  const Model m = push_scene(Integrator::kLinearlyImplicitEuler);
  Data d = make_data(m);
  int touching = 0;
  numen::test::AllocationGuard guard;
  for (int i = 0; i < 300; ++i) {
    step(m, d);
    touching += d.num_contacts > 0;
  }
  EXPECT_EQ(guard.count(), 0);
  EXPECT_GT(touching, 5);
}

TEST(CollisionMeshBody, OverflowIsCounted) {
  // More ball spheres inside the torus body's tube than the contact array holds.
  Model m = base(Integrator::kLinearlyImplicitEuler, Vec3::Zero());
  m.bodies.push_back(mesh_body(Pose{}, 0.2));
  m.bodies[0].mesh_pose = Pose{};
  BodyModel ring;
  ring.name = "ring";
  ring.sphere_begin = 0;
  const int n = kMaxContacts + 5;
  for (int i = 0; i < n; ++i) {
    const double u = 2.0 * M_PI * i / n;
    m.body_spheres.push_back(Sphere{Vec3(0.04 * std::cos(u), 0.04 * std::sin(u), 0.0), 0.002});
  }
  ring.sphere_count = n;
  m.bodies.push_back(ring);
  ASSERT_EQ(finalize_model(m), "");
  Data d = make_data(m);
  detect_contacts(m, d);
  EXPECT_EQ(d.num_contacts, kMaxContacts);
  EXPECT_EQ(d.contacts_dropped, 5);
  EXPECT_NE(d.status & kContactOverflow, 0u);
}

TEST(CollisionMeshBody, BadMeshIndexOrPoseIsRefusedByName) {
  Model m = push_scene(Integrator::kLinearlyImplicitEuler);
  m.bodies[0].mesh = 2;
  std::string err = finalize_model(m);
  EXPECT_NE(err.find("body 'mesh': mesh index out of Model::meshes"), std::string::npos) << err;
  m.bodies[0].mesh = 0;
  m.bodies[0].mesh_pose.position.x() = std::nan("");
  err = finalize_model(m);
  EXPECT_NE(err.find("body 'mesh': mesh pose must be finite"), std::string::npos) << err;
}

TEST(CollisionMeshBody, AMultirateGodObjectWithAMeshIsRefused) {
  Model m = push_scene(Integrator::kLinearlyImplicitEuler);
  Model out;
  const std::string err = make_god_object_model(m, 0, 1e-4, out);
  EXPECT_NE(err.find("god-object body 'mesh' carries a mesh"), std::string::npos) << err;
  EXPECT_EQ(make_god_object_model(m, 1, 1e-4, out), "");  // the ball against the torus: planes
}

}  // namespace
}  // namespace numen::core
