/// @file thread_tissue_contact.cpp
/// A thread lying on tissue (thread.hpp, "Couplings"; docs/thread.md "The thread on tissue"):
/// its nodes' penalty contacts with the nets' surface triangles as point terms of its implicit
/// step, and their reactions given back to the triangles' nodes as held node springs in the
/// nets' implicit step, as an eyelet's on tissue (thread_tissue.cpp).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <numbers>
#include <span>
#include <vector>

#include "mesh/mesh_shape_query.hpp"
#include "net/net_terms.hpp"
#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {
namespace {

/// Whether node `i` is left out of the contacts with tissue: next to a tie to a body (the tied
/// body, a needle in the tissue, holds it), or within two and a half segments of an active
/// eyelet (the thread enters the tissue there; an eyelet taken over this step included).
bool near_a_passage(const ThreadModel& thread, const ThreadState& st, int i) noexcept {
  const int last = thread.segments;
  if (thread.tie_start.body >= 0 && i < 3) return true;
  if (thread.tie_end.body >= 0 && i > last - 3) return true;
  const double clear = 2.5 * thread.rest_segment;
  const Vec3& x = st.position[static_cast<std::size_t>(i)];
  for (const ThreadEyelet& e : st.eyelets)
    if (e.active && (x - e.position).squaredNorm() < clear * clear) return true;
  return false;
}

/// Node i's contact with the triangle (a, b, c) of unit outward normal n, if deeper than its
/// hit so far: on the triangle's face, the node's sphere below the plane by less than
/// kThreadTissueContactReach; at an edge or a corner, the sphere reaching it from outside.
/// `locate(q, w, face, weights)`: the net triangle and weights that carry the touched point q
/// (barycentric w on (a, b, c)), called for a deeper hit only.
template <typename Locate>
void touch_triangle(const Vec3& x, double radius, int material, const Vec3& a, const Vec3& b,
                    const Vec3& c, const Vec3& n, ThreadTissueHit& hit, Locate locate) noexcept {
  int feature = detail::kFace;
  Vec3 w;
  const Vec3 q = detail::closest_on_triangle(x, a, b, c, feature, w);
  const Vec3 d = x - q;
  const double above = d.dot(n);
  double depth = 0.0;
  Vec3 normal = n;
  if (feature == detail::kFace) {
    if (above < -kThreadTissueContactReach) return;
    depth = radius - above;
  } else {
    const double dist = d.norm();
    if (!(above > 0.0) || dist <= 0.0) return;
    depth = radius - dist;
    normal = d / dist;
  }
  if (!(depth > hit.depth)) return;
  hit.depth = depth;
  locate(q, w, hit.face, hit.weights);
  hit.material = material;
  hit.normal = normal;
}

/// The net triangle's nodes' outcodes against the box [lo, hi] (bits 2k, 2k + 1: below, above on
/// axis k) into `outcode`; false when all of the net's nodes share a bit (the net is out of it).
bool net_outcodes(const NetModel& net, const Data& data, const Vec3& lo, const Vec3& hi,
                  std::vector<std::uint8_t>& outcode) noexcept {
  std::uint8_t all = 0x3f;
  for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
    const Vec3& x = data.nodes[static_cast<std::size_t>(i)].position;
    std::uint8_t code = 0;
    for (int k = 0; k < 3; ++k)
      code |= static_cast<std::uint8_t>((x[k] < lo[k] ? 1u : 0u) << (2 * k) | (x[k] > hi[k] ? 2u : 0u) << (2 * k));
    outcode[static_cast<std::size_t>(i)] = code;
    all &= code;
  }
  return all == 0;
}

/// Each node of the sorted thread (scratch.tissue_order / tissue_key along `axis`) within `reach`
/// of the bounds [flo, fhi] of a triangle: visit(i, x).
template <typename Visit>
void nodes_near(const ThreadState& st, const ThreadScratch& scratch, int axis, const Vec3& flo,
                const Vec3& fhi, double reach, Visit visit) noexcept {
  const auto key_begin = scratch.tissue_key.begin(), key_end = scratch.tissue_key.end();
  const auto first = std::lower_bound(key_begin, key_end, flo[axis] - reach);
  for (auto it = first; it != key_end && *it <= fhi[axis] + reach; ++it) {
    const int i = scratch.tissue_order[static_cast<std::size_t>(it - key_begin)];
    const Vec3& x = st.position[static_cast<std::size_t>(i)];
    if ((x.array() < flo.array() - reach).any() || (x.array() > fhi.array() + reach).any()) continue;
    visit(i, x);
  }
}

/// The thread's box (its nodes grown by its radius) and its nodes in order along the box's
/// longest axis into scratch.tissue_order / tissue_key: insertion sort of last step's order
/// (nearly sorted, O(n) a step), so that each triangle visits only the nodes within its extent.
/// Returns the axis; `lo`, `hi`: the box.
int sort_nodes_along_the_thread(const ThreadModel& thread, const ThreadState& st,
                                ThreadScratch& scratch, Vec3& lo, Vec3& hi) noexcept {
  const double rt = thread.radius;
  const auto nodes = st.position.size();
  lo = st.position[0];
  hi = st.position[0];
  for (const Vec3& x : st.position) {
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  lo.array() -= rt;
  hi.array() += rt;
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  std::vector<std::int32_t>& order = scratch.tissue_order;
  for (std::size_t p = 1; p < nodes; ++p) {
    const std::int32_t key = order[p];
    const double v = st.position[static_cast<std::size_t>(key)][axis];
    std::size_t q = p;
    for (; q > 0 && st.position[static_cast<std::size_t>(order[q - 1])][axis] > v; --q) order[q] = order[q - 1];
    order[q] = key;
  }
  for (std::size_t p = 0; p < nodes; ++p)
    scratch.tissue_key[p] = st.position[static_cast<std::size_t>(order[p])][axis];
  return axis;
}

/// Each node's deepest hit on the nets' surface triangles (touch_triangle()) into
/// scratch.tissue_hits: a net's own triangles, or where it carries a fine surface (the organ's
/// drawn surface, docs/fine-surface.md) the fine triangles riding on them, each hit then carried
/// by the net triangle under its point (the one its nearest corner rides on, the point's foot
/// on it). The net's triangles are culled by their nodes' outcodes against the thread's box
/// [lo, hi] grown by the reach and the fine surface's offsets: a net all of whose nodes share a
/// bit is out of reach, a triangle whose nodes share one too; a net triangle's riders are placed
/// only when a node of the thread is within the reach and the fine surface's of its bounds.
void find_tissue_hits(const Model& model, const Data& data, const ThreadModel& thread,
                      const ThreadState& st, ThreadScratch& scratch, int axis, const Vec3& lo,
                      const Vec3& hi) noexcept {
  const double rt = thread.radius;
  const double reach = rt + kThreadTissueContactReach;
  std::vector<std::uint8_t>& outcode = scratch.net_node_outcode;
  const std::span<const NodeState> nodes(data.nodes.data(), data.nodes.size());
  for (const NetModel& net : model.nets) {
    if (net.face_count == 0) continue;
    const bool fine = net.surface_face_count > 0;
    const double grow = kThreadTissueContactReach + (fine ? net.surface_reach : 0.0);
    if (!net_outcodes(net, data, lo.array() - grow, hi.array() + grow, outcode)) continue;
    for (int f = net.face_begin; f < net.face_begin + net.face_count; ++f) {
      const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(f)];
      if ((outcode[static_cast<std::size_t>(t[0])] & outcode[static_cast<std::size_t>(t[1])] &
           outcode[static_cast<std::size_t>(t[2])]) != 0)
        continue;
      const Vec3& a = data.nodes[static_cast<std::size_t>(t[0])].position;
      const Vec3& b = data.nodes[static_cast<std::size_t>(t[1])].position;
      const Vec3& c = data.nodes[static_cast<std::size_t>(t[2])].position;
      if (!fine) {
        const Vec3 flo = a.cwiseMin(b).cwiseMin(c), fhi = a.cwiseMax(b).cwiseMax(c);
        const Vec3 cross = (b - a).cross(c - a);
        const double area2 = cross.norm();
        if (!(area2 > 0.0)) continue;
        const Vec3 n = cross / area2;
        nodes_near(st, scratch, axis, flo, fhi, reach, [&](int i, const Vec3& x) {
          touch_triangle(x, rt, net.material, a, b, c, n, scratch.tissue_hits[static_cast<std::size_t>(i)],
                         [&](const Vec3&, const Vec3& w, int& face, Vec3& weights) { face = f, weights = w; });
        });
        continue;
      }
      if constexpr (kWithDeformable) {  // the fine surface's map is a net's (core/src/net/)
        // The fine triangles riding on f (one riding on several is touched from each: a hit keeps
        // the deepest), if a node of the thread is within their reach of f's bounds.
        bool near = false;
        nodes_near(st, scratch, axis, a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c),
                   reach + net.surface_reach, [&](int, const Vec3&) { near = true; });
        if (!near) continue;
        const auto first = static_cast<std::size_t>(model.net_face_surface_begin[static_cast<std::size_t>(f)]);
        const auto last = static_cast<std::size_t>(model.net_face_surface_begin[static_cast<std::size_t>(f) + 1]);
        for (std::size_t k = first; k < last; ++k) {
          const std::array<int, 3>& ft = model.net_surface_faces[static_cast<std::size_t>(model.net_face_surface_faces[k])];
          const Vec3 p[3] = {net_surface_position(model, nodes, ft[0]), net_surface_position(model, nodes, ft[1]),
                             net_surface_position(model, nodes, ft[2])};
          const Vec3 flo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), fhi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
          const Vec3 cross = (p[1] - p[0]).cross(p[2] - p[0]);
          const double area2 = cross.norm();
          if (!(area2 > 0.0) || !flo.allFinite() || !fhi.allFinite()) continue;
          const Vec3 n = cross / area2;
          nodes_near(st, scratch, axis, flo, fhi, reach, [&](int i, const Vec3& x) {
            touch_triangle(x, rt, net.material, p[0], p[1], p[2], n, scratch.tissue_hits[static_cast<std::size_t>(i)],
                           [&](const Vec3& q, const Vec3& w, int& face, Vec3& weights) {
                             int m = 0;  // the corner nearest q carries it: its net triangle, q's foot there
                             if (w[1] > w[m]) m = 1;
                             if (w[2] > w[m]) m = 2;
                             face = model.net_surface_points[static_cast<std::size_t>(ft[static_cast<std::size_t>(m)])].face;
                             const std::array<int, 3>& nt = model.net_faces[static_cast<std::size_t>(face)];
                             int feature = detail::kFace;
                             detail::closest_on_triangle(q, nodes[static_cast<std::size_t>(nt[0])].position,
                                                         nodes[static_cast<std::size_t>(nt[1])].position,
                                                         nodes[static_cast<std::size_t>(nt[2])].position, feature, weights);
                           });
          });
        }
      }
    }
  }
}

/// The passages: each eyelet on tissue is where the thread goes in or out, at its nearest node.
/// Writes those nodes' indices in increasing order into `gates`; returns their count.
int passage_gates(const ThreadState& st, std::array<int, kMaxThreadEyelets>& gates) noexcept {
  const auto nodes = st.position.size();
  int num_gates = 0;
  for (const ThreadEyelet& e : st.eyelets) {
    if (!e.active || e.face < 0) continue;
    std::size_t nearest = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < nodes; ++i) {
      const double d2 = (st.position[i] - e.position).squaredNorm();
      if (d2 < best) best = d2, nearest = i;
    }
    int g = num_gates++;
    for (; g > 0 && gates[static_cast<std::size_t>(g - 1)] > static_cast<int>(nearest); --g)
      gates[static_cast<std::size_t>(g)] = gates[static_cast<std::size_t>(g - 1)];
    gates[static_cast<std::size_t>(g)] = static_cast<int>(nearest);
  }
  return num_gates;
}

/// Node i's contact with the triangle of its hit as a point term of the thread's step.
void write_tissue_term(const Model& model, const Data& data, const ThreadModel& thread,
                       const ThreadState& st, const ThreadTissueHit& hit, std::size_t i,
                       ThreadPointTerm& term) noexcept {
  const double rt = thread.radius;
  const double thread_node_mass = thread.density * std::numbers::pi * rt * rt * thread.rest_segment;
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(hit.face)];
  Vec3 v_surface = Vec3::Zero();
  for (int m = 0; m < 3; ++m)
    v_surface += hit.weights[m] * data.nodes[static_cast<std::size_t>(t[static_cast<std::size_t>(m)])].velocity;
  // Under the time-constant floor of the lighter side: the touched point's effective mass on
  // its nodes, 1 / Σ w_j² / m_j, or the thread's node. Each side steps the other's point as
  // given (staggered), so a contact stiffer than the lighter side's step resolves pumps energy
  // into the pair (a heavy thread dropped on the patch bounced off it with the pair's 2e4 N/m).
  double inverse_mass = 0.0;
  for (int m = 0; m < 3; ++m)
    inverse_mass += hit.weights[m] * hit.weights[m] /
                    model.node_mass[static_cast<std::size_t>(t[static_cast<std::size_t>(m)])];
  const double m_eff = std::min(1.0 / inverse_mass, thread_node_mass);
  const MaterialPair& mp = model.material_pair(thread.material, hit.material);
  const double k = std::min(mp.stiffness, contact_stiffness_limit(m_eff, model.dt, model.solver.contact_max_omega_dt));
  term.a = term.b = static_cast<int>(i) + 1;
  fill_contact(term, mp, k, hit.depth, hit.normal, st.velocity[i] - v_surface);
  term.target_velocity = v_surface;
  term.point = st.position[i];
  term.face = hit.face;
  term.face_weights = hit.weights;
  term.axis = hit.normal;
}

}  // namespace

void gather_thread_tissue_contacts(const Model& model, const Data& data, const ThreadModel& thread,
                                   ThreadState& st, ThreadScratch& scratch) noexcept {
  scratch.num_tissue_terms = 0;
  if (model.net_faces.empty()) return;
  const auto nodes = st.position.size();
  for (std::size_t i = 0; i < nodes; ++i) scratch.tissue_hits[i] = ThreadTissueHit{};
  Vec3 lo, hi;
  const int axis = sort_nodes_along_the_thread(thread, st, scratch, lo, hi);
  find_tissue_hits(model, data, thread, st, scratch, axis, lo, hi);
  // Walking from the start, the thread is inside the tissue from a tissue eyelet to the next. A
  // thread that follows a needle starts inside while its count is odd (the tail has passed an
  // entry and not yet its exit: each pass takes over two points).
  std::array<int, kMaxThreadEyelets> gates{};
  const int num_gates = passage_gates(st, gates);
  bool inside = thread.needle >= 0 && num_gates % 2 == 1;
  int next_gate = 0;
  for (std::size_t i = 0; i < nodes; ++i) {
    for (; next_gate < num_gates && gates[static_cast<std::size_t>(next_gate)] <= static_cast<int>(i); ++next_gate)
      inside = !inside;
    const ThreadTissueHit& hit = scratch.tissue_hits[i];
    if (hit.face < 0 || inside || near_a_passage(thread, st, static_cast<int>(i))) continue;
    if (st.output.tissue_contacts >= kMaxThreadTissueContacts) {
      ++st.output.contacts_dropped;
      continue;
    }
    ThreadPointTerm* term = next_thread_term(scratch, st);
    if (term == nullptr) return;
    write_tissue_term(model, data, thread, st, hit, i, *term);
    ++st.output.tissue_contacts;
  }
}

void tie_tissue_contacts(const Model& model, Data& data, const ThreadScratch& scratch) noexcept {
  for (int j = 0; j < scratch.num_tissue_terms; ++j) {
    const ThreadTissueTerm& t = scratch.tissue_terms[static_cast<std::size_t>(j)];
    const std::array<int, 3>& face = model.net_faces[static_cast<std::size_t>(t.face)];
    for (int m = 0; m < 3; ++m) {
      const double w = t.weights[m];
      if (!(w > 0.0)) continue;
      const int node = face[static_cast<std::size_t>(m)];
      const auto slot = static_cast<std::size_t>(detail::node_contact_count(data));
      if (slot >= data.node_contacts.size()) return;  // make_data() gave them room: not reached
      const Vec3& v_node = data.nodes[static_cast<std::size_t>(node)].velocity;
      // On the node: its weight of the contact's force on the thread, reversed, along the
      // normal, stiff and damped towards the thread's node as the step left it.
      detail::set_held_spring(data.node_contacts[slot], node, -1, t.point, Vec3::Zero(), t.normal,
                              w * t.stiffness, w * t.damping, (-w * t.normal.dot(t.force)) * t.normal,
                              t.normal.dot(v_node - t.velocity));
      ++data.num_node_thread_ties;
    }
  }
}

}  // namespace numen::core
