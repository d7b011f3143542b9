#pragma once
/// @file contact.hpp
/// A penalty contact point between a dynamic body's sphere and an obstacle, another dynamic
/// body's sphere or another dynamic body's mesh (paper §5: sphere-based collision).

#include "numen/core/types.hpp"

namespace numen::core {

/// One contact point, world frame. Geometry is filled by the collision stage
/// (detect_contacts), `force` by the contact force stage.
struct Contact {
  int body_a = -1;          ///< Dynamic body receiving +force.
  int body_b = -1;          ///< Other dynamic body (receives −force), or -1 for a static obstacle.
  int obstacle = -1;        ///< Obstacle index when body_b == -1, else -1.
  int sphere_a = -1;        ///< Index into Model::body_spheres.
  /// Index into body_spheres (body_b >= 0) or static_spheres, or -1: a plane or mesh obstacle,
  /// or body_b's mesh (BodyModel::mesh) when body_b >= 0.
  int sphere_b = -1;
  int material_pair = 0;    ///< Index into Model::material_pairs.
  Vec3 position = Vec3::Zero();  ///< Contact point (m): middle of the overlap.
  Vec3 normal = Vec3::UnitZ();   ///< Unit normal from b towards a: pushes a out along +normal.
  double depth = 0.0;            ///< Penetration depth (m), > 0.
  Vec3 force = Vec3::Zero();     ///< Penalty force on body_a at `position` (N); −force on body_b.
  /// body_b == -1: velocity of the static side's surface at the contact (m/s, world), taken
  /// off body_a's point velocity in the penalty law. Zero for obstacles (detect_contacts); the
  /// moving planes of the multirate intermediate model set it (multirate.hpp).
  Vec3 surface_velocity = Vec3::Zero();
  /// Scales of the material pair's stiffness and damping for this contact (1: the pair's own).
  /// A multirate node plane (multirate.hpp) renders a net node's contact through the node's
  /// compliance: the contact stiffness k in series with the node's stiffness k_n to its rigid
  /// component gives k s with s = k_n / (k + k_n), the damping c s² (a Kelvin–Voigt element in
  /// series with a spring, its low-frequency limit). Friction is not scaled.
  double stiffness_scale = 1.0;
  double damping_scale = 1.0;
};

}  // namespace numen::core
