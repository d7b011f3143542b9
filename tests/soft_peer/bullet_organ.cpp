/// @file bullet_organ.cpp
/// A numen organ in Bullet's soft body (bullet_organ.hpp).

#include "bullet_organ.hpp"

#include <btBulletDynamicsCommon.h>

#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <BulletCollision/CollisionShapes/btEmptyShape.h>

#include <algorithm>
#include <limits>
#include <stdexcept>

#include "soft_peer_mapping.hpp"

namespace numen::soft_peer {

namespace {

btVector3 bt(const core::Vec3& v) {
  return btVector3(static_cast<btScalar>(v.x()), static_cast<btScalar>(v.y()),
                   static_cast<btScalar>(v.z()));
}

core::Vec3 from_bt(const btVector3& v) { return core::Vec3(v.x(), v.y(), v.z()); }

btTransform bt_pose(const core::Pose& p) {
  const core::Quat& q = p.orientation;
  return btTransform(btQuaternion(static_cast<btScalar>(q.x()), static_cast<btScalar>(q.y()),
                                  static_cast<btScalar>(q.z()), static_cast<btScalar>(q.w())),
                     bt(p.position));
}

}  // namespace

/// Bullet's objects, destroyed in the reverse order of their creation.
struct BulletOrgan::Parts {
  btSoftBodyRigidBodyCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btSoftRigidDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  btEmptyShape anchor_shape;
  std::unique_ptr<btRigidBody> anchor_body;  // static, not in the world: the anchors' body
  std::unique_ptr<btSphereShape> tool_shape;
  std::unique_ptr<btRigidBody> tool;
  std::unique_ptr<btSoftBody> soft;

  ~Parts() {
    if (soft) world.removeSoftBody(soft.get());
    if (tool) world.removeRigidBody(tool.get());
  }
};

BulletOrgan::BulletOrgan(const core::Model& model, const BulletOptions& options)
    : parts_(std::make_unique<Parts>()), dt_(model.dt) {
  if (model.nets.size() != 1 || model.bodies.size() < 2 || model.bodies[1].sphere_count != 1 ||
      model.nets[0].face_count == 0 || !(model.dt > 0.0))
    throw std::invalid_argument(
        "BulletOrgan: the model must have one net with faces (body 0) and a one-sphere tool (body 1)");
  if (options.position_iterations < 1 || !(options.margin > 0.0) || !(options.sdf_voxel > 0.0))
    throw std::invalid_argument("BulletOrgan: position_iterations >= 1, margin > 0, sdf_voxel > 0");
  const core::NetModel& net = model.nets[0];
  const int n = net.node_count;
  const int n0 = net.node_begin;
  const int iterations = options.position_iterations;
  Parts& p = *parts_;
  world_ = &p.world;
  world_->setGravity(btVector3(0, 0, 0));
  btSoftBodyWorldInfo& info = world_->getWorldInfo();
  info.m_gravity.setValue(0, 0, 0);
  info.air_density = 0;
  info.m_sparsesdf.setDefaultVoxelsz(static_cast<btScalar>(options.sdf_voxel));
  info.m_sparsesdf.Reset();

  // Nodes at rest, in the world (the anchored body's initial pose), and the net's triangles.
  const core::Pose& organ_pose = model.bodies[static_cast<std::size_t>(net.body)].initial_pose;
  std::vector<btScalar> xyz;
  xyz.reserve(static_cast<std::size_t>(3 * n));
  for (int i = 0; i < n; ++i) {
    const core::Vec3 x = organ_pose.position +
                         organ_pose.orientation * model.node_rest[static_cast<std::size_t>(n0 + i)];
    for (int c = 0; c < 3; ++c) xyz.push_back(static_cast<btScalar>(x[c]));
  }
  std::vector<int> tris;
  tris.reserve(static_cast<std::size_t>(3 * net.face_count));
  for (int f = net.face_begin; f < net.face_begin + net.face_count; ++f)
    for (int c = 0; c < 3; ++c) tris.push_back(model.net_faces[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)] - n0);
  // A net given by its material (NetModel::tie_scale set) has interior nodes on no triangle:
  // its nodes are made one by one and its links are its springs, each with its own k.
  const bool by_material = !net.tie_scale.empty();
  if (by_material) {
    std::vector<btVector3> x;
    std::vector<btScalar> m;
    for (int i = 0; i < n; ++i) {
      x.emplace_back(xyz[static_cast<std::size_t>(3 * i)], xyz[static_cast<std::size_t>(3 * i + 1)],
                     xyz[static_cast<std::size_t>(3 * i + 2)]);
      m.push_back(static_cast<btScalar>(model.node_mass[static_cast<std::size_t>(n0 + i)]));
    }
    p.soft = std::make_unique<btSoftBody>(&info, n, x.data(), m.data());
    for (int f = 0; f < net.face_count; ++f)
      p.soft->appendFace(tris[static_cast<std::size_t>(3 * f)], tris[static_cast<std::size_t>(3 * f + 1)],
                         tris[static_cast<std::size_t>(3 * f + 2)]);
  } else {
    p.soft.reset(btSoftBodyHelpers::CreateFromTriMesh(info, xyz.data(), tris.data(), net.face_count));
  }
  soft_ = p.soft.get();
  if (soft_->m_nodes.size() != n)
    throw std::invalid_argument("BulletOrgan: the net's triangles do not use every node");
  for (int i = 0; i < n; ++i)
    soft_->setMass(i, static_cast<btScalar>(model.node_mass[static_cast<std::size_t>(n0 + i)]));

  const auto mass = [&](const btSoftBody::Node* node) { return 1.0 / static_cast<double>(node->m_im); };
  const auto reduced = [&](const btSoftBody::Node* a, const btSoftBody::Node* b) {
    return mass(a) * mass(b) / (mass(a) + mass(b));
  };
  const auto material = [&](double klst) {
    btSoftBody::Material* m = soft_->appendMaterial();
    m->m_kLST = static_cast<btScalar>(klst);
    m->m_kAST = 1;
    m->m_kVST = 1;
    return m;
  };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  stats_.nodes = n;
  stats_.faces = soft_->m_faces.size();
  stats_.structural_links = soft_->m_links.size();
  stats_.klst_min = stats_.bend_klst_min = kInf;
  stats_.klst_max = stats_.bend_klst_max = -kInf;
  // One link for numen spring s, its kLST from the spring's k; returns the kLST.
  const auto append_spring_link = [&](int s) {
    const core::NetSpring& sp = model.net_springs[static_cast<std::size_t>(s)];
    const int a = sp.node_a - n0, b = sp.node_b - n0;
    const double klst =
        link_stiffness_fraction(sp.stiffness, reduced(&soft_->m_nodes[a], &soft_->m_nodes[b]), dt_, iterations);
    soft_->appendLink(a, b, material(klst), false);
    return klst;
  };
  const int springs_end = net.spring_begin + net.structural_count + net.bending_count;
  if (by_material) {
    // A material net: every spring (the tetrahedra's edges) one link, with its own k; shuffled as
    // CreateFromTriMesh shuffles its links (Bullet's Gauss–Seidel order).
    for (int s = net.spring_begin; s < springs_end; ++s) {
      const double klst = append_spring_link(s);
      stats_.klst_min = std::min(stats_.klst_min, klst);
      stats_.klst_max = std::max(stats_.klst_max, klst);
    }
    soft_->randomizeConstraints();
    stats_.structural_links = soft_->m_links.size();
  } else {
    // Structural: the mesh edges CreateFromTriMesh linked; every numen structural spring of the
    // net has the same k (NetSettings::stiffness).
    const double k_structural = net.structural_count > 0
                                    ? model.net_springs[static_cast<std::size_t>(net.spring_begin)].stiffness
                                    : 0.0;
    for (int i = 0; i < soft_->m_links.size(); ++i) {
      btSoftBody::Link& l = soft_->m_links[i];
      const double klst = link_stiffness_fraction(k_structural, reduced(l.m_n[0], l.m_n[1]), dt_, iterations);
      l.m_material = material(klst);
      stats_.klst_min = std::min(stats_.klst_min, klst);
      stats_.klst_max = std::max(stats_.klst_max, klst);
    }
    // Bending: numen's bending springs, one link each.
    for (int s = net.spring_begin + net.structural_count; s < springs_end; ++s) {
      const double klst = append_spring_link(s);
      stats_.bend_klst_min = std::min(stats_.bend_klst_min, klst);
      stats_.bend_klst_max = std::max(stats_.bend_klst_max, klst);
      ++stats_.bending_links;
    }
  }
  if (stats_.bending_links == 0) stats_.bend_klst_min = stats_.bend_klst_max = 0.0;

  // Ties: an anchor per node on a static body at the organ's pose.
  p.anchor_body = std::make_unique<btRigidBody>(0.0, nullptr, &p.anchor_shape);
  p.anchor_body->setWorldTransform(bt_pose(organ_pose));
  stats_.influence_min = kInf;
  stats_.influence_max = -kInf;
  for (int i = 0; i < n; ++i) {
    const double scale = core::tie_scale(net, n0 + i);  // a material net's per-node volume share
    const AnchorMapping am = anchor_mapping(scale * net.tie_stiffness, scale * net.tie_damping,
                                            mass(&soft_->m_nodes[i]), dt_, iterations);
    soft_->appendAnchor(i, p.anchor_body.get(), false, static_cast<btScalar>(am.influence));
    soft_->m_nodes[i].m_battach = 0;  // anchored nodes still collide (CollideSDF_RS skips them)
    stats_.anchor_hardness = am.hardness;
    stats_.influence_min = std::min(stats_.influence_min, am.influence);
    stats_.influence_max = std::max(stats_.influence_max, am.influence);
  }
  stats_.anchors = soft_->m_anchors.size();

  btSoftBody::Config& cfg = soft_->m_cfg;
  cfg.piterations = iterations;
  cfg.kAHR = static_cast<btScalar>(stats_.anchor_hardness);
  cfg.kDP = 0;  // the ties' damping is in the anchors
  cfg.kMT = 0;  // no pose matching
  cfg.kDF = 0;  // no friction, as numen's tissue
  cfg.kCHR = 1;
  cfg.collisions = btSoftBody::fCollision::SDF_RS;
  soft_->getCollisionShape()->setMargin(static_cast<btScalar>(options.margin));
  soft_->setActivationState(DISABLE_DEACTIVATION);
  world_->addSoftBody(soft_);

  // The tool: sphere 0 of body 1, with the body's mass.
  const core::BodyModel& tool_model = model.bodies[1];
  const core::Sphere& sphere = model.body_spheres[static_cast<std::size_t>(tool_model.sphere_begin)];
  if (!sphere.center.isZero())
    throw std::invalid_argument("BulletOrgan: the tool's sphere must be at its body's origin");
  tool_mass_ = tool_model.mass;
  p.tool_shape = std::make_unique<btSphereShape>(static_cast<btScalar>(sphere.radius));
  btVector3 inertia(0, 0, 0);
  p.tool_shape->calculateLocalInertia(static_cast<btScalar>(tool_mass_), inertia);
  p.tool = std::make_unique<btRigidBody>(static_cast<btScalar>(tool_mass_), nullptr, p.tool_shape.get(), inertia);
  tool_ = p.tool.get();
  tool_->setFriction(0);
  tool_->setRestitution(0);
  tool_->setDamping(0, 0);
  tool_->setActivationState(DISABLE_DEACTIVATION);
  world_->addRigidBody(tool_);
  tool_->setGravity(btVector3(0, 0, 0));
  set_tool(tool_model.initial_pose.position, core::Vec3::Zero());
}

BulletOrgan::~BulletOrgan() = default;

void BulletOrgan::set_tool(const core::Vec3& position, const core::Vec3& velocity) {
  btTransform t;
  t.setIdentity();
  t.setOrigin(bt(position));
  tool_->setWorldTransform(t);
  tool_->setInterpolationWorldTransform(t);
  tool_->setLinearVelocity(bt(velocity));
  tool_->setInterpolationLinearVelocity(bt(velocity));
  tool_->setAngularVelocity(btVector3(0, 0, 0));
  tool_->setInterpolationAngularVelocity(btVector3(0, 0, 0));
  tool_velocity_set_ = from_bt(bt(velocity));  // as Bullet holds it (btScalar)
}

void BulletOrgan::step() { world_->stepSimulation(static_cast<btScalar>(dt_), 0); }

core::Vec3 BulletOrgan::force_on_organ() const {
  return -tool_mass_ * (from_bt(tool_->getLinearVelocity()) - tool_velocity_set_) / dt_;
}

core::Vec3 BulletOrgan::node_position(int i) const { return from_bt(soft_->m_nodes[i].m_x); }

int BulletOrgan::num_nodes() const { return soft_->m_nodes.size(); }

int BulletOrgan::num_contacts() const { return soft_->m_rcontacts.size(); }

std::vector<std::pair<int, int>> BulletOrgan::link_pairs() const {
  std::vector<std::pair<int, int>> out;
  const btSoftBody::Node* base = &soft_->m_nodes[0];
  for (int i = 0; i < soft_->m_links.size(); ++i) {
    const auto a = static_cast<int>(soft_->m_links[i].m_n[0] - base);
    const auto b = static_cast<int>(soft_->m_links[i].m_n[1] - base);
    out.emplace_back(std::min(a, b), std::max(a, b));
  }
  return out;
}

}  // namespace numen::soft_peer
