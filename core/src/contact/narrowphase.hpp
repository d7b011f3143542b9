#pragma once
/// @file narrowphase.hpp
/// Private to numen::core (core/src/contact; tests reach it through numen_core_internal).
/// Narrow phase of the collision stage (paper §5): the contact geometry of a
/// sphere (of a dynamic body, "a") against a static shape or another sphere
/// ("b"), world frame, SI units.
///
/// Convention (contact.hpp): `normal` is a unit vector from b towards a (it
/// pushes a out of b); `depth` > 0 is the overlap along it; `position` is the
/// middle of the overlap: halfway between the deepest point of a inside b
/// (c_a − r_a n) and the surface point of b it is pushed to.
/// Degenerate cases (coincident centres, centre on a capsule's segment) give a
/// deterministic finite unit normal, never NaN. No allocation, no exception.

#include "numen/core/types.hpp"

namespace numen::core {
struct MeshShape;
}

namespace numen::core {

/// Contact geometry of one sphere pair / sphere–shape pair.
struct ContactGeometry {
  Vec3 position = Vec3::Zero();  ///< Middle of the overlap (m).
  Vec3 normal = Vec3::UnitZ();   ///< Unit, from b towards a.
  double depth = 0.0;            ///< Penetration (m), > 0 when a contact is reported.
};

/// Below this squared distance (m²) a centre is treated as lying on the other
/// centre or segment, and the fallback normal is used (1e-12 m).
inline constexpr double kDegenerateDistance2 = 1e-24;

/// Broad test of two spheres: true iff |c_a − c_b|² < (r_a + r_b)². The exact
/// expression used by sphere_sphere(), so that a prefilter built on it never
/// rejects a pair sphere_sphere() would report.
inline bool spheres_overlap(const Vec3& ca, double ra, const Vec3& cb, double rb) noexcept {
  const double s = ra + rb;
  return (ca - cb).squaredNorm() < s * s;
}

/// Sphere a (centre ca, radius ra) against sphere b (cb, rb). When the centres
/// coincide, the normal is `fallback` normalized, or +z if `fallback` is ~0.
/// Returns true and fills `out` when they overlap with depth > 0.
bool sphere_sphere(const Vec3& ca, double ra, const Vec3& cb, double rb, const Vec3& fallback,
                   ContactGeometry& out) noexcept;

/// Sphere against the solid half-space below the plane through `point` with
/// unit normal `normal` (pointing out of the solid). The normal is `normal`
/// whatever the depth.
bool sphere_plane(const Vec3& c, double r, const Vec3& point, const Vec3& normal,
                  ContactGeometry& out) noexcept;

/// Sphere against a solid box of centre `center`, rotation `rotation` (box →
/// world, columns are the box axes) and half extents `half` (m). A centre
/// inside the box (or on its surface) is pushed out through the nearest face
/// (ties: x before y before z, + before −).
bool sphere_box(const Vec3& c, double r, const Vec3& center, const Mat3& rotation, const Vec3& half,
                ContactGeometry& out) noexcept;

/// Sphere against a capsule: segment centre `center`, unit axis `axis`, half
/// length `half_length`, radius `radius` (m). A centre on the segment is pushed
/// out perpendicular to the axis, towards the world axis least aligned with it
/// (ties: x before y before z).
bool sphere_capsule(const Vec3& c, double r, const Vec3& center, const Vec3& axis,
                    double half_length, double radius, ContactGeometry& out) noexcept;

/// Sphere against the solid inside of a closed mesh `shape` placed at `pose` (mesh frame → world):
/// the exact signed distance sd of the centre to the surface (mesh_signed_distance(), reach r),
/// depth r − sd, normal the unit direction of the closest feature (outward), surface point the
/// closest point. A centre inside, however deep, is pushed out through the nearest surface point.
bool sphere_mesh(const Vec3& c, double r, const MeshShape& shape, const Pose& pose,
                 ContactGeometry& out) noexcept;

}  // namespace numen::core
