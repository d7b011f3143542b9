#pragma once
/// @file lean_scenes.hpp
/// A rigid-only model (one coupled body with spheres, no joints, nets or
/// obstacles) and the same model plus one optional part: an obstacle, a second
/// body joined by a revolute joint, or a deformable net on the body. Used by
/// the lean-scene tests (data_size, step_stages, capacity) and the lean benchmark.

#include <stdexcept>
#include <string>

#include <vector>

#include "numen/core/features.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_model.hpp"

namespace numen::test {

/// Optional part added to the rigid-only model.
enum class LeanPart { kNone, kObstacle, kJoint, kNet, kJointAndNet };

/// The parts this build has (NUMEN_WITH_ARTICULATION, NUMEN_WITH_DEFORMABLE).
inline std::vector<LeanPart> lean_parts() {
  std::vector<LeanPart> parts{LeanPart::kNone, LeanPart::kObstacle};
  if (core::kWithArticulation) parts.push_back(LeanPart::kJoint);
  if (core::kWithDeformable) parts.push_back(LeanPart::kNet);
  return parts;
}

/// The rigid-only model (kNone) or it plus `part` (kJointAndNet: the joint and the
/// net), finalized. Throws
/// std::runtime_error if the model is refused (a part this build left out).
inline core::Model make_lean_model(LeanPart part) {
  core::Model m;
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{}};
  const auto add_body = [&m](const core::Vec3& at) {
    core::BodyModel b;
    b.name = "tool" + std::to_string(m.bodies.size());
    b.mass = 0.2;
    b.inertia_body = core::Mat3::Identity() * 1e-4;
    b.sphere_begin = static_cast<int>(m.body_spheres.size());
    b.sphere_count = 3;
    for (int k = 0; k < 3; ++k)
      m.body_spheres.push_back(core::Sphere{core::Vec3(0.0, 0.0, 0.02 * (k - 1)), 0.01});
    b.coupling = {400.0, core::damping_from_ratio(0.8, b.mass, 400.0), 0.5, 0.02};
    b.initial_pose.position = at;
    m.bodies.push_back(b);
  };
  add_body(core::Vec3(0.0, 0.0, 0.1));
  m.initial_held_body = 0;
  m.feedback = {400.0, 2.0, 0.5, 0.01, 10.0, 1.0};
  std::string err;
  const bool joint = part == LeanPart::kJoint || part == LeanPart::kJointAndNet;
  const bool net = part == LeanPart::kNet || part == LeanPart::kJointAndNet;
  if (part == LeanPart::kObstacle) {
    core::Obstacle floor;
    floor.name = "floor";
    m.obstacles.push_back(floor);
  }
  if (joint) {
    add_body(core::Vec3(0.0, 0.0, 0.2));
    // Bodies of one articulation never collide with each other: no contact is possible.
    core::JointModel j;
    j.name = "hinge";
    j.type = core::JointType::kRevolute;
    j.parent = 0;
    j.child = 1;
    j.frame_parent.position = core::Vec3(0.0, 0.0, 0.05);
    j.frame_child.position = core::Vec3(0.0, 0.0, -0.05);
    m.joints.push_back(j);
  }
  if (net) {
    core::NetSettings s;
    s.name = "skin";
    s.body = 0;
    s.mass = 0.05;
    s.stiffness = 200.0;
    s.damping = 0.05;
    s.tie_stiffness = 5.0;
    s.tie_damping = 0.05;
    if constexpr (core::kWithDeformable)
      err = core::add_net(m, core::make_icosphere(0.03, 1), s);
    else
      err = "nets: this build has NUMEN_WITH_DEFORMABLE=OFF";
  }
  if (err.empty()) err = core::finalize_model(m);
  if (!err.empty()) throw std::runtime_error(err);
  return m;
}

}  // namespace numen::test
