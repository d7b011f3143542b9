/// @file collision.cpp
/// Collision stage (paper §5, sphere-based collision for penalty contacts):
/// world sphere centres, broad phase (obstacle bounds, static sphere grid,
/// sort-and-sweep between bodies) and contact output with a fixed capacity.

#include "numen/core/collision.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "contact/collision_query.hpp"
#include "numen/core/broadphase.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "contact/narrowphase.hpp"

namespace numen::core {
namespace {

using collision_detail::box_distance2;
using collision_detail::boxes_overlap;
using collision_detail::kInf;
using collision_detail::kMargin;

/// Writes contacts up to the capacity, counts the rest.
struct ContactSink {
  Data& data;
  int count = 0;
  int dropped = 0;
  double max_depth = 0.0;

  void add(int body_a, int body_b, int obstacle, int sphere_a, int sphere_b, int material_pair,
           const ContactGeometry& g) noexcept {
    max_depth = std::max(max_depth, g.depth);
    if (count >= kMaxContacts) {
      ++dropped;
      return;
    }
    Contact& c = data.contacts[static_cast<std::size_t>(count++)];
    c.body_a = body_a;
    c.body_b = body_b;
    c.obstacle = obstacle;
    c.sphere_a = sphere_a;
    c.sphere_b = sphere_b;
    c.material_pair = material_pair;
    c.position = g.position;
    c.normal = g.normal;
    c.depth = g.depth;
    c.force.setZero();
    c.surface_velocity.setZero();  // a static side stands still
    c.stiffness_scale = 1.0;       // the material pair's own law
    c.damping_scale = 1.0;
  }
};

/// Fallback normal direction for coincident centres: from b's reference point
/// towards a's centre of mass (normalized by the narrow phase, +z if zero).
inline Vec3 fallback_from(const Vec3& body_com, const Vec3& b_point) noexcept {
  return body_com - b_point;
}

/// Body `b` against the primitive (non sphere-set) obstacle `o`: first its
/// bounding sphere against the exact shape, then each of its spheres.
void collide_body_obstacle(const Model& model, const Data& data, int b, int o,
                           ContactSink& sink) noexcept {
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
  const Obstacle& ob = model.obstacles[static_cast<std::size_t>(o)];
  const Vec3& x = data.bodies[static_cast<std::size_t>(b)].position;
  const Vec3* sw = data.scratch->collision.sphere_world.data();
  const Sphere* bs = model.body_spheres.data();
  const int s0 = bm.sphere_begin;
  const int s1 = bm.sphere_begin + bm.sphere_count;
  const int mat = bm.material * model.num_materials() + ob.material;
  ContactGeometry g;

  switch (ob.type) {
    case ShapeType::kPlane: {
      const Vec3 n = ob.pose.orientation * Vec3::UnitZ();
      const Vec3& p = ob.pose.position;
      if ((x - p).dot(n) >= bm.bounding_radius + kMargin) return;
      const CollisionScratch& cs = data.scratch->collision;
      for (int s = s0; s < s1; ++s) {
        // Signed distance prefilter on the flat arrays; sphere_plane decides.
        const double dist = (cs.sphere_x[static_cast<std::size_t>(s)] - p.x()) * n.x() +
                            (cs.sphere_y[static_cast<std::size_t>(s)] - p.y()) * n.y() +
                            (cs.sphere_z[static_cast<std::size_t>(s)] - p.z()) * n.z();
        if (dist >= bs[s].radius + kMargin) continue;
        if (sphere_plane(sw[s], bs[s].radius, p, n, g)) sink.add(b, -1, o, s, -1, mat, g);
      }
      return;
    }
    case ShapeType::kBox: {
      const Mat3 rot = ob.pose.orientation.toRotationMatrix();
      // Body cull: distance from the centre of mass to the solid box.
      const Vec3 local = rot.transpose() * (x - ob.pose.position);
      const Vec3 outside = local - local.cwiseMax(-ob.half_extents).cwiseMin(ob.half_extents);
      if (outside.squaredNorm() > (bm.bounding_radius + kMargin) * (bm.bounding_radius + kMargin))
        return;
      for (int s = s0; s < s1; ++s)
        if (sphere_box(sw[s], bs[s].radius, ob.pose.position, rot, ob.half_extents, g))
          sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kSphere: {
      const double reach = bm.bounding_radius + ob.radius + kMargin;
      if ((x - ob.pose.position).squaredNorm() > reach * reach) return;  // body cull
      const Vec3 fb = fallback_from(x, ob.pose.position);
      for (int s = s0; s < s1; ++s)
        if (sphere_sphere(sw[s], bs[s].radius, ob.pose.position, ob.radius, fb, g))
          sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kCapsule: {
      const Vec3 axis = ob.pose.orientation * Vec3::UnitZ();
      // Body cull: distance from the centre of mass to the segment.
      const Vec3 rel = x - ob.pose.position;
      const double t = std::clamp(rel.dot(axis), -ob.half_length, ob.half_length);
      const double reach = bm.bounding_radius + ob.radius + kMargin;
      if ((rel - t * axis).squaredNorm() > reach * reach) return;
      for (int s = s0; s < s1; ++s)
        if (sphere_capsule(sw[s], bs[s].radius, ob.pose.position, axis, ob.half_length, ob.radius,
                           g))
          sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kMesh: {
      // The body already met the mesh's world AABB (detect_contacts()); each sphere's own
      // reach is the query's (mesh_signed_distance() rejects far centres on its grid).
      const MeshShape& shape = model.meshes[static_cast<std::size_t>(ob.mesh)];
      for (int s = s0; s < s1; ++s)
        if (sphere_mesh(sw[s], bs[s].radius, shape, ob.pose, g)) sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kSphereSet:
      return;  // through the grid
  }
}

/// Body `b` against every static sphere set, one grid query per sphere
/// (query_static_grid(): float prefilter, per-entry stamps); the exact double
/// test (the one of the reference) decides.
void collide_body_grid(const Model& model, Data& data, int b, ContactSink& sink) noexcept {
  CollisionScratch& cs = data.scratch->collision;
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
  const Vec3& x = data.bodies[static_cast<std::size_t>(b)].position;
  const Vec3* sw = cs.sphere_world.data();
  const Sphere* bs = model.body_spheres.data();
  const int mat_a = bm.material * model.num_materials();
  ContactGeometry g;
  for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
    const Vec3& c = sw[s];
    const double r = bs[s].radius;
    collision_detail::query_static_grid(
        model.static_grid, c, r, cs.entry_stamp.data(), cs.stamp, [&](const GridEntry& en) {
          if (sphere_sphere(c, r, en.center, en.radius, fallback_from(x, en.center), g))
            sink.add(b, -1, en.obstacle, s, en.sphere, mat_a + en.material, g);
        });
  }
}

/// The pair (sa, sb) if it was held back at the last call, or null (pairs_prev; the look-up
/// starts after the last match: the pairs come in the same order every step).
SpherePairRecord* find_held_pair(CollisionScratch& cs, int sa, int sb) noexcept {
  const int n = cs.num_pairs_prev;
  SpherePairRecord* prev = cs.pairs_prev.data();
  int k = cs.pair_cursor < n ? cs.pair_cursor : 0;
  for (int tried = 0; tried < n; ++tried, k = (k + 1 == n) ? 0 : k + 1) {
    if (prev[k].sphere_a == sa && prev[k].sphere_b == sb) {
      cs.pair_cursor = k + 1;
      return &prev[k];
    }
  }
  return nullptr;
}

/// Crossing (collision.hpp): the contact `g` between sphere sa of body a and sphere sb of body
/// b keeps the normal of its approach when their centres went past each other within the step.
/// The reference normal is the one the pair was held back along at the last call, else that of
/// the relative motion over the step, r(t) = r₁ − (1 − t) Δt v_rel (r₁ = c_a − c_b, v_rel the
/// relative velocity of the two centres: the step's motion under the integrators'
/// x₁ = x₀ + Δt v₁): at first touch, |r(t)| = r_a + r_b, for a pair apart at the step's start,
/// else at the start, r(0)/|r(0)|. When r₁ lies behind it (r₁·n < 0), the contact takes n and
/// the depth r_a + r_b − r₁·n (> r_a + r_b): the penalty pushes the pair back the way it came
/// instead of on through. Counts it in data.crossed_contacts and remembers the pair in cs.pairs
/// (within capacity) for the next call. Bodies at rest: the contact as sphere_sphere() gave it.
void hold_back_crossing(const Model& model, Data& data, int a, int b, int sa, int sb,
                        ContactGeometry& g) noexcept {
  CollisionScratch& cs = data.scratch->collision;
  const Vec3* sw = cs.sphere_world.data();
  const double rsum =
      cs.sphere_r[static_cast<std::size_t>(sa)] + cs.sphere_r[static_cast<std::size_t>(sb)];
  const Vec3 r1 = sw[sa] - sw[sb];
  Vec3 ref = Vec3::Zero();
  if (SpherePairRecord* p = cs.num_pairs_prev > 0 ? find_held_pair(cs, sa, sb) : nullptr) {
    p->matched = true;
    ref = p->normal;
  } else {
    const BodyState& A = data.bodies[static_cast<std::size_t>(a)];
    const BodyState& B = data.bodies[static_cast<std::size_t>(b)];
    const Vec3 v_rel = A.linear_velocity + A.angular_velocity.cross(sw[sa] - A.position) -
                       B.linear_velocity - B.angular_velocity.cross(sw[sb] - B.position);
    const Vec3 d = model.dt * v_rel;  // relative displacement over the step
    const Vec3 r0 = r1 - d;           // the offset at the step's start
    const double c = r0.squaredNorm() - rsum * rsum;
    const double bq = r0.dot(d);
    const double dd = d.squaredNorm();
    Vec3 at = r0;  // overlapping at the start: the start's normal
    if (c > 0.0 && bq < 0.0) {
      // Apart at the start and closing: first touch at the smaller root of |r0 + t d| = rsum.
      const double disc = std::max(0.0, bq * bq - dd * c);
      at = r0 + std::clamp((-bq - std::sqrt(disc)) / dd, 0.0, 1.0) * d;
    }
    const double len2 = at.squaredNorm();
    if (len2 > kDegenerateDistance2) ref = at / std::sqrt(len2);
  }
  if (!(r1.dot(ref) < 0.0)) return;  // not past each other (or no reference)
  const double rb = cs.sphere_r[static_cast<std::size_t>(sb)];
  g.normal = ref;
  g.depth = rsum - r1.dot(ref);
  g.position = sw[sb] + (rb - 0.5 * g.depth) * ref;  // as sphere_sphere: middle of the overlap
  ++data.crossed_contacts;
  if (cs.num_pairs < static_cast<int>(cs.pairs.size())) {
    SpherePairRecord& rec = cs.pairs[static_cast<std::size_t>(cs.num_pairs++)];
    rec.sphere_a = sa;
    rec.sphere_b = sb;
    rec.normal = ref;
    rec.matched = false;
  }
}

/// After the body–body phase: a pair held back at the last call and out of contact now, its
/// centres still past each other along the held normal, went through (data.pass_throughs).
/// Then this call's held pairs become the last call's.
void finish_pairs(Data& data) noexcept {
  CollisionScratch& cs = data.scratch->collision;
  const Vec3* sw = cs.sphere_world.data();
  for (int k = 0; k < cs.num_pairs_prev; ++k) {
    const SpherePairRecord& p = cs.pairs_prev[static_cast<std::size_t>(k)];
    if (!p.matched && (sw[p.sphere_a] - sw[p.sphere_b]).dot(p.normal) < 0.0) ++data.pass_throughs;
  }
  std::swap(cs.pairs, cs.pairs_prev);  // no allocation: the buffers trade places
  cs.num_pairs_prev = cs.num_pairs;
  cs.num_pairs = 0;
  cs.pair_cursor = 0;
}

/// Spheres of body a against spheres of body b (a < b): only the spheres of
/// each body whose box meets the overlap of the two bodies' AABBs are paired
/// (a face layer of each when blocks touch), in sphere index order. Prefilters
/// run on the scratch's flat coordinate arrays; sphere_sphere() decides.
void collide_bodies(const Model& model, Data& data, int a, int b, ContactSink& sink) noexcept {
  const BodyModel& ba = model.bodies[static_cast<std::size_t>(a)];
  const BodyModel& bb = model.bodies[static_cast<std::size_t>(b)];
  CollisionScratch& cs = data.scratch->collision;
  const double* X = cs.sphere_x.data();
  const double* Y = cs.sphere_y.data();
  const double* Z = cs.sphere_z.data();
  const double* R = cs.sphere_r.data();
  const Vec3 lo = cs.body_aabb_min[static_cast<std::size_t>(a)].cwiseMax(
      cs.body_aabb_min[static_cast<std::size_t>(b)]);
  const Vec3 hi = cs.body_aabb_max[static_cast<std::size_t>(a)].cwiseMin(
      cs.body_aabb_max[static_cast<std::size_t>(b)]);
  auto select = [&](const BodyModel& body, std::int32_t* out) noexcept {
    return collision_detail::spheres_near_box(X, Y, Z, R, body.sphere_begin,
                                              body.sphere_begin + body.sphere_count, lo, hi, out);
  };
  std::int32_t* near_a = cs.near_a.data();
  std::int32_t* near_b = cs.near_b.data();
  const int na = select(ba, near_a);
  if (na == 0) return;
  const int nb = select(bb, near_b);
  if (nb == 0) return;
  const Vec3 fb = fallback_from(data.bodies[static_cast<std::size_t>(a)].position,
                                data.bodies[static_cast<std::size_t>(b)].position);
  const int mat = ba.material * model.num_materials() + bb.material;
  const Vec3* sw = cs.sphere_world.data();
  ContactGeometry g;
  for (int i = 0; i < na; ++i) {
    const int sa = near_a[i];
    const double xa = X[sa], ya = Y[sa], za = Z[sa], ra = R[sa];
    for (int j = 0; j < nb; ++j) {
      const int sb = near_b[j];
      const double dx = xa - X[sb], dy = ya - Y[sb], dz = za - Z[sb];
      const double sr = ra + R[sb];
      // Conservative (relative slack 1e-12): the exact test is sphere_sphere's.
      if (dx * dx + dy * dy + dz * dz > sr * sr * (1.0 + 1e-12)) continue;
      if (!sphere_sphere(sw[sa], ra, sw[sb], R[sb], fb, g)) continue;
      hold_back_crossing(model, data, a, b, sa, sb, g);
      sink.add(a, b, -1, sa, sb, mat, g);
    }
  }
}

/// The world box [lo, hi] of `shape`'s local box placed at position `c`, rotation `rot` (the
/// box of its eight corners).
void posed_mesh_box(const MeshShape& shape, const Vec3& c, const Mat3& rot, Vec3& lo,
                    Vec3& hi) noexcept {
  const Vec3 mid = c + rot * (0.5 * (shape.aabb_min + shape.aabb_max));
  const Vec3 ext = rot.cwiseAbs() * (0.5 * (shape.aabb_max - shape.aabb_min));
  lo = mid - ext;
  hi = mid + ext;
}

/// The spheres of body `b` against the mesh of body `m`, placed at `pose` (world) with world box
/// [lo, hi]: only b's spheres within reach of the box are queried (sphere_mesh() decides). The
/// contact's body_b is m, its sphere_b −1; the normal points out of the mesh.
void collide_body_mesh(const Model& model, Data& data, int b, int m, const Pose& pose,
                       const Vec3& lo, const Vec3& hi, ContactSink& sink) noexcept {
  const BodyModel& bb = model.bodies[static_cast<std::size_t>(b)];
  const BodyModel& mb = model.bodies[static_cast<std::size_t>(m)];
  CollisionScratch& cs = data.scratch->collision;
  std::int32_t* near = cs.near_a.data();
  const int n = collision_detail::spheres_near_box(
      cs.sphere_x.data(), cs.sphere_y.data(), cs.sphere_z.data(), cs.sphere_r.data(),
      bb.sphere_begin, bb.sphere_begin + bb.sphere_count, lo, hi, near);
  const MeshShape& shape = model.meshes[static_cast<std::size_t>(mb.mesh)];
  const int mat = bb.material * model.num_materials() + mb.material;
  const Vec3* sw = cs.sphere_world.data();
  const double* R = cs.sphere_r.data();
  ContactGeometry g;
  for (int i = 0; i < n; ++i) {
    const int s = near[i];
    if (sphere_mesh(sw[s], R[s], shape, pose, g)) sink.add(b, m, -1, s, -1, mat, g);
  }
}

}  // namespace

void CollisionScratch::resize(const Model& model) {
  const auto nb = static_cast<std::size_t>(model.num_bodies());
  sphere_world.assign(model.body_spheres.size(), Vec3::Zero());
  sphere_x.assign(model.body_spheres.size(), 0.0);
  sphere_y.assign(model.body_spheres.size(), 0.0);
  sphere_z.assign(model.body_spheres.size(), 0.0);
  sphere_r.resize(model.body_spheres.size());
  for (std::size_t s = 0; s < model.body_spheres.size(); ++s)
    sphere_r[s] = model.body_spheres[s].radius;
  body_aabb_min.assign(nb, Vec3::Constant(kInf));
  body_aabb_max.assign(nb, Vec3::Constant(-kInf));
  sweep_order.clear();
  sweep_order.reserve(nb);
  for (std::size_t b = 0; b < nb; ++b)
    if (model.bodies[b].sphere_count > 0) sweep_order.push_back(static_cast<std::int32_t>(b));
  int max_spheres = 0;
  for (const BodyModel& b : model.bodies) max_spheres = std::max(max_spheres, b.sphere_count);
  near_a.assign(static_cast<std::size_t>(max_spheres), 0);
  near_b.assign(static_cast<std::size_t>(max_spheres), 0);
  mesh_bodies.clear();
  for (std::size_t b = 0; b < nb; ++b)
    if (model.bodies[b].mesh >= 0) mesh_bodies.push_back(static_cast<std::int32_t>(b));
  entry_stamp.assign(static_cast<std::size_t>(model.static_grid.num_entries), 0u);
  stamp = 0;
  pairs.assign(static_cast<std::size_t>(cross_contact_capacity(model)), SpherePairRecord{});
  pairs_prev.assign(pairs.size(), SpherePairRecord{});
  num_pairs = num_pairs_prev = pair_cursor = 0;
}

void build_collision_structures(Model& model) {
  for (Obstacle& o : model.obstacles) {
    const Vec3& c = o.pose.position;
    const Mat3 rot = o.pose.orientation.normalized().toRotationMatrix();
    switch (o.type) {
      case ShapeType::kPlane:
        o.aabb_min = Vec3::Constant(-kInf);
        o.aabb_max = Vec3::Constant(kInf);
        break;
      case ShapeType::kBox: {
        const Vec3 ext = rot.cwiseAbs() * o.half_extents.cwiseAbs();
        o.aabb_min = c - ext;
        o.aabb_max = c + ext;
        break;
      }
      case ShapeType::kSphere:
        o.aabb_min = c - Vec3::Constant(o.radius);
        o.aabb_max = c + Vec3::Constant(o.radius);
        break;
      case ShapeType::kCapsule: {
        const Vec3 ext = rot.col(2).cwiseAbs() * o.half_length + Vec3::Constant(o.radius);
        o.aabb_min = c - ext;
        o.aabb_max = c + ext;
        break;
      }
      case ShapeType::kMesh: {
        // The world box of the mesh's local box (its eight corners).
        o.aabb_min = Vec3::Constant(kInf);
        o.aabb_max = Vec3::Constant(-kInf);
        if (o.mesh < 0 || static_cast<std::size_t>(o.mesh) >= model.meshes.size()) break;
        posed_mesh_box(model.meshes[static_cast<std::size_t>(o.mesh)], c, rot, o.aabb_min,
                       o.aabb_max);
        break;
      }
      case ShapeType::kSphereSet:
        o.aabb_min = Vec3::Constant(kInf);
        o.aabb_max = Vec3::Constant(-kInf);
        for (int s = o.sphere_begin; s < o.sphere_begin + o.sphere_count; ++s) {
          if (s < 0 || static_cast<std::size_t>(s) >= model.static_spheres.size()) continue;
          const Sphere& sp = model.static_spheres[static_cast<std::size_t>(s)];
          o.aabb_min = o.aabb_min.cwiseMin(sp.center - Vec3::Constant(sp.radius));
          o.aabb_max = o.aabb_max.cwiseMax(sp.center + Vec3::Constant(sp.radius));
        }
        break;
    }
  }
  build_static_grid(model.static_spheres, model.obstacles, 0.0, model.static_grid);
}

namespace {

/// Phase 1 of detect_contacts(): every body sphere's world centre (CollisionScratch::
/// sphere_world and its x / y / z arrays) and each body's tight box of its spheres; a body with
/// a non-finite pose gets an inverted box (skipped: the step's checks report it).
void place_spheres(const Model& model, Data& data) noexcept {
  CollisionScratch& cs = data.scratch->collision;
  const int nb = model.num_bodies();
  const Sphere* bs = model.body_spheres.data();
  Vec3* sw = cs.sphere_world.data();
  for (int b = 0; b < nb; ++b) {
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const BodyState& st = data.bodies[static_cast<std::size_t>(b)];
    Vec3 lo = Vec3::Constant(kInf);
    Vec3 hi = Vec3::Constant(-kInf);
    if (bm.sphere_count > 0 && st.position.allFinite() && st.orientation.coeffs().allFinite()) {
      const Mat3 rot = st.orientation.toRotationMatrix();
      double lx = kInf, ly = kInf, lz = kInf, hx = -kInf, hy = -kInf, hz = -kInf;
      for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
        const Vec3 c = st.position + rot * bs[s].center;
        sw[s] = c;
        const double r = bs[s].radius;
        cs.sphere_x[static_cast<std::size_t>(s)] = c.x();
        cs.sphere_y[static_cast<std::size_t>(s)] = c.y();
        cs.sphere_z[static_cast<std::size_t>(s)] = c.z();
        lx = std::min(lx, c.x() - r);
        ly = std::min(ly, c.y() - r);
        lz = std::min(lz, c.z() - r);
        hx = std::max(hx, c.x() + r);
        hy = std::max(hy, c.y() + r);
        hz = std::max(hz, c.z() + r);
      }
      lo = Vec3(lx, ly, lz);
      hi = Vec3(hx, hy, hz);
      if (!(lo.allFinite() && hi.allFinite())) {
        lo = Vec3::Constant(kInf);
        hi = Vec3::Constant(-kInf);
      }
    }
    cs.body_aabb_min[static_cast<std::size_t>(b)] = lo;
    cs.body_aabb_max[static_cast<std::size_t>(b)] = hi;
  }
}

/// Phase 2: each body's spheres against the static obstacles its box meets, and against the
/// static spheres' grid.
void collide_with_obstacles(const Model& model, Data& data, ContactSink& sink) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const int nb = model.num_bodies();
  const bool has_grid = !model.static_grid.empty();
  const int no = static_cast<int>(model.obstacles.size());
  for (int b = 0; b < nb; ++b) {
    const Vec3& lo = cs.body_aabb_min[static_cast<std::size_t>(b)];
    const Vec3& hi = cs.body_aabb_max[static_cast<std::size_t>(b)];
    if (!(lo.x() <= hi.x())) continue;  // no spheres or non-finite
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const Vec3& x = data.bodies[static_cast<std::size_t>(b)].position;
    const double reach2 = (bm.bounding_radius + kMargin) * (bm.bounding_radius + kMargin);
    for (int o = 0; o < no; ++o) {
      const Obstacle& ob = model.obstacles[static_cast<std::size_t>(o)];
      if (ob.type == ShapeType::kSphereSet) continue;
      if (ob.type != ShapeType::kPlane && (!boxes_overlap(lo, hi, ob.aabb_min, ob.aabb_max) ||
                                           box_distance2(x, ob.aabb_min, ob.aabb_max) > reach2))
        continue;
      collide_body_obstacle(model, data, b, o, sink);
    }
    if (has_grid &&
        boxes_overlap(lo, hi, model.static_grid.bounds_min, model.static_grid.bounds_max))
      collide_body_grid(model, data, b, sink);
  }
}

/// Phase 3: body against body, a sort-and-sweep along x over the bodies' boxes, two bodies of
/// one articulation never; crossings held back (hold_back_crossing(), finish_pairs()).
void collide_body_pairs(const Model& model, Data& data, ContactSink& sink) noexcept {
  CollisionScratch& cs = data.scratch->collision;
  data.crossed_contacts = 0;
  cs.num_pairs = 0;
  const int ns = static_cast<int>(cs.sweep_order.size());
  if (ns > 1) {
    std::int32_t* order = cs.sweep_order.data();
    const Vec3* amin = cs.body_aabb_min.data();
    const Vec3* amax = cs.body_aabb_max.data();
    const int* tree = model.articulation.body_tree.data();
    sort_sweep_order(amin, 0, order, ns);
    for (int i = 0; i < ns; ++i) {
      const int a = order[i];
      if (!(amin[a].x() <= amax[a].x())) break;  // inverted boxes sort last
      const double reach = amax[a].x() + kMargin;
      for (int j = i + 1; j < ns; ++j) {
        const int b = order[j];
        if (!(amin[b].x() <= reach)) break;
        if (!boxes_overlap(amin[a], amax[a], amin[b], amax[b])) continue;
        if (tree[a] == tree[b]) continue;  // same articulation: no self-collision
        collide_bodies(model, data, std::min(a, b), std::max(a, b), sink);
      }
    }
  }
  finish_pairs(data);
  if (data.crossed_contacts > 0) ++data.crossed_contact_steps;
}

/// Phase 4: spheres against the meshes of the other bodies (BodyModel::mesh): the mesh's world
/// box from its local box at the body's pose, then the bodies of other articulations whose
/// sphere box meets it.
void collide_with_meshes(const Model& model, Data& data, ContactSink& sink) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const int nb = model.num_bodies();
  const int* tree = model.articulation.body_tree.data();
  for (const std::int32_t m : cs.mesh_bodies) {
    const BodyModel& mb = model.bodies[static_cast<std::size_t>(m)];
    const BodyState& st = data.bodies[static_cast<std::size_t>(m)];
    if (!(st.position.allFinite() && st.orientation.coeffs().allFinite())) continue;
    const Pose pose{st.position + st.orientation * mb.mesh_pose.position,
                    st.orientation * mb.mesh_pose.orientation};
    Vec3 lo, hi;
    posed_mesh_box(model.meshes[static_cast<std::size_t>(mb.mesh)], pose.position,
                   pose.orientation.toRotationMatrix(), lo, hi);
    for (int b = 0; b < nb; ++b) {
      if (b == m || tree[b] == tree[m]) continue;  // its own spheres, its articulation's
      const Vec3& blo = cs.body_aabb_min[static_cast<std::size_t>(b)];
      const Vec3& bhi = cs.body_aabb_max[static_cast<std::size_t>(b)];
      if (!(blo.x() <= bhi.x()) || !boxes_overlap(blo, bhi, lo, hi)) continue;
      collide_body_mesh(model, data, b, m, pose, lo, hi, sink);
    }
  }
}

}  // namespace

void detect_contacts(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageContacts;  // the stage report (step_stages.hpp)
  place_spheres(model, data);
  ContactSink sink{data};
  collide_with_obstacles(model, data, sink);
  collide_body_pairs(model, data, sink);
  collide_with_meshes(model, data, sink);
  data.num_contacts = sink.count;
  data.contacts_dropped = sink.dropped;
  data.max_penetration = sink.max_depth;
  data.status &= ~static_cast<std::uint32_t>(kContactOverflow);
  if (sink.dropped > 0) {
    data.status |= kContactOverflow;
    ++data.contact_overflow_steps;
  }
}

}  // namespace numen::core
