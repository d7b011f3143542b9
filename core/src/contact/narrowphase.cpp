/// @file narrowphase.cpp
/// Sphere against sphere, plane, box and capsule (paper §5, sphere-based
/// collision). See narrowphase.hpp for the contact convention.

#include <algorithm>
#include <cmath>

#include "contact/narrowphase.hpp"
#include "numen/core/mesh_shape.hpp"

namespace numen::core {
namespace {

/// Fills `out` from the surface point of b (`surface_b`), the normal and the
/// depth: position is halfway between surface_b and the deepest point of a.
inline void finish(const Vec3& surface_b, const Vec3& n, double depth,
                   ContactGeometry& out) noexcept {
  out.normal = n;
  out.depth = depth;
  out.position = surface_b - (0.5 * depth) * n;
}

}  // namespace

bool sphere_sphere(const Vec3& ca, double ra, const Vec3& cb, double rb, const Vec3& fallback,
                   ContactGeometry& out) noexcept {
  if (!spheres_overlap(ca, ra, cb, rb)) return false;
  const Vec3 diff = ca - cb;
  const double d2 = diff.squaredNorm();
  Vec3 n;
  double d = 0.0;
  if (d2 > kDegenerateDistance2) {
    d = std::sqrt(d2);
    n = diff / d;
  } else {
    const double f2 = fallback.squaredNorm();
    n = (f2 > kDegenerateDistance2) ? Vec3(fallback / std::sqrt(f2)) : Vec3::UnitZ();
  }
  const double depth = ra + rb - d;
  if (!(depth > 0.0)) return false;
  finish(cb + rb * n, n, depth, out);
  return true;
}

bool sphere_plane(const Vec3& c, double r, const Vec3& point, const Vec3& normal,
                  ContactGeometry& out) noexcept {
  const double s = (c - point).dot(normal);  // signed distance of the centre
  const double depth = r - s;
  if (!(depth > 0.0)) return false;
  finish(c - s * normal, normal, depth, out);
  return true;
}

bool sphere_box(const Vec3& c, double r, const Vec3& center, const Mat3& rotation, const Vec3& half,
                ContactGeometry& out) noexcept {
  const Vec3 local = rotation.transpose() * (c - center);
  const Vec3 q = local.cwiseMax(-half).cwiseMin(half);
  const Vec3 diff = local - q;
  const double d2 = diff.squaredNorm();
  if (!(d2 < r * r)) return false;
  Vec3 n_local;
  Vec3 surface_local;
  double depth;
  if (d2 > kDegenerateDistance2) {
    // Centre outside: the closest point of the box is on its surface.
    const double d = std::sqrt(d2);
    n_local = diff / d;
    surface_local = q;
    depth = r - d;
  } else {
    // Centre inside (or on the surface): out through the nearest face.
    int axis = 0;
    double sign = 1.0;
    double best = half.x() - local.x();
    for (int k = 0; k < 3; ++k) {
      const double up = half[k] - local[k];
      const double down = half[k] + local[k];
      if (up < best) {
        best = up;
        axis = k;
        sign = 1.0;
      }
      if (down < best) {
        best = down;
        axis = k;
        sign = -1.0;
      }
    }
    n_local = Vec3::Zero();
    n_local[axis] = sign;
    surface_local = local;
    surface_local[axis] = sign * half[axis];
    depth = r + best;
  }
  if (!(depth > 0.0)) return false;
  finish(center + rotation * surface_local, rotation * n_local, depth, out);
  return true;
}

bool sphere_capsule(const Vec3& c, double r, const Vec3& center, const Vec3& axis,
                    double half_length, double radius, ContactGeometry& out) noexcept {
  const Vec3 rel = c - center;
  const double t = std::clamp(rel.dot(axis), -half_length, half_length);
  const Vec3 q = center + t * axis;  // closest point of the segment
  const Vec3 diff = c - q;
  const double d2 = diff.squaredNorm();
  const double s = r + radius;
  if (!(d2 < s * s)) return false;
  Vec3 n;
  double d = 0.0;
  if (d2 > kDegenerateDistance2) {
    d = std::sqrt(d2);
    n = diff / d;
  } else {
    // On the segment: perpendicular to the axis, towards the least aligned world axis.
    const Vec3 a = axis.cwiseAbs();
    int k = 0;
    if (a.y() < a[k]) k = 1;
    if (a.z() < a[k]) k = 2;
    const Vec3 e = Vec3::Unit(k);
    n = (e - e.dot(axis) * axis).normalized();
  }
  const double depth = s - d;
  if (!(depth > 0.0)) return false;
  finish(q + radius * n, n, depth, out);
  return true;
}

bool sphere_mesh(const Vec3& c, double r, const MeshShape& shape, const Pose& pose,
                 ContactGeometry& out) noexcept {
  const Vec3 local = pose.orientation.conjugate() * (c - pose.position);
  MeshDistance md;
  if (!mesh_signed_distance(shape, local, r, md)) return false;
  const double depth = r - md.distance;
  if (!(depth > 0.0)) return false;
  const Vec3 n = pose.orientation * md.normal;
  finish(pose.position + pose.orientation * md.point, n, depth, out);
  return true;
}

}  // namespace numen::core
