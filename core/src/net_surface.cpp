/// @file net_surface.cpp
/// An organ's surface contacts (detail/net_surface.hpp; docs/organs.md, "Surface
/// contacts"): the dynamic bodies' spheres against the net's triangles through its node
/// centres, the closest point by Ericson's test shared with the mesh obstacles
/// (mesh_shape_query.hpp), inside or outside by the angle-weighted pseudo-normal.

#include "detail/net_surface.hpp"

#include <cmath>
#include <cstdint>
#include <numbers>

#include "collision_query.hpp"
#include "detail/data_scratch.hpp"
#include "detail/mesh_shape_query.hpp"
#include "numen/core/data.hpp"

namespace numen::core::detail {
namespace {

using collision_detail::boxes_overlap;
using collision_detail::kMargin;

/// Two closest points closer than this (m) are the same point of the surface (a vertex or an
/// edge point computed from two triangles).
constexpr double kSamePoint2 = 1e-9 * 1e-9;

/// A triangle with an edge stretched beyond this many times its rest length is torn: it meets
/// no sphere (docs/organs.md, "Surface contacts": a tool driven through the organ otherwise
/// drags its surface along).
constexpr double kTearStretch = 3.0;

/// The angle of the triangle (a, b, c) at its point q of feature `f` (Feature): the corner's
/// angle at a vertex, π on an edge, 2π inside; the weight of its normal in the pseudo-normal.
double angle_at(int f, const Vec3& a, const Vec3& b, const Vec3& c) noexcept {
  const auto corner = [](const Vec3& p, const Vec3& u, const Vec3& v) {
    return std::atan2((u - p).cross(v - p).norm(), (u - p).dot(v - p));
  };
  switch (f) {
    case kVertex0:
      return corner(a, b, c);
    case kVertex1:
      return corner(b, c, a);
    case kVertex2:
      return corner(c, a, b);
    case kFace:
      return 2.0 * std::numbers::pi;
    default:
      return std::numbers::pi;
  }
}

}  // namespace

void collide_net_faces(const Model& model, const Data& data, NetScratch& ns, const NetModel& net,
                       int num_near, int mat_net, NodeContactSink& sink) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const double* R = cs.sphere_r.data();
  const Vec3* sw = cs.sphere_world.data();
  const std::int32_t* near = ns.near_spheres.data();
  const NodeState* nodes = data.nodes.data();
  const int room = static_cast<int>(ns.face_candidates.size());

  // The near spheres' bounds.
  Vec3 qlo = Vec3::Constant(collision_detail::kInf), qhi = Vec3::Constant(-collision_detail::kInf);
  const int num_spheres = ns.near_sphere_end[static_cast<std::size_t>(num_near - 1)];
  for (int i = 0; i < num_spheres; ++i) {
    const int s = near[i];
    const Vec3 e = Vec3::Constant(R[s] + kMargin);
    qlo = qlo.cwiseMin(sw[s] - e);
    qhi = qhi.cwiseMax(sw[s] + e);
  }
  // Candidates: the triangles whose bounds meet them (non-finite nodes never do).
  int nc = 0;
  for (int f = net.face_begin; f < net.face_begin + net.face_count && nc < room; ++f) {
    const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(f)];
    const Vec3& a = nodes[t[0]].position;
    const Vec3& b = nodes[t[1]].position;
    const Vec3& c = nodes[t[2]].position;
    const Vec3 lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
    if (!boxes_overlap(lo, hi, qlo, qhi) || !(lo.allFinite() && hi.allFinite())) continue;
    const Vec3& ra = model.node_rest[static_cast<std::size_t>(t[0])];
    const Vec3& rb = model.node_rest[static_cast<std::size_t>(t[1])];
    const Vec3& rc = model.node_rest[static_cast<std::size_t>(t[2])];
    constexpr double kTear2 = kTearStretch * kTearStretch;
    if ((b - a).squaredNorm() > kTear2 * (rb - ra).squaredNorm() ||
        (c - b).squaredNorm() > kTear2 * (rc - rb).squaredNorm() ||
        (a - c).squaredNorm() > kTear2 * (ra - rc).squaredNorm())
      continue;  // torn
    ns.face_candidates[static_cast<std::size_t>(nc)] = f;
    ns.face_lo[static_cast<std::size_t>(nc)] = lo;
    ns.face_hi[static_cast<std::size_t>(nc)] = hi;
    ++nc;
  }
  if (nc == 0) return;
  const std::int32_t* cand = ns.face_candidates.data();
  const Vec3* flo = ns.face_lo.data();
  const Vec3* fhi = ns.face_hi.data();
  // Corner k of candidate m at the nodes' current positions.
  const auto corner = [&](int m, int k) -> const Vec3& {
    return nodes[model.net_faces[static_cast<std::size_t>(cand[m])][static_cast<std::size_t>(k)]].position;
  };

  int j = 0;
  for (int k = 0; k < num_near; ++k) {
    const int body = ns.near_bodies[static_cast<std::size_t>(k)];
    const int end = ns.near_sphere_end[static_cast<std::size_t>(k)];
    const int begin = j;
    j = end;
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(body)];
    const Vec3& com = data.bodies[static_cast<std::size_t>(body)].position;
    for (int i = begin; i < end; ++i) {
      const int s = near[i];
      const Vec3& centre = sw[s];
      const double r = R[s];
      // Every triangle whose closest point to the centre is inside it and within r is a
      // contact, along its own normal; the nearest point on an edge or a vertex is one more
      // when it is nearer than all of those (a convex edge or corner).
      double face2 = r * r;  // the nearest face-interior contact
      double best2 = r * r;  // the nearest edge or vertex point
      int best = -1;
      int feature = kFace;
      Vec3 q = Vec3::Zero(), w = Vec3::Zero();
      for (int m = 0; m < nc; ++m) {
        if (detail::box_distance2(centre, flo[m], fhi[m]) >= r * r) continue;
        const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(cand[m])];
        const Vec3 &a = corner(m, 0), &b = corner(m, 1), &c = corner(m, 2);
        int fm = kFace;
        Vec3 wm;
        const Vec3 qm = closest_on_triangle(centre, a, b, c, fm, wm);
        const double d2 = (centre - qm).squaredNorm();
        if (!(d2 < r * r)) continue;
        if (fm == kFace) {
          const Vec3 n = (b - a).cross(c - a);
          const double len = n.norm();
          if (!(len > 0.0)) continue;
          const Vec3 o = n / len;  // outward
          ContactGeometry g;
          g.depth = r - o.dot(centre - qm);
          g.normal = -o;
          g.position = 0.5 * (qm + centre - r * o);
          sink.add_face(cand[m], t, wm, body, s, mat_net + bm.material, g, com);
          face2 = std::min(face2, d2);
        } else if (d2 < best2) {
          best2 = d2;
          best = m;
          feature = fm;
          q = qm;
          w = wm;
        }
      }
      if (best < 0 || !(best2 < face2)) continue;
      // The pseudo-normal at q: the angle-weighted normals of the triangles through q.
      Vec3 pn = Vec3::Zero();
      for (int m = 0; m < nc; ++m) {
        if (m != best && detail::box_distance2(q, flo[m], fhi[m]) > kSamePoint2) continue;
        const Vec3 &a = corner(m, 0), &b = corner(m, 1), &c = corner(m, 2);
        int fm = kFace;
        Vec3 wm;
        const Vec3 qm = m == best ? q : closest_on_triangle(centre, a, b, c, fm, wm);
        if (m == best) fm = feature;
        if ((qm - q).squaredNorm() > kSamePoint2) continue;
        const Vec3 n = (b - a).cross(c - a);
        const double len = n.norm();
        if (len > 0.0) pn += (angle_at(fm, a, b, c) / len) * n;
      }
      const Vec3 diff = centre - q;
      const double d = std::sqrt(best2);
      const bool outside = diff.dot(pn) >= 0.0;
      Vec3 o;  // outward, from the surface towards the sphere's centre
      if (d > 1e-12 * (1.0 + q.norm())) {
        o = (outside ? diff : Vec3(-diff)) / d;
      } else {
        const double len = pn.norm();
        if (!(len > 0.0)) continue;
        o = pn / len;
      }
      ContactGeometry g;
      g.depth = r - (outside ? d : -d);
      g.normal = -o;
      g.position = 0.5 * (q + centre - r * o);
      sink.add_face(cand[best], model.net_faces[static_cast<std::size_t>(cand[best])], w, body, s,
                    mat_net + bm.material, g, com);
    }
  }
}

}  // namespace numen::core::detail
