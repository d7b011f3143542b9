/// @file net_collision.cpp
/// Collision stage of the deformable nets (net_collision.hpp; paper §4.2, §5):
/// node spheres against the primitive obstacles, the static sphere sets (grid
/// query shared with the bodies, collision_query.hpp) and the dynamic bodies'
/// spheres, culled per net by the AABB of its node spheres; an organ's surface
/// triangles against the dynamic bodies' spheres (net_surface.cpp).
///
/// Depends on detect_contacts() having run earlier in the step on the same
/// body states: it fills CollisionScratch::body_aabb_min/max, sphere_world and
/// sphere_x/y/z (read here), clears StepStatus::kContactOverflow (so that a set
/// bit means its own overflow was already counted this step); the grid stamps
/// CollisionScratch::entry_stamp/stamp are shared with it. Per-net scratch:
/// NetScratch::near_obstacles, obstacle_axis, obstacle_rotation, near_bodies,
/// near_sphere_end, near_spheres (sized by NetScratch::resize()).

#include "numen/core/net_collision.hpp"

#include <algorithm>
#include <cstdint>

#include "contact/collision_query.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "contact/narrowphase.hpp"
#include "net/net_surface.hpp"
#include "net/node_contact_sink.hpp"

namespace numen::core {
namespace {

using collision_detail::box_distance2;
using collision_detail::boxes_overlap;
using collision_detail::kInf;
using collision_detail::kMargin;
using detail::NodeContactSink;

/// Tight AABB of the finite node spheres of `net` (inverted when none is finite).
void net_aabb(const Model& model, const Data& data, const NetModel& net, Vec3& lo,
              Vec3& hi) noexcept {
  double lx = kInf, ly = kInf, lz = kInf, hx = -kInf, hy = -kInf, hz = -kInf;
  for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
    const Vec3& c = data.nodes[static_cast<std::size_t>(i)].position;
    if (!c.allFinite()) continue;  // left to the step's non-finite checks
    const double r = model.node_radius[static_cast<std::size_t>(i)];
    lx = std::min(lx, c.x() - r);
    ly = std::min(ly, c.y() - r);
    lz = std::min(lz, c.z() - r);
    hx = std::max(hx, c.x() + r);
    hy = std::max(hy, c.y() + r);
    hz = std::max(hz, c.z() + r);
  }
  lo = Vec3(lx, ly, lz);
  hi = Vec3(hx, hy, hz);
}

/// Primitive obstacles (index order) that the net's AABB [lo, hi] may touch,
/// with their frames, into the scratch; returns their count. A plane is kept
/// when the lowest corner of the box along its normal is below it.
int gather_obstacles(const Model& model, NetScratch& ns, const Vec3& lo, const Vec3& hi) noexcept {
  int n = 0;
  const Vec3 centre = 0.5 * (lo + hi);
  const Vec3 half = 0.5 * (hi - lo);
  for (int o = 0; o < static_cast<int>(model.obstacles.size()); ++o) {
    const Obstacle& ob = model.obstacles[static_cast<std::size_t>(o)];
    switch (ob.type) {
      case ShapeType::kSphereSet:
        continue;  // through the grid
      case ShapeType::kPlane: {
        const Vec3 normal = ob.pose.orientation * Vec3::UnitZ();
        if ((centre - ob.pose.position).dot(normal) - half.dot(normal.cwiseAbs()) >= kMargin)
          continue;
        ns.obstacle_axis[static_cast<std::size_t>(n)] = normal;
        break;
      }
      case ShapeType::kBox:
      case ShapeType::kSphere:
      case ShapeType::kCapsule:
      case ShapeType::kMesh:
        if (!boxes_overlap(lo, hi, ob.aabb_min, ob.aabb_max)) continue;
        if (ob.type == ShapeType::kBox)
          ns.obstacle_rotation[static_cast<std::size_t>(n)] =
              ob.pose.orientation.toRotationMatrix();
        else if (ob.type == ShapeType::kCapsule)
          ns.obstacle_axis[static_cast<std::size_t>(n)] = ob.pose.orientation * Vec3::UnitZ();
        break;
    }
    ns.near_obstacles[static_cast<std::size_t>(n++)] = o;
  }
  return n;
}

/// Dynamic bodies (index order) whose world AABB meets the net's AABB [lo, hi],
/// except the net's rigid component and the bodies of its articulation, and
/// for each the spheres that meet the overlap of the two boxes; returns the
/// number of bodies. Reads CollisionScratch::body_aabb_min/max and the flat
/// sphere centres, filled by detect_contacts() earlier in the step.
int gather_bodies(const Model& model, const Data& data, NetScratch& ns, const NetModel& net,
                  const Vec3& lo, const Vec3& hi) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const int nb = model.num_bodies();
  const std::vector<int>& tree = model.articulation.body_tree;
  const bool has_tree = static_cast<int>(tree.size()) == nb;  // always after finalize_model()
  const int own_tree = has_tree ? tree[static_cast<std::size_t>(net.body)] : -1;
  const double* X = cs.sphere_x.data();
  const double* Y = cs.sphere_y.data();
  const double* Z = cs.sphere_z.data();
  const double* R = cs.sphere_r.data();
  std::int32_t* near = ns.near_spheres.data();
  int n = 0;
  int m = 0;
  for (int b = 0; b < nb; ++b) {
    if (b == net.body || (has_tree && tree[static_cast<std::size_t>(b)] == own_tree)) continue;
    const Vec3& bmin = cs.body_aabb_min[static_cast<std::size_t>(b)];
    const Vec3& bmax = cs.body_aabb_max[static_cast<std::size_t>(b)];
    if (!boxes_overlap(lo, hi, bmin, bmax)) continue;  // also: no spheres, non-finite pose
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const int first = m;
    m += collision_detail::spheres_near_box(X, Y, Z, R, bm.sphere_begin,
                                            bm.sphere_begin + bm.sphere_count, lo.cwiseMax(bmin),
                                            hi.cwiseMin(bmax), near + m);
    if (m == first) continue;
    ns.near_bodies[static_cast<std::size_t>(n)] = b;
    ns.near_sphere_end[static_cast<std::size_t>(n++)] = m;
  }
  return n;
}

/// Node sphere (c, r) against the near primitive obstacle in slot `k`.
inline void collide_node_obstacle(const Model& model, const NetScratch& ns, int k, int node,
                                  const Vec3& c, double r, const Vec3& fallback, int mat_net,
                                  NodeContactSink& sink) noexcept {
  const int o = ns.near_obstacles[static_cast<std::size_t>(k)];
  const Obstacle& ob = model.obstacles[static_cast<std::size_t>(o)];
  ContactGeometry g;
  bool hit = false;
  if (ob.type == ShapeType::kPlane) {
    const Vec3& n = ns.obstacle_axis[static_cast<std::size_t>(k)];
    if ((c - ob.pose.position).dot(n) >= r + kMargin) return;
    hit = sphere_plane(c, r, ob.pose.position, n, g);
  } else {
    const double reach = r + kMargin;
    if (box_distance2(c, ob.aabb_min, ob.aabb_max) > reach * reach) return;
    switch (ob.type) {
      case ShapeType::kBox:
        hit = sphere_box(c, r, ob.pose.position, ns.obstacle_rotation[static_cast<std::size_t>(k)],
                         ob.half_extents, g);
        break;
      case ShapeType::kSphere:
        hit = sphere_sphere(c, r, ob.pose.position, ob.radius, fallback, g);
        break;
      case ShapeType::kCapsule:
        hit = sphere_capsule(c, r, ob.pose.position, ns.obstacle_axis[static_cast<std::size_t>(k)],
                             ob.half_length, ob.radius, g);
        break;
      case ShapeType::kMesh:
        hit = sphere_mesh(c, r, model.meshes[static_cast<std::size_t>(ob.mesh)], ob.pose, g);
        break;
      default:
        break;
    }
  }
  if (hit) sink.add(node, -1, o, -1, mat_net + ob.material, g, Vec3::Zero());
}

/// Node sphere (c, r) against the near spheres of the near bodies (slot order).
inline void collide_node_bodies(const Model& model, const Data& data, const NetScratch& ns,
                                int num_near, int node, const Vec3& c, double r,
                                const Vec3& fallback, int mat_net, NodeContactSink& sink) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const double* X = cs.sphere_x.data();
  const double* Y = cs.sphere_y.data();
  const double* Z = cs.sphere_z.data();
  const double* R = cs.sphere_r.data();
  const Vec3* sw = cs.sphere_world.data();
  const std::int32_t* near = ns.near_spheres.data();
  const double reach = r + kMargin;
  ContactGeometry g;
  int j = 0;
  for (int k = 0; k < num_near; ++k) {
    const int b = ns.near_bodies[static_cast<std::size_t>(k)];
    const int end = ns.near_sphere_end[static_cast<std::size_t>(k)];
    const int begin = j;
    j = end;
    if (box_distance2(c, cs.body_aabb_min[static_cast<std::size_t>(b)],
                      cs.body_aabb_max[static_cast<std::size_t>(b)]) > reach * reach)
      continue;
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const Vec3& com = data.bodies[static_cast<std::size_t>(b)].position;
    for (int i = begin; i < end; ++i) {
      const int s = near[i];
      const double dx = c.x() - X[s], dy = c.y() - Y[s], dz = c.z() - Z[s];
      const double sr = r + R[s];
      // Conservative (relative slack 1e-12): the exact test is sphere_sphere's.
      if (dx * dx + dy * dy + dz * dz > sr * sr * (1.0 + 1e-12)) continue;
      if (sphere_sphere(c, r, sw[s], R[s], fallback, g))
        sink.add(node, b, -1, s, mat_net + bm.material, g, com);
    }
  }
}

}  // namespace

void detect_node_contacts(const Model& model, Data& data) noexcept {
  data.num_node_contacts = 0;
  if (model.nets.empty()) return;
  data.stages_run |= kStageNodeContacts;  // the stage report (step_stages.hpp)
  NetScratch& ns = data.scratch->net;
  CollisionScratch& cs = data.scratch->collision;
  const StaticSphereGrid& grid = model.static_grid;
  const int num_materials = model.num_materials();
  NodeContactSink sink{data.node_contacts.data(),
                       std::min(static_cast<int>(data.node_contacts.size()), kMaxNodeContacts)};

  for (int k = 0; k < model.num_nets(); ++k) {
    const NetModel& net = model.nets[static_cast<std::size_t>(k)];
    sink.net_max_depth = 0.0;
    Vec3 lo, hi;
    net_aabb(model, data, net, lo, hi);
    if (lo.x() <= hi.x()) {  // some finite node
      // An organ (a net on an anchored body) is part of the static world: like two obstacles,
      // it does not collide with the obstacles; only with the dynamic bodies.
      const bool organ = model.bodies[static_cast<std::size_t>(net.body)].anchored;
      const int num_obstacles = organ ? 0 : gather_obstacles(model, ns, lo, hi);
      const bool use_grid =
          !organ && !grid.empty() && boxes_overlap(lo, hi, grid.bounds_min, grid.bounds_max);
      // Body AABBs and world sphere centres come from detect_contacts(), which
      // must have run on the same body states earlier in this step.
      const int num_bodies = gather_bodies(model, data, ns, net, lo, hi);
      const int mat_net = net.material * num_materials;
      const Vec3& com = data.bodies[static_cast<std::size_t>(net.body)].position;
      const bool com_finite = com.allFinite();
      // An organ with surface triangles meets the tool's spheres with them, not with its
      // node spheres (net_surface.hpp).
      const bool faces = organ && net.face_count > 0;
      if (faces && num_bodies > 0)
        detail::collide_net_faces(model, data, ns, net, num_bodies, mat_net, sink);
      if (!faces && (num_obstacles > 0 || use_grid || num_bodies > 0)) {
        for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
          const Vec3& c = data.nodes[static_cast<std::size_t>(i)].position;
          if (!c.allFinite()) continue;
          const double r = model.node_radius[static_cast<std::size_t>(i)];
          // Coincident centres: from the rigid component's COM to the node (+z if 0).
          const Vec3 fallback = com_finite ? Vec3(c - com) : Vec3::Zero();
          for (int o = 0; o < num_obstacles; ++o)
            collide_node_obstacle(model, ns, o, i, c, r, fallback, mat_net, sink);
          if (use_grid) {
            collision_detail::query_static_grid(
                grid, c, r, cs.entry_stamp.data(), cs.stamp, [&](const GridEntry& en) {
                  ContactGeometry g;
                  if (sphere_sphere(c, r, en.center, en.radius, fallback, g))
                    sink.add(i, -1, en.obstacle, en.sphere, mat_net + en.material, g, Vec3::Zero());
                });
          }
          if (num_bodies > 0)
            collide_node_bodies(model, data, ns, num_bodies, i, c, r, fallback, mat_net, sink);
        }
      }
    }
    data.nets[static_cast<std::size_t>(k)].max_penetration = sink.net_max_depth;
    sink.max_depth = std::max(sink.max_depth, sink.net_max_depth);
  }

  data.num_node_contacts = sink.count;
  data.max_penetration = std::max(data.max_penetration, sink.max_depth);
  if (sink.dropped > 0) {
    data.contacts_dropped += sink.dropped;
    // One overflow step, whether the bodies' contacts or the nodes' overflowed.
    if ((data.status & kContactOverflow) == 0) ++data.contact_overflow_steps;
    data.status |= kContactOverflow;
  }
}

}  // namespace numen::core
