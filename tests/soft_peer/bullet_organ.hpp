#pragma once
/// @file bullet_organ.hpp
/// A numen organ (core::Model: net 0 on an anchored body 0, a one-sphere tool body 1, as
/// organ_indentation.hpp's organ_model() builds it) translated into Bullet 3's soft body
/// (btSoftRigidDynamicsWorld, btSoftBody) and pressed by the same sphere (docs/soft_peer.md).
///
/// Frames and units: Bullet's world frame is numen's world frame (the organ's anchored body at
/// its initial pose), SI units; Bullet's gravity is zero as the organ model's.
///
/// The translation (soft_peer_mapping.hpp for the constants):
///  - nodes: the net's nodes at their rest positions, each with numen's node mass
///    (Model::node_mass, lumped by vertex area);
///  - links: btSoftBodyHelpers::CreateFromTriMesh on the net's triangles (Model::net_faces),
///    one link per mesh edge = numen's structural springs; one more link per numen bending
///    spring (the two far nodes of adjacent triangles); each link its own material, its
///    kLST from its spring's k and its nodes' reduced mass (link_stiffness_fraction());
///  - a net given by its material (NetModel::tie_scale set; docs/tissue.md): its surface and
///    interior nodes made one by one (btSoftBody's constructor), the net's triangles appended
///    as faces, one link per numen spring (the tetrahedra's edges) with its own k, shuffled
///    (btSoftBody::randomizeConstraints(), as CreateFromTriMesh does), every link counted in
///    BulletOrganStats::structural_links; each node's tie scaled by its tie_scale();
///  - ties: one anchor per node on a static rigid body at the organ's pose (anchor_mapping():
///    Config::kAHR and each anchor's influence); Bullet skips rigid contacts of anchored nodes
///    (Node::m_battach), which is cleared so that they still collide with the tool;
///  - the tool: a dynamic btRigidBody, btSphereShape of the tool's radius and its mass, no
///    friction, held on the path: before each step its pose and velocity are set to the
///    path's; the soft body's contact impulses change its velocity during the step, and the
///    force on the organ is their sum over the step per second, −M (v_after − v_path) / dt;
///  - contacts: Bullet's node-against-rigid contacts (fCollision::SDF_RS, hardness kCHR = 1),
///    found in the sphere's sparse signed distance field (voxel `sdf_voxel`) within the soft
///    body's collision margin `margin` of its surface; numen's contacts are against the net's
///    triangles.
///
/// Needs Bullet's BulletSoftBody, BulletDynamics, BulletCollision, LinearMath.

#include <memory>
#include <vector>

#include "numen/core/model.hpp"

class btSoftRigidDynamicsWorld;
class btSoftBody;
class btRigidBody;

namespace numen::soft_peer {

/// Choices of the Bullet side that numen's model does not fix.
struct BulletOptions {
  int position_iterations = 4;  ///< Config::piterations (Bullet's default is 1; the issue's 4).
  double margin = 1e-4;         ///< Soft body collision margin (m): contact within it.
  double sdf_voxel = 2.5e-4;    ///< Sparse SDF voxel (m); Bullet's default 0.25 m is 100x the tool.
};

/// What the translation made (counts; the constants' range over nodes and links).
struct BulletOrganStats {
  int nodes = 0;
  int structural_links = 0;  ///< Links CreateFromTriMesh made (mesh edges).
  int bending_links = 0;     ///< Links added for numen's bending springs.
  int faces = 0;
  int anchors = 0;
  double anchor_hardness = 0.0;                    ///< Config::kAHR.
  double influence_min = 0.0, influence_max = 0.0;  ///< Over the anchors.
  double klst_min = 0.0, klst_max = 0.0;            ///< Over the structural links.
  double bend_klst_min = 0.0, bend_klst_max = 0.0;  ///< Over the bending links.
};

/// The Bullet world of one organ and its tool. Not copyable.
class BulletOrgan {
 public:
  /// Translates `model` (net 0 on body 0, tool sphere 0 on body 1; Model::dt the step) at the
  /// model's initial state. Throws std::invalid_argument when the model does not have that
  /// shape or a constant cannot be mapped (anchor_mapping()).
  BulletOrgan(const core::Model& model, const BulletOptions& options);
  ~BulletOrgan();
  BulletOrgan(const BulletOrgan&) = delete;
  BulletOrgan& operator=(const BulletOrgan&) = delete;

  /// Places the tool's centre at `position` (m, world) moving at `velocity` (m/s), no rotation.
  void set_tool(const core::Vec3& position, const core::Vec3& velocity);

  /// One step of Model::dt: btSoftRigidDynamicsWorld::stepSimulation(dt, 0) (exactly one
  /// internal step). The call a benchmark times.
  void step();

  /// The force the tool put on the organ over the last step (N, world), from the change of the
  /// tool's momentum since set_tool(): −M (v − v_set) / dt.
  core::Vec3 force_on_organ() const;

  /// Node `i`'s position (m, world) and the number of nodes.
  core::Vec3 node_position(int i) const;
  int num_nodes() const;

  /// Nodes in contact with the tool at the last step (Bullet's rigid contacts).
  int num_contacts() const;

  /// Node pairs of the soft body's links (node_a < node_b), in Bullet's order.
  std::vector<std::pair<int, int>> link_pairs() const;

  const BulletOrganStats& stats() const { return stats_; }

  /// Bullet's own objects, for tests (owned by this object).
  btSoftBody* soft_body() const { return soft_; }
  btRigidBody* tool() const { return tool_; }

 private:
  struct Parts;
  std::unique_ptr<Parts> parts_;
  btSoftRigidDynamicsWorld* world_ = nullptr;
  btSoftBody* soft_ = nullptr;
  btRigidBody* tool_ = nullptr;
  double dt_ = 0.0;
  double tool_mass_ = 0.0;
  core::Vec3 tool_velocity_set_ = core::Vec3::Zero();
  BulletOrganStats stats_;
};

}  // namespace numen::soft_peer
