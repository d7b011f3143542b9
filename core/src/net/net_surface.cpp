/// @file net_surface.cpp
/// An organ's surface contacts (net/net_surface.hpp; docs/organs.md, "Surface
/// contacts"): the dynamic bodies' spheres against the net's triangles through its node
/// centres, the closest point by Ericson's test shared with the mesh obstacles
/// (mesh_shape_query.hpp), inside or outside by the angle-weighted pseudo-normal.

#include "net/net_surface.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>

#include "contact/collision_query.hpp"
#include "scratch/data_scratch.hpp"
#include "mesh/mesh_shape_query.hpp"
#include "numen/core/net_tissue_contact.hpp"
#include "scratch/net_scratch.hpp"
#include "net/net_surface_frame.hpp"
#include "numen/core/data.hpp"
#include "numen/core/net_surface_map.hpp"

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

/// Whether a triangle of normal `n` (any length) has turned over: n more than 90° from `rest`,
/// its normal at rest carried by the net's body (any length; zero: never).
inline bool turned_over(const Vec3& n, const Vec3& rest) noexcept { return rest.dot(n) < 0.0; }

/// The outward unit normal `o` of a triangle, or its rest normal's direction where it has turned
/// over (turned_over()): a triangle folded round a tool's sphere turns its normal from one step
/// to the next, and the contacts along it threw the suturing pad's nodes past 5 m/s
/// (docs/organs.md, "Surface contacts").
inline Vec3 kept_side(const Vec3& o, const Vec3& rest) noexcept {
  return turned_over(o, rest) ? Vec3(rest.normalized()) : o;
}

/// Near sphere i's bit in NetScratch::surface_sphere_mask (bit 63 for every i ≥ 63).
constexpr std::uint64_t sphere_bit(int i) noexcept {
  return std::uint64_t{1} << (i < 63 ? i : 63);
}

/// Spheres of one body whose candidates are gathered together (collide_candidates()): a body's
/// spheres are laid along it, so neighbours share their candidates.
constexpr int kSphereGroup = 8;
/// How much a run's bounds grow beyond its balls' boxes (m): above kSamePoint, so that every
/// triangle through a point a ball holds stays a candidate.
constexpr double kGroupSlack = 1e-6;

/// The near spheres (NetScratch::near_*) against the `nc` candidate triangles of bounds
/// [flo, fhi]: `corner(m, k)` is corner k of candidate m at the current positions,
/// `emit(m, w, body, sphere, material_pair, geometry, com)` writes a contact at the point of
/// barycentric weights w of candidate m (net_surface.hpp, collide_net_faces()).
/// With `tissue` (the sink, for an organ given by its material: NetModel::contact_modulus), the
/// entries of each sphere's deepest contact are marked NodeContact::primary: the two-scale law
/// (net_tissue_contact.hpp) is the whole sphere's and acts there — but for a sharp body's
/// (BodyModel::sharp), whose contacts are the pair's penalty.
/// With `mask` (the fine surface's candidates, NetScratch::surface_sphere_mask), sphere i meets
/// only the candidates whose mask has its bit (sphere_bit(i)): the others ride on no net
/// triangle within its reach, so they are out of its radius (the same contacts, fewer tests).
/// `rest_normal(m)`: candidate m's normal at rest, carried by the net's body (any length; zero
/// where there is none to keep): a triangle turned over keeps its rest side (kept_side()).
/// A body's spheres go in runs of kSphereGroup: each run tests only the candidates whose bounds
/// meet the run's bounds (its balls' boxes grown by kGroupSlack), in their order, into
/// NetScratch::group_candidates — every candidate within a ball's radius of its centre, or
/// within kSamePoint of a point inside the ball, is among them: the same contacts, fewer tests.
template <typename Corner, typename Emit, typename RestNormal>
void collide_candidates(const Model& model, const Data& data, NetScratch& ns, int num_near,
                        int mat_net, int nc, const Vec3* flo, const Vec3* fhi,
                        const std::uint64_t* mask, Corner corner, Emit emit_contact,
                        NodeContactSink* tissue, RestNormal rest_normal) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const double* R = cs.sphere_r.data();
  const Vec3* sw = cs.sphere_world.data();
  const std::int32_t* near = ns.near_spheres.data();
  // The spheres some candidate's mask names: the others meet none of them.
  std::uint64_t any = ~std::uint64_t{0};
  if (mask) {
    any = 0;
    for (int m = 0; m < nc; ++m) any |= mask[m];
  }
  std::int32_t* group = ns.group_candidates.data();
  int ng = 0;  // the current run's candidates, group[0, ng)
  int j = 0;
  for (int k = 0; k < num_near; ++k) {
    const int body = ns.near_bodies[static_cast<std::size_t>(k)];
    const int end = ns.near_sphere_end[static_cast<std::size_t>(k)];
    const int begin = j;
    j = end;
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(body)];
    const Vec3& com = data.bodies[static_cast<std::size_t>(body)].position;
    // A sharp body (a needle) meets the organ through the pair's penalty: no primary contact.
    NodeContactSink* const primary = bm.sharp ? nullptr : tissue;
    for (int i = begin; i < end; ++i) {
      if ((i - begin) % kSphereGroup == 0) {  // a run starts: its candidates
        const int run_end = std::min(end, i + kSphereGroup);
        Vec3 glo = Vec3::Constant(collision_detail::kInf), ghi = Vec3::Constant(-collision_detail::kInf);
        bool live = false;  // a sphere of the run some candidate can touch
        for (int g = i; g < run_end; ++g) {
          if (!(any & sphere_bit(g))) continue;
          const Vec3 e = Vec3::Constant(R[near[g]] + kGroupSlack);
          glo = glo.cwiseMin(sw[near[g]] - e);
          ghi = ghi.cwiseMax(sw[near[g]] + e);
          live = true;
        }
        ng = 0;
        for (int m = 0; live && m < nc; ++m)
          if (boxes_overlap(flo[m], fhi[m], glo, ghi)) group[ng++] = m;
      }
      if (!(any & sphere_bit(i))) continue;
      const int s = near[i];
      const Vec3& centre = sw[s];
      const double r = R[s];
      // The sphere's deepest contact's entries in the sink (primary only), and where its
      // entries begin.
      const int sphere_begin = primary ? primary->count : 0;
      int deepest_begin = 0, deepest_end = 0;
      double deepest = -1.0;
      // `fade`: the contact's K(τ) (a face's; 0 for an edge's or a vertex's).
      const auto emit = [&](int m, const Vec3& w, int body_, int sphere, int material_pair,
                            const ContactGeometry& g, const Vec3& com_, double fade) {
        const int before = primary ? primary->count : 0;
        emit_contact(m, w, body_, sphere, material_pair, g, com_);
        if (!primary || primary->count <= before) return;
        for (int k = before; k < primary->count; ++k) primary->out[k].blend = fade;
        if (g.depth > deepest) deepest = g.depth, deepest_begin = before, deepest_end = primary->count;
      };
      // The deepest's entries primary; each entry's weight in the touched point, its contact's
      // K(τ) (written by emit) times its depth's factor (net_tissue_contact.hpp,
      // kTissueTouchDepthScale), both for the true sphere (a multirate scene loop grows it by
      // BodyModel::sphere_margin: a contact the true sphere does not reach weighs 0, as after
      // the loop cuts its contacts back to it).
      const auto mark = [&] {
        for (int k = deepest_begin; k < deepest_end; ++k) primary->out[k].primary = true;
        const double margin = bm.sphere_margin;
        double at = -1.0, factor = 0.0;  // a contact's entries share its depth: one exp a contact
        for (int k = sphere_begin; k < primary->count; ++k) {
          NodeContact& e = primary->out[k];
          if (!(e.blend > 0.0)) continue;
          if (e.depth != at)
            at = e.depth, factor = at > margin ? tissue_touch_depth_factor(deepest - at, r - margin) : 0.0;
          e.blend *= factor;
        }
      };
      // Every triangle whose closest point to the centre is inside it and within r is a
      // contact, along its own normal; the nearest point on an edge or a vertex is one more
      // when it is nearer than all of those (a convex edge or corner).
      double face2 = r * r;  // the nearest face-interior contact
      double best2 = r * r;  // the nearest edge or vertex point
      int best = -1;
      int feature = kFace;
      Vec3 q = Vec3::Zero(), w = Vec3::Zero();
      const std::uint64_t bit = sphere_bit(i);
      for (int gi = 0; gi < ng; ++gi) {
        const int m = group[gi];
        if (mask && !(mask[m] & bit)) continue;
        if (detail::box_distance2(centre, flo[m], fhi[m]) >= r * r) continue;
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
          const Vec3 o = kept_side(n / len, rest_normal(m));  // outward
          ContactGeometry g;
          g.depth = r - o.dot(centre - qm);
          g.normal = -o;
          g.position = 0.5 * (qm + centre - r * o);
          emit(m, wm, body, s, mat_net + bm.material, g, com, primary ? tissue_touch_fade(wm) : 0.0);
          face2 = std::min(face2, d2);
        } else if (d2 < best2) {
          best2 = d2;
          best = m;
          feature = fm;
          q = qm;
          w = wm;
        }
      }
      if (best < 0 || !(best2 < face2)) {
        if (primary) mark();
        continue;
      }
      // The pseudo-normal at q: the angle-weighted normals of the triangles through q.
      Vec3 pn = Vec3::Zero();
      for (int gi = 0; gi < ng; ++gi) {
        const int m = group[gi];
        if (m != best && detail::box_distance2(q, flo[m], fhi[m]) > kSamePoint2) continue;
        const Vec3 &a = corner(m, 0), &b = corner(m, 1), &c = corner(m, 2);
        int fm = kFace;
        Vec3 wm;
        const Vec3 qm = m == best ? q : closest_on_triangle(centre, a, b, c, fm, wm);
        if (m == best) fm = feature;
        if ((qm - q).squaredNorm() > kSamePoint2) continue;
        const Vec3 n = (b - a).cross(c - a);
        const double len = n.norm();
        if (!(len > 0.0)) continue;
        const Vec3 rest = rest_normal(m);
        if (turned_over(n, rest))  // its rest side (kept_side())
          pn += angle_at(fm, a, b, c) * rest.normalized();
        else
          pn += (angle_at(fm, a, b, c) / len) * n;
      }
      const Vec3 diff = centre - q;
      const double d = std::sqrt(best2);
      const bool outside = diff.dot(pn) >= 0.0;
      Vec3 o;  // outward, from the surface towards the sphere's centre
      if (d > 1e-12 * (1.0 + q.norm())) {
        o = (outside ? diff : Vec3(-diff)) / d;
      } else {
        const double len = pn.norm();
        if (!(len > 0.0)) {
          if (primary) mark();
          continue;
        }
        o = pn / len;
      }
      ContactGeometry g;
      g.depth = r - (outside ? d : -d);
      g.normal = -o;
      g.position = 0.5 * (q + centre - r * o);
      emit(best, w, body, s, mat_net + bm.material, g, com, 0.0);
      if (primary) mark();
    }
  }
}

/// True when the net triangle `f` (global) has an edge stretched beyond kTearStretch times its
/// rest length (torn: it meets no sphere, nor does the fine surface riding on it).
bool torn(const Model& model, const NodeState* nodes, int f) noexcept {
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(f)];
  const Vec3& a = nodes[t[0]].position;
  const Vec3& b = nodes[t[1]].position;
  const Vec3& c = nodes[t[2]].position;
  const Vec3& ra = model.node_rest[static_cast<std::size_t>(t[0])];
  const Vec3& rb = model.node_rest[static_cast<std::size_t>(t[1])];
  const Vec3& rc = model.node_rest[static_cast<std::size_t>(t[2])];
  constexpr double kTear2 = kTearStretch * kTearStretch;
  return (b - a).squaredNorm() > kTear2 * (rb - ra).squaredNorm() ||
         (c - b).squaredNorm() > kTear2 * (rc - rb).squaredNorm() ||
         (a - c).squaredNorm() > kTear2 * (ra - rc).squaredNorm();
}

/// Cohen–Sutherland outcodes of the net's nodes against the box [lo, hi] widened by kMargin, into
/// ns.node_outcode: bit 2a when node coordinate a is not ≥ lo_a − kMargin (below, or not a
/// number), bit 2a + 1 when it is not ≤ hi_a + kMargin. A triangle whose three codes share a bit
/// lies wholly on one side of the box along that axis, so its bounds fail
/// collision_detail::boxes_overlap() against the box (the test compares each bound through
/// lo_a ≤ max + kMargin and min ≤ hi_a + kMargin, and rounding x + kMargin is monotone in x, so
/// the test on the three nodes is the test on their bounds): cull_face() skips it without its
/// bounds, and the triangles it keeps are tested as before.
void node_outcodes(const Data& data, NetScratch& ns, const NetModel& net, const Vec3& lo,
                   const Vec3& hi) noexcept {
  const NodeState* nodes = data.nodes.data();
  std::uint8_t* code = ns.node_outcode.data();
  for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
    const Vec3& x = nodes[i].position;
    unsigned c = 0;
    for (int a = 0; a < 3; ++a) {
      c |= (x[a] + kMargin >= lo[a] ? 0u : 1u) << (2 * a);
      c |= (x[a] <= hi[a] + kMargin ? 0u : 2u) << (2 * a);
    }
    code[i] = static_cast<std::uint8_t>(c);
  }
}

/// Whether net triangle `f` (global) lies wholly on one side of node_outcodes()' box.
inline bool cull_face(const Model& model, const NetScratch& ns, int f) noexcept {
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(f)];
  const std::uint8_t* code = ns.node_outcode.data();
  return (code[t[0]] & code[t[1]] & code[t[2]]) != 0;
}

/// The bounds of the net triangle `f` (global) at the nodes' current positions.
void net_face_bounds(const Model& model, const NodeState* nodes, int f, Vec3& lo, Vec3& hi) noexcept {
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(f)];
  const Vec3& a = nodes[t[0]].position;
  const Vec3& b = nodes[t[1]].position;
  const Vec3& c = nodes[t[2]].position;
  lo = a.cwiseMin(b).cwiseMin(c);
  hi = a.cwiseMax(b).cwiseMax(c);
}

/// Whether every component of `v` is finite_point (Eigen's allFinite(), without its loop).
inline bool finite_point(const Vec3& v) noexcept {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

/// How much a patch's bounds grow beyond what its corners and offsets give (m): the rounding
/// of its corners' and its vertices' positions, many orders below it.
constexpr double kClusterSlack = 1e-6;

/// The near spheres among `close` (bits as NetScratch::surface_sphere_mask's, i <
/// `num_spheres`) whose radius reaches patch `pc` (NetSurfaceCluster, its first record) at the
/// nodes' current positions: the bounds of its records' parallelograms, grown by its largest
/// offset and kClusterSlack, and for a patch on one net triangle that parallelogram (its two
/// triangles) grown likewise. A sphere left out is at least its radius from every point of the
/// patch's triangles, so none of them touches it or passes within kSamePoint of a point that does.
/// Non-finite_point nodes give no sphere.
std::uint64_t cluster_spheres(const Model& model, const CollisionScratch& cs,
                              const std::int32_t* near, const NodeState* nodes, int pc,
                              std::uint64_t close, int num_spheres) noexcept {
  const NetSurfaceCluster* rec = model.net_surface_clusters.data() + pc;
  // Each record's parallelogram: the corners (w_0, w_1, 1 − w_0 − w_1) of the box of the first
  // two weights, at its triangle's current corners: x = d + w_0 (a − d) + w_1 (b − d).
  Vec3 p00, p10, p01, p11;
  const auto corners = [&](const NetSurfaceCluster& c) {
    const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(c.face)];
    const Vec3& d = nodes[t[2]].position;
    const Vec3 u = nodes[t[0]].position - d, v = nodes[t[1]].position - d;
    const double lo0 = c.weights_lo[0], lo1 = c.weights_lo[1];
    p00 = d + lo0 * u + lo1 * v;
    const Vec3 du = (double{c.weights_hi[0]} - lo0) * u;
    const Vec3 dv = (double{c.weights_hi[1]} - lo1) * v;
    p10 = p00 + du, p01 = p00 + dv, p11 = p10 + dv;
  };
  Vec3 lo = Vec3::Constant(collision_detail::kInf), hi = Vec3::Constant(-collision_detail::kInf);
  for (int q = rec->parts - 1; q >= 0; --q) {  // the first record's corners are left in p00…p11
    corners(rec[q]);
    lo = lo.cwiseMin(p00).cwiseMin(p10).cwiseMin(p01).cwiseMin(p11);
    hi = hi.cwiseMax(p00).cwiseMax(p10).cwiseMax(p01).cwiseMax(p11);
  }
  const double grow = double{rec->offset_max} + kClusterSlack;
  lo.array() -= grow;
  hi.array() += grow;
  // Its bounds first; then, for a patch on one net triangle, the parallelogram itself (its two
  // triangles) grown by the offsets.
  const auto reaches = [&](int i) {
    const int sp = near[i];
    const double r = cs.sphere_r[static_cast<std::size_t>(sp)];
    const Vec3& centre = cs.sphere_world[static_cast<std::size_t>(sp)];
    if (!(detail::box_distance2(centre, lo, hi) < r * r)) return false;
    if (rec->parts > 1) return true;
    const double reach = r + grow;
    int feature = kFace;
    if ((centre - detail::closest_on_triangle(centre, p00, p10, p11, feature)).squaredNorm() < reach * reach)
      return true;
    return (centre - detail::closest_on_triangle(centre, p00, p11, p01, feature)).squaredNorm() < reach * reach;
  };
  std::uint64_t bits = 0;
  for (std::uint64_t rest = close; rest != 0; rest &= rest - 1) {
    const int i = std::countr_zero(rest);
    if (i < 63) {
      if (reaches(i)) bits |= sphere_bit(i);
      continue;
    }
    for (int j = 63; j < num_spheres; ++j)  // bit 63 stands for every sphere from 63 on
      if (reaches(j)) {
        bits |= sphere_bit(j);
        break;
      }
  }
  return bits;
}

/// The near spheres with a finite_point centre sorted along the axis `axis` of the query box
/// (NetScratch::near_order / near_key; insertion sort: a tool's few dozen), and the sweep's
/// half-width: the largest radius plus `reach` (and kMargin).
struct NearSweep {
  int axis = 0;
  int sorted = 0;
  double half_width = 0.0;
};
NearSweep sort_near_spheres(const CollisionScratch& cs, NetScratch& ns, int num_spheres,
                            const Vec3& extent, double reach) noexcept {
  NearSweep out;
  extent.maxCoeff(&out.axis);
  double r_max = 0.0;
  std::int32_t* order = ns.near_order.data();
  double* key = ns.near_key.data();
  for (int i = 0; i < num_spheres; ++i) {
    const int sp = ns.near_spheres[static_cast<std::size_t>(i)];
    const double x = cs.sphere_world[static_cast<std::size_t>(sp)][out.axis];
    if (!std::isfinite(x)) continue;
    r_max = std::max(r_max, cs.sphere_r[static_cast<std::size_t>(sp)]);
    int m = out.sorted++;
    for (; m > 0 && key[m - 1] > x; --m) key[m] = key[m - 1], order[m] = order[m - 1];
    key[m] = x;
    order[m] = i;
  }
  out.half_width = r_max + reach + kMargin;
  return out;
}

/// The near spheres (bits as NetScratch::surface_sphere_mask's) within their radius plus `reach`
/// of net triangle `f` itself (bounds [lo, hi]), not only of its bounds: the only ones its fine
/// triangles can touch (each has a vertex whose foot is on it, and every point of it within
/// `reach` of that foot). Only the spheres whose centres the sweep finds within its half-width
/// of the bounds along its axis are tested.
std::uint64_t net_face_spheres(const Model& model, const CollisionScratch& cs, const NetScratch& ns,
                               const NodeState* nodes, int f, const Vec3& lo, const Vec3& hi,
                               const NearSweep& sweep, double reach) noexcept {
  const double* key = ns.near_key.data();
  const std::int32_t* order = ns.near_order.data();
  const std::array<int, 3>& tri = model.net_faces[static_cast<std::size_t>(f)];
  std::uint64_t close = 0;
  const int a = sweep.axis;
  const int from = static_cast<int>(std::lower_bound(key, key + sweep.sorted, lo[a] - sweep.half_width) - key);
  for (int o = from; o < sweep.sorted && key[o] <= hi[a] + sweep.half_width; ++o) {
    const int i = order[o];
    const int sp = ns.near_spheres[static_cast<std::size_t>(i)];
    const double d = cs.sphere_r[static_cast<std::size_t>(sp)] + reach;
    const Vec3& centre = cs.sphere_world[static_cast<std::size_t>(sp)];
    if (!(detail::box_distance2(centre, lo, hi) < d * d)) continue;
    int feature = kFace;
    const Vec3 q = detail::closest_on_triangle(centre, nodes[tri[0]].position, nodes[tri[1]].position,
                                               nodes[tri[2]].position, feature);
    if ((centre - q).squaredNorm() < d * d) close |= sphere_bit(i);
  }
  return close;
}

/// The fine triangles riding on the net triangles near the `num_spheres` near spheres (a net
/// triangle whose bounds come within a sphere's radius plus the net's surface_reach of its
/// centre), whose bounds at their vertices' current positions meet [qlo, qhi] (the near spheres'
/// bounds) and which ride on no torn net triangle: into ns.surface_candidates / surface_lo /
/// surface_hi, each once, their vertices' positions in ns.surface_position; a patch of them
/// (NetSurfaceCluster) that no sphere near its net triangle reaches is skipped before its
/// vertices are placed. Every net triangle's tear is judged once a call (ns.surface_net_*).
/// Returns their count.
int gather_surface_candidates(const Model& model, const Data& data, NetScratch& ns,
                              const NetModel& net, int num_spheres, const Vec3& qlo,
                              const Vec3& qhi) noexcept {
  const NodeState* nodes = data.nodes.data();
  const CollisionScratch& cs = data.scratch->collision;
  if (++ns.surface_stamp == 0) {  // wrapped: no entry may look stamped by this call
    std::fill(ns.surface_face_stamp.begin(), ns.surface_face_stamp.end(), 0u);
    std::fill(ns.surface_point_stamp.begin(), ns.surface_point_stamp.end(), 0u);
    std::fill(ns.surface_net_stamp.begin(), ns.surface_net_stamp.end(), 0u);
    ns.surface_stamp = 1;
  }
  const std::uint32_t stamp = ns.surface_stamp;
  ns.surface_patches_skipped = 0;
  const double reach = net.surface_reach + kMargin;
  const Vec3 plo = qlo - Vec3::Constant(reach), phi = qhi + Vec3::Constant(reach);
  const int room = static_cast<int>(ns.surface_candidates.size());
  const std::span<const NodeState> node_states(data.nodes.data(), data.nodes.size());
  // The net triangle whose riders are being gathered: its corners and frame, computed once for
  // the fine vertices on it.
  int face_now = -1;
  const Vec3* corner_now[3] = {nullptr, nullptr, nullptr};
  Mat3 frame_now;
  bool frame_ok = false;
  const auto position = [&](int p) -> const Vec3& {
    Vec3& x = ns.surface_position[static_cast<std::size_t>(p)];
    std::uint32_t& st = ns.surface_point_stamp[static_cast<std::size_t>(p)];
    if (st != stamp) {
      st = stamp;
      const NetSurfacePoint& e = model.net_surface_points[static_cast<std::size_t>(p)];
      x = e.face == face_now ? net_surface_point(e, *corner_now[0], *corner_now[1], *corner_now[2],
                                                 frame_ok ? &frame_now : nullptr)
                             : net_surface_position(model, node_states, p);
    }
    return x;
  };
  const auto is_torn = [&](int f) {
    std::uint32_t& st = ns.surface_net_stamp[static_cast<std::size_t>(f)];
    std::uint8_t& torn_f = ns.surface_net_torn[static_cast<std::size_t>(f)];
    if (st != stamp) {
      st = stamp;
      torn_f = torn(model, nodes, f) ? 1 : 0;
    }
    return torn_f != 0;
  };
  const std::int32_t* near = ns.near_spheres.data();
  const std::int32_t* cluster_of = model.net_face_surface_cluster.data();
  const NearSweep sweep = sort_near_spheres(cs, ns, num_spheres, qhi - qlo, reach);
  int nc = 0;
  node_outcodes(data, ns, net, plo, phi);
  for (int f = net.face_begin; f < net.face_begin + net.face_count; ++f) {
    if (cull_face(model, ns, f)) continue;
    Vec3 lo, hi;
    net_face_bounds(model, nodes, f, lo, hi);
    if (!boxes_overlap(lo, hi, plo, phi) || !finite_point(lo) || !finite_point(hi)) continue;
    const std::uint64_t close = net_face_spheres(model, cs, ns, nodes, f, lo, hi, sweep, reach);
    if (close == 0) continue;
    face_now = f;
    const std::array<int, 3>& tri = model.net_faces[static_cast<std::size_t>(f)];
    for (int m = 0; m < 3; ++m) corner_now[m] = &nodes[tri[static_cast<std::size_t>(m)]].position;
    frame_ok = net_surface_frame(*corner_now[0], *corner_now[1], *corner_now[2], frame_now);
    const auto first = static_cast<std::size_t>(model.net_face_surface_begin[static_cast<std::size_t>(f)]);
    const auto last = static_cast<std::size_t>(model.net_face_surface_begin[static_cast<std::size_t>(f) + 1]);
    for (std::size_t k = first; k < last && nc < room;) {
      // A patch's triangles (consecutive) meet only the spheres that reach the patch
      // (cluster_spheres()): the others' tests would find them out of their reach. A patch is on
      // this net triangle only, met once a call.
      std::uint64_t spheres = close;
      std::size_t run_end = k + 1;
      bool on_f_alone = false;  // a patch on f alone
      if (const std::int32_t pc = cluster_of[k]; pc >= 0) {
        const NetSurfaceCluster& patch = model.net_surface_clusters[static_cast<std::size_t>(pc)];
        run_end = std::min(last, k + static_cast<std::size_t>(std::max(patch.riders, 1)));  // ≥ 1: never stuck
        on_f_alone = patch.parts == 1;
        spheres = cluster_spheres(model, cs, near, nodes, pc, close, num_spheres);
        if (spheres == 0) {
          ++ns.surface_patches_skipped;
          k = run_end;
          continue;
        }
      }
      for (; k < run_end && nc < room; ++k) {
        const std::int32_t F = model.net_face_surface_faces[k];
        std::uint32_t& st = ns.surface_face_stamp[static_cast<std::size_t>(F)];
        std::int32_t& slot = ns.surface_face_slot[static_cast<std::size_t>(F)];
        if (st == stamp) {  // gathered from another net triangle it rides on: its spheres too
          if (slot >= 0) ns.surface_sphere_mask[static_cast<std::size_t>(slot)] |= spheres;
          continue;
        }
        st = stamp;
        slot = -1;
        const std::array<int, 3>& t = model.net_surface_faces[static_cast<std::size_t>(F)];
        bool keep = true;
        if (on_f_alone)  // its triangle's three vertices ride on f
          keep = !is_torn(f);
        else
          for (int m = 0; m < 3 && keep; ++m)
            keep = !is_torn(model.net_surface_points[static_cast<std::size_t>(t[static_cast<std::size_t>(m)])].face);
        if (!keep) continue;
        const Vec3& a = position(t[0]);
        const Vec3& b = position(t[1]);
        const Vec3& c = position(t[2]);
        const Vec3 flo = a.cwiseMin(b).cwiseMin(c), fhi = a.cwiseMax(b).cwiseMax(c);
        if (!boxes_overlap(flo, fhi, qlo, qhi) || !finite_point(flo) || !finite_point(fhi))
          continue;
        ns.surface_candidates[static_cast<std::size_t>(nc)] = F;
        ns.surface_lo[static_cast<std::size_t>(nc)] = flo;
        ns.surface_hi[static_cast<std::size_t>(nc)] = fhi;
        ns.surface_sphere_mask[static_cast<std::size_t>(nc)] = spheres;
        slot = nc;
        ++nc;
      }
    }
  }
  return nc;
}

}  // namespace

void collide_net_faces(const Model& model, const Data& data, NetScratch& ns, const NetModel& net,
                       int num_near, int mat_net, NodeContactSink& sink) noexcept {
  const CollisionScratch& cs = data.scratch->collision;
  const double* R = cs.sphere_r.data();
  const Vec3* sw = cs.sphere_world.data();
  const std::int32_t* near = ns.near_spheres.data();
  const NodeState* nodes = data.nodes.data();

  // The near spheres' bounds.
  Vec3 qlo = Vec3::Constant(collision_detail::kInf), qhi = Vec3::Constant(-collision_detail::kInf);
  const int num_spheres = ns.near_sphere_end[static_cast<std::size_t>(num_near - 1)];
  for (int i = 0; i < num_spheres; ++i) {
    const int s = near[i];
    const Vec3 e = Vec3::Constant(R[s] + kMargin);
    qlo = qlo.cwiseMin(sw[s] - e);
    qhi = qhi.cwiseMax(sw[s] + e);
  }

  if (net.surface_face_count > 0) {  // the fine surface riding on the net
    const int nc = gather_surface_candidates(model, data, ns, net, num_spheres, qlo, qhi);
    if (nc == 0) return;
    const std::int32_t* cand = ns.surface_candidates.data();
    const Vec3* x = ns.surface_position.data();
    const NetSurfacePoint* points = model.net_surface_points.data();
    const auto corner = [&](int m, int k) -> const Vec3& {
      return x[model.net_surface_faces[static_cast<std::size_t>(cand[m])][static_cast<std::size_t>(k)]];
    };
    const auto emit = [&](int m, const Vec3& w, int body, int sphere, int material_pair,
                          const ContactGeometry& g, const Vec3& com) {
      const std::array<int, 3>& t = model.net_surface_faces[static_cast<std::size_t>(cand[m])];
      sink.add_surface_face({&points[t[0]], &points[t[1]], &points[t[2]]}, model.net_faces.data(), w,
                            body, sphere, material_pair, g, com);
    };
    collide_candidates(model, data, ns, num_near, mat_net, nc, ns.surface_lo.data(),
                       ns.surface_hi.data(), ns.surface_sphere_mask.data(), corner, emit, net.contact_modulus > 0.0 ? &sink : nullptr,
                       [](int) { return Vec3::Zero(); });
    return;
  }

  // Candidates: the net's triangles whose bounds meet them (non-finite_point nodes never do).
  const int room = static_cast<int>(ns.face_candidates.size());
  int nc = 0;
  node_outcodes(data, ns, net, qlo, qhi);
  for (int f = net.face_begin; f < net.face_begin + net.face_count && nc < room; ++f) {
    if (cull_face(model, ns, f)) continue;
    Vec3 lo, hi;
    net_face_bounds(model, nodes, f, lo, hi);
    if (!boxes_overlap(lo, hi, qlo, qhi) || !(lo.allFinite() && hi.allFinite())) continue;
    if (torn(model, nodes, f)) continue;
    ns.face_candidates[static_cast<std::size_t>(nc)] = f;
    ns.face_lo[static_cast<std::size_t>(nc)] = lo;
    ns.face_hi[static_cast<std::size_t>(nc)] = hi;
    ++nc;
  }
  if (nc == 0) return;
  const std::int32_t* cand = ns.face_candidates.data();
  const auto corner = [&](int m, int k) -> const Vec3& {
    return nodes[model.net_faces[static_cast<std::size_t>(cand[m])][static_cast<std::size_t>(k)]].position;
  };
  const auto emit = [&](int m, const Vec3& w, int body, int sphere, int material_pair,
                        const ContactGeometry& g, const Vec3& com) {
    sink.add_face(cand[m], model.net_faces[static_cast<std::size_t>(cand[m])], w, body, sphere,
                  material_pair, g, com);
  };
  const Quat& q_net = data.bodies[static_cast<std::size_t>(net.body)].orientation;
  const auto rest_normal = [&](int m) -> Vec3 {
    const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(cand[m])];
    const Vec3& ra = model.node_rest[static_cast<std::size_t>(t[0])];
    return q_net * (model.node_rest[static_cast<std::size_t>(t[1])] - ra).cross(model.node_rest[static_cast<std::size_t>(t[2])] - ra);
  };
  collide_candidates(model, data, ns, num_near, mat_net, nc, ns.face_lo.data(), ns.face_hi.data(),
                     nullptr, corner, emit, net.contact_modulus > 0.0 ? &sink : nullptr, rest_normal);
}

}  // namespace numen::core::detail
