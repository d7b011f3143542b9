/// @file collision.cpp
/// Collision stage (paper §5, sphere-based collision for penalty contacts):
/// world sphere centres, broad phase (obstacle bounds, static sphere grid,
/// sort-and-sweep between bodies) and contact output with a fixed capacity.

#include "numen/core/collision.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "numen/core/broadphase.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/narrowphase.hpp"

namespace numen::core {
namespace {

/// Inflation of every broad-phase box (m): keeps the culling conservative with
/// respect to rounding; the narrow phase decides.
constexpr double kMargin = 1e-9;

constexpr double kInf = std::numeric_limits<double>::infinity();

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
  }
};

/// Squared distance from `p` to the box [lo, hi] (inf for an inverted box).
inline double box_distance2(const Vec3& p, const Vec3& lo, const Vec3& hi) noexcept {
  return (p - p.cwiseMax(lo).cwiseMin(hi)).squaredNorm();
}

inline bool boxes_overlap(const Vec3& amin, const Vec3& amax, const Vec3& bmin, const Vec3& bmax) noexcept {
  return (amin.array() <= bmax.array() + kMargin).all() && (bmin.array() <= amax.array() + kMargin).all();
}

/// Fallback normal direction for coincident centres: from b's reference point
/// towards a's centre of mass (normalized by the narrow phase, +z if zero).
inline Vec3 fallback_from(const Vec3& body_com, const Vec3& b_point) noexcept { return body_com - b_point; }

/// Body `b` against the primitive (non sphere-set) obstacle `o`.
void collide_body_obstacle(const Model& model, const Data& data, int b, int o, ContactSink& sink) noexcept {
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
  const Obstacle& ob = model.obstacles[static_cast<std::size_t>(o)];
  const Vec3& x = data.bodies[static_cast<std::size_t>(b)].position;
  const Vec3* sw = data.collision.sphere_world.data();
  const Sphere* bs = model.body_spheres.data();
  const int s0 = bm.sphere_begin;
  const int s1 = bm.sphere_begin + bm.sphere_count;
  const int mat = bm.material * model.num_materials() + ob.material;
  ContactGeometry g;

  switch (ob.type) {
    case ShapeType::kPlane: {
      const Vec3 n = ob.pose.orientation * Vec3::UnitZ();
      if ((x - ob.pose.position).dot(n) >= bm.bounding_radius + kMargin) return;
      for (int s = s0; s < s1; ++s)
        if (sphere_plane(sw[s], bs[s].radius, ob.pose.position, n, g)) sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kBox: {
      const Mat3 rot = ob.pose.orientation.toRotationMatrix();
      for (int s = s0; s < s1; ++s)
        if (sphere_box(sw[s], bs[s].radius, ob.pose.position, rot, ob.half_extents, g))
          sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kSphere: {
      const Vec3 fb = fallback_from(x, ob.pose.position);
      for (int s = s0; s < s1; ++s)
        if (sphere_sphere(sw[s], bs[s].radius, ob.pose.position, ob.radius, fb, g))
          sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kCapsule: {
      const Vec3 axis = ob.pose.orientation * Vec3::UnitZ();
      for (int s = s0; s < s1; ++s)
        if (sphere_capsule(sw[s], bs[s].radius, ob.pose.position, axis, ob.half_length, ob.radius, g))
          sink.add(b, -1, o, s, -1, mat, g);
      return;
    }
    case ShapeType::kSphereSet:
      return;  // through the grid
  }
}

/// Body `b` against every static sphere set, one grid query per sphere: a
/// branch-free float prefilter over each row of cells collects candidates, the
/// exact double test (the one of the reference) decides, and a per-entry stamp
/// drops the duplicates of spheres listed in several cells.
void collide_body_grid(const Model& model, Data& data, int b, ContactSink& sink) noexcept {
  const StaticSphereGrid& grid = model.static_grid;
  CollisionScratch& cs = data.collision;
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
  const Vec3& x = data.bodies[static_cast<std::size_t>(b)].position;
  const Vec3* sw = cs.sphere_world.data();
  const Sphere* bs = model.body_spheres.data();
  const std::int32_t* cell_start = grid.cell_start.data();
  const GridItem* items = grid.items.data();
  const std::int32_t* item_entry = grid.item_entry.data();
  const GridEntry* entries = grid.entries.data();
  std::uint32_t* stamps = cs.entry_stamp.data();
  const int mat_a = bm.material * model.num_materials();
  constexpr int kChunk = 64;
  std::int32_t candidates[kChunk];
  float gap[kChunk];
  ContactGeometry g;

  for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
    const Vec3& c = sw[s];
    const double r = bs[s].radius;
    const Vec3 ext = Vec3::Constant(r + kMargin);
    Eigen::Vector3i first, last;
    if (!grid.cell_range(c - ext, c + ext, first, last)) continue;
    if (++cs.stamp == 0) {  // wrapped: forget every stamp
      std::fill(cs.entry_stamp.begin(), cs.entry_stamp.end(), 0u);
      cs.stamp = 1;
    }
    const std::uint32_t stamp = cs.stamp;
    const Vec3 rel = c - grid.origin;
    const float qx = static_cast<float>(rel.x());
    const float qy = static_cast<float>(rel.y());
    const float qz = static_cast<float>(rel.z());
    const float qr = static_cast<float>(r) * (1.0f + 1e-6f) + grid.float_slack;
    for (int z = first.z(); z <= last.z(); ++z) {
      for (int y = first.y(); y <= last.y(); ++y) {
        // Cells first.x..last.x of a row are one contiguous range of items.
        int k = cell_start[grid.cell_index(first.x(), y, z)];
        const int k_end = cell_start[grid.cell_index(last.x(), y, z) + 1];
        for (; k < k_end; k += kChunk) {
          const int m = std::min(k_end - k, kChunk);
          const GridItem* chunk = items + k;
          for (int i = 0; i < m; ++i) {  // vectorizable: no branch, no dependency
            const float dx = chunk[i].x - qx, dy = chunk[i].y - qy, dz = chunk[i].z - qz;
            const float sr = chunk[i].radius + qr;
            gap[i] = dx * dx + dy * dy + dz * dz - sr * sr;
          }
          int n = 0;
          for (int i = 0; i < m; ++i) {  // branch-free compaction
            candidates[n] = k + i;
            n += gap[i] <= 0.0f ? 1 : 0;
          }
          for (int i = 0; i < n; ++i) {
            const std::int32_t e = item_entry[candidates[i]];
            const GridEntry& en = entries[e];
            if (!spheres_overlap(c, r, en.center, en.radius)) continue;
            if (stamps[e] == stamp) continue;  // already seen in another cell
            stamps[e] = stamp;
            if (sphere_sphere(c, r, en.center, en.radius, fallback_from(x, en.center), g))
              sink.add(b, -1, en.obstacle, s, en.sphere, mat_a + en.material, g);
          }
        }
      }
    }
  }
}

/// Spheres of body a against spheres of body b (a < b).
void collide_bodies(const Model& model, const Data& data, int a, int b, ContactSink& sink) noexcept {
  const BodyModel& ba = model.bodies[static_cast<std::size_t>(a)];
  const BodyModel& bb = model.bodies[static_cast<std::size_t>(b)];
  const CollisionScratch& cs = data.collision;
  const Vec3* sw = cs.sphere_world.data();
  const Sphere* bs = model.body_spheres.data();
  const Vec3& bmin = cs.body_aabb_min[static_cast<std::size_t>(b)];
  const Vec3& bmax = cs.body_aabb_max[static_cast<std::size_t>(b)];
  const Vec3 fb = fallback_from(data.bodies[static_cast<std::size_t>(a)].position,
                                data.bodies[static_cast<std::size_t>(b)].position);
  const int mat = ba.material * model.num_materials() + bb.material;
  const int b0 = bb.sphere_begin;
  const int b1 = bb.sphere_begin + bb.sphere_count;
  ContactGeometry g;
  for (int sa = ba.sphere_begin; sa < ba.sphere_begin + ba.sphere_count; ++sa) {
    const Vec3& ca = sw[sa];
    const double ra = bs[sa].radius;
    const Vec3 ext = Vec3::Constant(ra);
    if (!boxes_overlap(ca - ext, ca + ext, bmin, bmax)) continue;
    for (int sb = b0; sb < b1; ++sb) {
      if (!spheres_overlap(ca, ra, sw[sb], bs[sb].radius)) continue;
      if (sphere_sphere(ca, ra, sw[sb], bs[sb].radius, fb, g)) sink.add(a, b, -1, sa, sb, mat, g);
    }
  }
}

}  // namespace

void CollisionScratch::resize(const Model& model) {
  const auto nb = static_cast<std::size_t>(model.num_bodies());
  sphere_world.assign(model.body_spheres.size(), Vec3::Zero());
  body_aabb_min.assign(nb, Vec3::Constant(kInf));
  body_aabb_max.assign(nb, Vec3::Constant(-kInf));
  sweep_order.clear();
  sweep_order.reserve(nb);
  for (std::size_t b = 0; b < nb; ++b)
    if (model.bodies[b].sphere_count > 0) sweep_order.push_back(static_cast<std::int32_t>(b));
  entry_stamp.assign(static_cast<std::size_t>(model.static_grid.num_entries), 0u);
  stamp = 0;
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

void detect_contacts(const Model& model, Data& data) noexcept {
  CollisionScratch& cs = data.collision;
  const int nb = model.num_bodies();
  const Sphere* bs = model.body_spheres.data();
  Vec3* sw = cs.sphere_world.data();

  // 1. World centres and tight AABBs. A body with a non-finite pose is skipped
  //    (inverted AABB): the step's checks report it.
  for (int b = 0; b < nb; ++b) {
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const BodyState& st = data.bodies[static_cast<std::size_t>(b)];
    Vec3 lo = Vec3::Constant(kInf);
    Vec3 hi = Vec3::Constant(-kInf);
    if (bm.sphere_count > 0 && st.position.allFinite() && st.orientation.coeffs().allFinite()) {
      const Mat3 rot = st.orientation.toRotationMatrix();
      for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
        const Vec3 c = st.position + rot * bs[s].center;
        sw[s] = c;
        const Vec3 r = Vec3::Constant(bs[s].radius);
        lo = lo.cwiseMin(c - r);
        hi = hi.cwiseMax(c + r);
      }
      if (!(lo.allFinite() && hi.allFinite())) {
        lo = Vec3::Constant(kInf);
        hi = Vec3::Constant(-kInf);
      }
    }
    cs.body_aabb_min[static_cast<std::size_t>(b)] = lo;
    cs.body_aabb_max[static_cast<std::size_t>(b)] = hi;
  }

  ContactSink sink{data};

  // 2. Bodies against static obstacles.
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
      if (ob.type != ShapeType::kPlane &&
          (!boxes_overlap(lo, hi, ob.aabb_min, ob.aabb_max) ||
           box_distance2(x, ob.aabb_min, ob.aabb_max) > reach2))
        continue;
      collide_body_obstacle(model, data, b, o, sink);
    }
    if (has_grid && boxes_overlap(lo, hi, model.static_grid.bounds_min, model.static_grid.bounds_max))
      collide_body_grid(model, data, b, sink);
  }

  // 3. Body against body: sort-and-sweep along x.
  const int ns = static_cast<int>(cs.sweep_order.size());
  if (ns > 1) {
    std::int32_t* order = cs.sweep_order.data();
    const Vec3* amin = cs.body_aabb_min.data();
    const Vec3* amax = cs.body_aabb_max.data();
    sort_sweep_order(amin, 0, order, ns);
    for (int i = 0; i < ns; ++i) {
      const int a = order[i];
      if (!(amin[a].x() <= amax[a].x())) break;  // inverted boxes sort last
      const double reach = amax[a].x() + kMargin;
      for (int j = i + 1; j < ns; ++j) {
        const int b = order[j];
        if (!(amin[b].x() <= reach)) break;
        if (!boxes_overlap(amin[a], amax[a], amin[b], amax[b])) continue;
        collide_bodies(model, data, std::min(a, b), std::max(a, b), sink);
      }
    }
  }

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
