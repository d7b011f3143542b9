/// @file needle.cpp
/// The needle's shape: its body, its arc, its checks (needle.hpp).

#include "numen/core/needle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "numen/core/grasp.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"

namespace numen::core {
namespace {

/// θ of arc parameter s (clamped to [0, L]).
double arc_angle_at(const NeedleModel& n, double s) noexcept {
  return n.tail_angle + std::clamp(s, 0.0, n.length()) / n.radius;
}

}  // namespace

double needle_steel_mass(double radius, double arc, double wire_radius) noexcept {
  return kNeedleSteelDensity * std::numbers::pi * wire_radius * wire_radius * radius * 2.0 *
         std::numbers::pi * arc;
}

int add_needle(Model& model, const NeedleSpec& spec) {
  NeedleModel n;
  n.name = spec.name;
  n.radius = spec.radius;
  n.arc_angle = 2.0 * std::numbers::pi * spec.arc;
  n.wire_radius = spec.wire_radius;
  n.tail_angle = -0.5 * n.arc_angle;
  n.tip_angle = 0.5 * n.arc_angle;
  n.puncture_force = spec.puncture_force;
  n.puncture_max_angle = spec.puncture_max_angle;
  n.tie_stiffness = spec.tie_stiffness;
  n.tie_damping = spec.tie_damping;
  n.friction = spec.friction;
  const double half = 0.5 * n.arc_angle;
  // The arc's centroid lies at R sin(α)/α from the circle's centre along +x (α = φ/2).
  const double centroid = half > 0.0 ? n.radius * std::sin(half) / half : n.radius;
  n.centre = Vec3(-centroid, 0.0, 0.0);
  BodyModel b;
  b.name = spec.name;
  b.mass = std::isnan(spec.mass) ? needle_steel_mass(spec.radius, spec.arc, spec.wire_radius) : spec.mass;
  b.material = spec.material;
  b.initial_pose = spec.pose;
  b.sharp = true;  // its tip cuts: an organ given by its material meets it by the pair's penalty
  // A thin arc about the circle's centre: ∫x² = m R² (1/2 + sin 2α / 4α), ∫y² = m R² (1/2 − sin 2α / 4α);
  // about the centroid, ∫x'² = ∫x² − m x̄². Plus the wire's own section, m r_w² / 2 (kept on
  // every axis: an upper bound on its ≤ m r_w² / 2 contribution).
  const double m = b.mass, r2 = n.radius * n.radius;
  const double s2a = half > 0.0 ? std::sin(2.0 * half) / (4.0 * half) : 0.5;
  const double xx = m * r2 * (0.5 + s2a) - m * centroid * centroid;
  const double yy = m * r2 * (0.5 - s2a);
  const double wire = 0.5 * m * spec.wire_radius * spec.wire_radius;
  b.inertia_body = Vec3(yy + wire, xx + wire, xx + yy + wire).asDiagonal();
  // Spheres along the arc, tail to tip, their centres at most r_w apart along it.
  const double length = n.length();
  const int count = spec.wire_radius > 0.0 && std::isfinite(length / spec.wire_radius)
                        ? std::max(2, static_cast<int>(std::ceil(length / spec.wire_radius)) + 1)
                        : 0;
  b.sphere_begin = static_cast<int>(model.body_spheres.size());
  b.sphere_count = count;
  n.sphere_begin = b.sphere_begin;
  n.sphere_count = count;
  for (int i = 0; i < count; ++i)
    model.body_spheres.push_back(Sphere{needle_point(n, length * i / (count - 1)), spec.wire_radius});
  n.body = model.num_bodies();
  model.bodies.push_back(b);
  model.needles.push_back(n);
  return static_cast<int>(model.needles.size()) - 1;
}

Vec3 needle_point(const NeedleModel& needle, double s) noexcept {
  const double theta = arc_angle_at(needle, s);
  return needle.centre + needle.radius * Vec3(std::cos(theta), std::sin(theta), 0.0);
}

Vec3 needle_tangent(const NeedleModel& needle, double s) noexcept {
  const double theta = arc_angle_at(needle, s);
  return Vec3(-std::sin(theta), std::cos(theta), 0.0);
}

double needle_closest_parameter(const NeedleModel& needle, const Vec3& point) noexcept {
  const Vec3 q = point - needle.centre;
  if (q.x() == 0.0 && q.y() == 0.0) return 0.0;  // on the axis: every point is as close
  const double theta = std::atan2(q.y(), q.x());  // in (−π, π]; the arc is [−φ/2, φ/2] ⊂ (−π, π)
  if (theta >= needle.tail_angle && theta <= needle.tip_angle) return (theta - needle.tail_angle) * needle.radius;
  // In the gap: the nearer end (by the angle, the same as by distance on the circle).
  const double to_tip = theta > needle.tip_angle
                            ? theta - needle.tip_angle
                            : theta - needle.tip_angle + 2.0 * std::numbers::pi;
  const double to_tail = theta < needle.tail_angle
                             ? needle.tail_angle - theta
                             : needle.tail_angle - theta + 2.0 * std::numbers::pi;
  return to_tip < to_tail ? needle.length() : 0.0;
}

std::string finalize_needles(const Model& model) {
  for (const NeedleModel& n : model.needles) {
    const std::string who = "needle '" + n.name + "': ";
    if (n.body < 0 || n.body >= model.num_bodies()) return who + "its body is not a body of the model";
    const BodyModel& b = model.bodies[static_cast<std::size_t>(n.body)];
    if (b.anchored) return who + "its body is anchored: a needle moves";
    if (!(n.wire_radius > 0.0) || !std::isfinite(n.wire_radius))
      return who + "wire_radius must be > 0 (m), got " + std::to_string(n.wire_radius);
    if (!(n.radius > n.wire_radius) || !std::isfinite(n.radius))
      return who + "radius (" + std::to_string(n.radius) + " m) must exceed wire_radius (" +
             std::to_string(n.wire_radius) + " m)";
    if (!(n.arc_angle > 0.0) || !(n.arc_angle < 2.0 * std::numbers::pi))
      return who + "arc must be a fraction of a circle in (0, 1), got " +
             std::to_string(n.arc_angle / (2.0 * std::numbers::pi));
    if (!std::isnan(n.puncture_force) && !(n.puncture_force > 0.0 && std::isfinite(n.puncture_force)))
      return who + "puncture_force must be > 0 (N), got " + std::to_string(n.puncture_force);
    if (!(n.puncture_max_angle > 0.0 && n.puncture_max_angle <= 0.5 * std::numbers::pi))
      return who + "puncture_max_angle must be in (0, π/2] (rad), got " + std::to_string(n.puncture_max_angle);
    if (!(n.tie_stiffness > 0.0 && std::isfinite(n.tie_stiffness)))
      return who + "tie_stiffness must be > 0 (N/m), got " + std::to_string(n.tie_stiffness);
    if (!(n.tie_damping >= 0.0 && std::isfinite(n.tie_damping)) || !(n.friction >= 0.0 && std::isfinite(n.friction)))
      return who + "tie_damping and friction must be ≥ 0 (N·s/m)";
    if (n.sphere_count < 2 || n.sphere_begin != b.sphere_begin || n.sphere_count != b.sphere_count)
      return who + "its spheres are not its body's (build it with add_needle())";
  }
  return {};
}

double grasp_widest_wire(const Model& model, int grasp) noexcept {
  const GraspModel& g = model.grasps[static_cast<std::size_t>(grasp)];
  double widest = -std::numeric_limits<double>::infinity();
  bool hinged = false;
  for (int k = 0; k < 2; ++k) {
    const int joint = g.jaw_joints[static_cast<std::size_t>(k)];
    const BodyModel& jaw = model.bodies[static_cast<std::size_t>(g.jaws[static_cast<std::size_t>(k)])];
    Vec3 pivot = Vec3::Zero(), axis = Vec3::UnitZ();
    if (joint >= 0) {
      const JointModel& jm = model.joints[static_cast<std::size_t>(joint)];
      pivot = jm.frame_child.position;
      axis = jm.frame_child.orientation * Vec3::UnitZ();
      hinged = true;
    }
    for (int i = 0; i < jaw.sphere_count; ++i) {
      const Sphere& s = model.body_spheres[static_cast<std::size_t>(jaw.sphere_begin + i)];
      const Vec3 off = s.center - pivot;
      const double d = joint >= 0 ? (off - off.dot(axis) * axis).norm() : 0.0;
      widest = std::max(widest, 2.0 * (d * std::sin(0.5 * g.close_angle) - s.radius));
    }
  }
  return hinged ? widest : std::numeric_limits<double>::infinity();
}

}  // namespace numen::core
