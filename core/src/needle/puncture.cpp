/// @file puncture.cpp
/// The needle through tissue: its puncture test, its ties and its sweep (needle_puncture.hpp).

#include "numen/core/needle_puncture.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/step_stages.hpp"

#include "contact/collision_query.hpp"
#include "needle/needle_passage.hpp"
#include "net/net_terms.hpp"
#include "scratch/data_scratch.hpp"

namespace numen::core {
namespace {

/// A world point of `body` given in its frame.
Vec3 world_point(const BodyState& b, const Vec3& local) noexcept { return b.position + b.orientation * local; }

/// The point Σ w_m x_m (or the velocity, `velocity`) of net triangle `face` (m or m/s, world).
Vec3 face_point(const Model& model, const Data& data, int face, const Vec3& w, bool velocity) noexcept {
  const std::array<int, 3>& f = model.net_faces[static_cast<std::size_t>(face)];
  Vec3 p = Vec3::Zero();
  for (int k = 0; k < 3; ++k) {
    const NodeState& n = data.nodes[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])];
    p += w[k] * (velocity ? n.velocity : n.position);
  }
  return p;
}

/// The outward unit normal of net triangle `face` now ((x1 − x0) × (x2 − x0), Model::net_faces'
/// winding), or zero for a degenerate one.
Vec3 face_normal(const Model& model, const Data& data, int face) noexcept {
  const std::array<int, 3>& f = model.net_faces[static_cast<std::size_t>(face)];
  const Vec3& x0 = data.nodes[static_cast<std::size_t>(f[0])].position;
  const Vec3 n = (data.nodes[static_cast<std::size_t>(f[1])].position - x0)
                     .cross(data.nodes[static_cast<std::size_t>(f[2])].position - x0);
  const double len = n.norm();
  return len > 0.0 ? Vec3(n / len) : Vec3::Zero();
}

/// Whether the segment a → b crosses net triangle `face` (Möller & Trumbore 1997, "Fast, minimum
/// storage ray/triangle intersection", on the segment u ∈ [0, 1]); its barycentric weights there
/// and its u.
bool segment_crosses_face(const Model& model, const Data& data, int face, const Vec3& a, const Vec3& b,
                          Vec3* weights, double* along) noexcept {
  const std::array<int, 3>& f = model.net_faces[static_cast<std::size_t>(face)];
  const Vec3& p0 = data.nodes[static_cast<std::size_t>(f[0])].position;
  const Vec3 e1 = data.nodes[static_cast<std::size_t>(f[1])].position - p0;
  const Vec3 e2 = data.nodes[static_cast<std::size_t>(f[2])].position - p0;
  const Vec3 dir = b - a;
  const Vec3 p = dir.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-30) return false;  // parallel
  const Vec3 s = a - p0;
  const double w1 = s.dot(p) / det;
  if (w1 < 0.0 || w1 > 1.0) return false;
  const Vec3 q = s.cross(e1);
  const double w2 = dir.dot(q) / det;
  if (w2 < 0.0 || w1 + w2 > 1.0) return false;
  const double u = e2.dot(q) / det;
  if (u < 0.0 || u > 1.0) return false;
  *weights = Vec3(1.0 - w1 - w2, w1, w2);
  if (along != nullptr) *along = u;
  return true;
}

/// The passage's exit point (NeedlePuncture::exit), or nullptr.
const NeedlePuncture* exit_point(const NeedleState& st) noexcept {
  for (int i = 0; i < st.num_punctures; ++i)
    if (st.punctures[static_cast<std::size_t>(i)].exit) return &st.punctures[static_cast<std::size_t>(i)];
  return nullptr;
}

/// The passage's entry point, or nullptr (let go at the tail, or none).
const NeedlePuncture* entry_point(const NeedleState& st) noexcept {
  for (int i = 0; i < st.num_punctures; ++i)
    if (!st.punctures[static_cast<std::size_t>(i)].exit) return &st.punctures[static_cast<std::size_t>(i)];
  return nullptr;
}

/// The arc parameter (m) of sphere `i` (of the needle's own, tail first).
double sphere_parameter(const NeedleModel& n, int i) noexcept {
  return n.length() * static_cast<double>(i) / static_cast<double>(std::max(1, n.sphere_count - 1));
}

/// Calls `visit(face, weights, u)` for each triangle of net `net` that a → b crosses (u ∈ [0, 1]
/// along it), in the net's order, until it returns true. A triangle whose box misses the
/// segment's (boxes_overlap(), its margin covering the crossing test's rounding) is not crossed:
/// the boxes first, cheaper than the test (about 1 000 triangles a step on the suturing pad, most
/// far from the tip).
template <typename Visit>
void visit_crossings(const Model& model, const Data& data, int net, const Vec3& a, const Vec3& b,
                     Visit visit) noexcept {
  const NetModel& nm = model.nets[static_cast<std::size_t>(net)];
  const Vec3 lo = a.cwiseMin(b), hi = a.cwiseMax(b);
  for (int f = nm.face_begin; f < nm.face_begin + nm.face_count; ++f) {
    const std::array<int, 3>& v = model.net_faces[static_cast<std::size_t>(f)];
    const Vec3& p0 = data.nodes[static_cast<std::size_t>(v[0])].position;
    const Vec3& p1 = data.nodes[static_cast<std::size_t>(v[1])].position;
    const Vec3& p2 = data.nodes[static_cast<std::size_t>(v[2])].position;
    if (!collision_detail::boxes_overlap(p0.cwiseMin(p1).cwiseMin(p2), p0.cwiseMax(p1).cwiseMax(p2), lo, hi))
      continue;
    Vec3 w;
    double u = 0.0;
    if (segment_crosses_face(model, data, f, a, b, &w, &u) && visit(f, w, u)) return;
  }
}

/// The first crossing of net `net`'s triangles by a → b in the net's order: its face (−1: none)
/// and weights.
int first_crossing(const Model& model, const Data& data, int net, const Vec3& a, const Vec3& b, Vec3* weights) noexcept {
  int first = -1;
  visit_crossings(model, data, net, a, b, [&](int f, const Vec3& w, double) {
    first = f, *weights = w;
    return true;
  });
  return first;
}

/// The earliest crossing of net `net`'s triangles by a → b going in (against the triangle's
/// outward normal): its face (−1: none) and its fraction u ∈ [0, 1] of the segment.
int first_inward_crossing(const Model& model, const Data& data, int net, const Vec3& a, const Vec3& b,
                          double* along) noexcept {
  int first = -1;
  visit_crossings(model, data, net, a, b, [&](int f, const Vec3&, double u) {
    if (face_normal(model, data, f).dot(b - a) < 0.0 && (first < 0 || u < *along)) first = f, *along = u;
    return false;
  });
  return first;
}

/// The tip's sweep over the last step (NeedleState::tip_previous → now): an exit, a way back out,
/// or a tunnel (tie_needles()).
void sweep_tip(const Model& model, Data& data, const NeedleModel& n, NeedleState& st, const Vec3& tip,
               const Vec3& tangent) noexcept {
  const Vec3 a = st.tip_previous;
  st.tip_previous = tip;
  const bool swept = st.tip_previous_valid;
  st.tip_previous_valid = true;
  if (!swept || (tip - a).squaredNorm() == 0.0) return;
  Vec3 w;
  if (st.num_punctures > 0) {
    if (exit_point(st) != nullptr) return;  // one pass: the tip is out
    const NeedlePuncture& entry = st.punctures[0];
    const int f = first_crossing(model, data, entry.net, a, tip, &w);
    if (f < 0 || face_normal(model, data, f).dot(tip - a) <= 0.0) return;  // not out
    // Drawn back out the way it came only while the tip is within 4 r_w of the entry along the
    // arc; deeper in, the tip comes out through new tissue whichever way it moved this step (the
    // surface moves too: a dragged pad can pass a still tip), which is an exit.
    const bool at_entry = entry.arc_parameter >= n.length() - 4.0 * n.wire_radius;
    if (!at_entry || (tip - a).dot(tangent) > 0.0) {  // out through new tissue: the exit
      NeedlePuncture& x = st.punctures[static_cast<std::size_t>(st.num_punctures++)];
      x = NeedlePuncture{};
      x.net = entry.net;
      x.face = f;
      x.weights = w;
      x.exit = true;
      x.friction = n.friction;
      st.event = PunctureEvent::kExit;
      ++st.exits;
    } else {  // back out the way it came: the passage ends
      st.releases += st.num_punctures;
      st.num_punctures = 0;
      st.event = PunctureEvent::kRelease;
    }
    return;
  }
  for (int net = 0; net < model.num_nets(); ++net) {
    const int f = first_crossing(model, data, net, a, tip, &w);
    if (f >= 0 && face_normal(model, data, f).dot(tip - a) < 0.0) {
      ++st.tunnels;  // in without a puncture
      return;
    }
  }
}

/// Where a puncture point is against the arc (measure_tie()).
enum class TieFate : std::uint8_t {
  kHeld,      ///< On the arc: tied.
  kPastTail,  ///< Behind the tail: the needle was pulled through; a thread at the tail takes it.
  kPastTip,   ///< More than 4 r_w past the tip: the needle was drawn back out.
};

/// Updates puncture `p`'s geometry and force at the step's start (NeedlePuncture); not kHeld when
/// its point has passed off the arc (past the tail, or more than 4 r_w past the tip) and is let go.
TieFate measure_tie(const Model& model, const Data& data, const NeedleModel& n, NeedlePuncture& p) noexcept {
  const BodyState& b = data.bodies[static_cast<std::size_t>(n.body)];
  const Vec3 x = face_point(model, data, p.face, p.weights, false);
  const Vec3 v = face_point(model, data, p.face, p.weights, true);
  const Vec3 local = b.orientation.conjugate() * (x - b.position);
  const double s = needle_closest_parameter(n, local);
  if (needle_point_behind_tail(n, local, s)) {
    p.position = x;
    return TieFate::kPastTail;
  }
  if (needle_point_past_tip(n, local, s)) return TieFate::kPastTip;
  const Vec3 at = world_point(b, needle_point(n, s));
  const Vec3 t = b.orientation * needle_tangent(n, s);
  const Vec3 v_at = b.linear_velocity + b.angular_velocity.cross(at - b.position);
  const Vec3 d = x - at, dv = v - v_at;
  // On the material point: stiff and damped sideways, viscous along the tangent.
  const Vec3 f = -n.tie_stiffness * (d - d.dot(t) * t) - n.tie_damping * (dv - dv.dot(t) * t) -
                 n.friction * dv.dot(t) * t;
  p.arc_parameter = s;
  p.position = x;
  p.tangent = t;
  p.friction = n.friction;
  p.force = -f;
  p.deviation = d.norm();
  return TieFate::kHeld;
}

/// Writes puncture `p`'s springs after the node contacts, the grasp springs and the ties written
/// so far (NodeContact::held; Data::num_node_needle_ties): per node of its triangle with a weight
/// w > 0, three along the tangent and two normals to it.
void write_tie_springs(const Model& model, Data& data, const NeedleModel& n, const NeedlePuncture& p) noexcept {
  const BodyState& b = data.bodies[static_cast<std::size_t>(n.body)];
  const Vec3 at = world_point(b, needle_point(n, p.arc_parameter));
  const Vec3 v_at = b.linear_velocity + b.angular_velocity.cross(at - b.position);
  const Vec3 on_point = -p.force;  // the tie's force on the material point
  const Vec3 e1 = p.tangent.unitOrthogonal();
  const std::array<Vec3, 3> axes{p.tangent, e1, p.tangent.cross(e1)};
  detail::write_face_springs(model, data, p.face, p.weights, axes, {0.0, n.tie_stiffness, n.tie_stiffness},
                             {n.friction, n.tie_damping, n.tie_damping}, on_point, n.body, at,
                             at - b.position, v_at, data.num_node_contacts + data.num_node_grasp_springs,
                             data.num_node_needle_ties);
}

/// Drops this step's penalty node contacts between needle `n`'s spheres inside the net of its
/// passage `st` (arc parameters in [s_entry − 2 r_w, s_exit + 2 r_w]: s_exit = L without an exit,
/// s_entry = 0 once the entry is let go at the tail) and that net, keeping the order of the rest
/// (the grasp springs after them included).
void drop_inside_contacts(const Model& model, Data& data, const NeedleModel& n, const NeedleState& st) noexcept {
  const int net = st.punctures[0].net;
  const int total = std::clamp(data.num_node_contacts + data.num_node_grasp_springs, 0,
                               static_cast<int>(data.node_contacts.size()));
  NodeContact* first = data.node_contacts.data();
  NodeContact* last = std::remove_if(first, first + total, [&](const NodeContact& c) {
    if (c.held || c.body_b != n.body || c.sphere_b < n.sphere_begin || c.sphere_b >= n.sphere_begin + n.sphere_count ||
        model.node_net[static_cast<std::size_t>(c.node)] != net)
      return false;
    return detail::needle_sphere_inside(n, st, c.sphere_b - n.sphere_begin);
  });
  data.num_node_contacts -= static_cast<int>((first + total) - last);
}

/// Whether a node contact is one of needle `n`'s tip's (its spheres within 2 r_w of the tip).
struct TipContact {
  int body, first, end;
  bool operator()(const NodeContact& ct) const noexcept {
    return !ct.held && ct.body_b == body && ct.sphere_b >= first && ct.sphere_b < end;
  }
};
TipContact tip_contact(const NeedleModel& n) noexcept {
  return {n.body, n.sphere_begin + std::max(0, n.sphere_count - 3), n.sphere_begin + n.sphere_count};
}

/// The tissue giving way at the threshold within the puncture's step (find_punctures()): each
/// contact of the tip (`at_tip`, of the first `nc`) scaled by F_p / F_tip when the tip's force
/// along the needle F_tip = NeedleState::tip_force passed F_p = NeedleModel::puncture_force — the
/// excess taken back from its node's force and its reaction on the needle (compute_net_forces()
/// added both: a needle is sharp, so even an organ given by its material meets it with the pair's
/// penalty on the node alone, no load patch), its Jacobian coefficients scaled alike — and
/// tip_force set to F_p.
void give_way_at_threshold(Data& data, const NeedleModel& n, NeedleState& st, const TipContact& at_tip,
                           int nc) noexcept {
  if (!(st.tip_force > n.puncture_force)) return;
  const double a = n.puncture_force / st.tip_force;
  NetScratch& s = data.scratch->net;
  for (int c = 0; c < nc; ++c) {
    NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!at_tip(ct)) continue;
    const Vec3 excess = (1.0 - a) * ct.force;
    s.force[static_cast<std::size_t>(ct.node)] -= excess;
    Wrench& w = data.body_wrench[static_cast<std::size_t>(ct.body_b)];
    w.force += excess;
    w.torque += ct.r_b.cross(excess);
    ct.force *= a;
    ct.stiffness *= a;
    ct.damping *= a;
    ct.friction *= a;
  }
  st.tip_force = n.puncture_force;
}

/// The entry of needle `n` (state `st`, not in a passage) at the deepest triangle its tip goes
/// into, not along or out of: its tangent within puncture_max_angle of the triangle's inward
/// normal (where two faces meet, a box's edge, the tip touches both and the side's contact may be
/// the deeper; it cannot be punctured from above, the top can). Of the first `nc` node contacts
/// (`at_tip`'s). The event, the time and the count; false, changing nothing, without such a
/// triangle.
bool enter_at_tip(const Model& model, const Data& data, const NeedleModel& n, NeedleState& st,
                  const TipContact& at_tip, int nc) noexcept {
  const BodyState& b = data.bodies[static_cast<std::size_t>(n.body)];
  const Vec3 t = b.orientation * needle_tangent(n, n.length());
  const double cos_max = std::cos(n.puncture_max_angle);
  int deepest = -1;
  for (int c = 0; c < nc; ++c) {
    const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)];
    if (!at_tip(ct) || ct.face < 0 ||
        (deepest >= 0 && !(ct.depth > data.node_contacts[static_cast<std::size_t>(deepest)].depth)))
      continue;
    if (-face_normal(model, data, ct.face).dot(t) >= cos_max) deepest = c;
  }
  if (deepest < 0) return false;
  const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(deepest)];
  NeedlePuncture& p = st.punctures[0];
  p = NeedlePuncture{};
  p.net = model.node_net[static_cast<std::size_t>(ct.node)];
  p.face = ct.face;
  p.weights = ct.face_weights;
  p.arc_parameter = n.length();
  p.position = face_point(model, data, p.face, p.weights, false);
  p.tangent = t;
  p.friction = n.friction;
  st.num_punctures = 1;
  st.event = PunctureEvent::kPuncture;
  st.puncture_time = data.time;
  ++st.punctures_made;
  return true;
}

}  // namespace

void tie_needles(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageNeedles;
  data.num_node_needle_ties = 0;
  for (std::size_t k = 0; k < model.needles.size(); ++k) {
    const NeedleModel& n = model.needles[k];
    NeedleState& st = data.needles[k];
    st.event = PunctureEvent::kNone;
    st.max_deviation = 0.0;
    st.num_tail_releases = 0;
    const BodyState& b = data.bodies[static_cast<std::size_t>(n.body)];
    sweep_tip(model, data, n, st, world_point(b, needle_tip(n)), b.orientation * needle_tangent(n, n.length()));
    // Measure each point; let go those past the arc's ends (keeping the entry first).
    int kept = 0;
    for (int i = 0; i < st.num_punctures; ++i) {
      NeedlePuncture p = st.punctures[static_cast<std::size_t>(i)];
      const TieFate fate = measure_tie(model, data, n, p);
      if (fate != TieFate::kHeld) {
        st.event = PunctureEvent::kRelease;
        ++st.releases;
        if (fate == TieFate::kPastTail) st.tail_releases[static_cast<std::size_t>(st.num_tail_releases++)] = p;
        continue;
      }
      st.max_deviation = std::max(st.max_deviation, p.deviation);
      st.punctures[static_cast<std::size_t>(kept++)] = p;
    }
    st.num_punctures = kept;
    if (kept == 0) continue;
    drop_inside_contacts(model, data, n, st);
  }
  // The ties after the node contacts the drops left and the grasp springs.
  for (std::size_t k = 0; k < model.needles.size(); ++k)
    for (int i = 0; i < data.needles[k].num_punctures; ++i)
      write_tie_springs(model, data, model.needles[k], data.needles[k].punctures[static_cast<std::size_t>(i)]);
}

bool detail::needle_sphere_inside(const NeedleModel& n, const NeedleState& st, int sphere) noexcept {
  if (st.num_punctures <= 0) return false;
  const NeedlePuncture* entry = entry_point(st);
  const NeedlePuncture* exit = exit_point(st);
  const double lo = entry != nullptr ? entry->arc_parameter - 2.0 * n.wire_radius : -1.0;
  const double hi = exit != nullptr ? exit->arc_parameter + 2.0 * n.wire_radius : n.length() + 1.0;
  const double s = sphere_parameter(n, sphere);
  return s >= lo && s <= hi;
}

void detail::drop_needles_inside_contacts(const Model& model, Data& data) noexcept {
  for (std::size_t k = 0; k < model.needles.size() && k < data.needles.size(); ++k)
    if (data.needles[k].num_punctures > 0) drop_inside_contacts(model, data, model.needles[k], data.needles[k]);
}

void find_punctures(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageNeedles;
  const int nc = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  for (std::size_t k = 0; k < model.needles.size(); ++k) {
    const NeedleModel& n = model.needles[k];
    NeedleState& st = data.needles[k];
    const BodyState& b = data.bodies[static_cast<std::size_t>(n.body)];
    const Vec3 t = b.orientation * needle_tangent(n, n.length());
    const TipContact at_tip = tip_contact(n);
    Vec3 force = Vec3::Zero();  // on the needle
    for (int c = 0; c < nc; ++c)
      if (const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(c)]; at_tip(ct)) force -= ct.force;
    st.tip_force = -force.dot(t);
    if (st.num_punctures > 0 || n.puncture_on_request || !(st.tip_force >= n.puncture_force)) continue;
    if (!enter_at_tip(model, data, n, st, at_tip, nc)) continue;
    st.puncture_contact_force = st.tip_force;
    give_way_at_threshold(data, n, st, at_tip, nc);
    st.puncture_tip_force = st.tip_force;
  }
}

bool detail::puncture_on_request(const Model& model, Data& data, int needle, double tip_force) noexcept {
  if (needle < 0 || needle >= model.num_needles() || needle >= static_cast<int>(data.needles.size()))
    return false;
  const NeedleModel& n = model.needles[static_cast<std::size_t>(needle)];
  NeedleState& st = data.needles[static_cast<std::size_t>(needle)];
  if (st.num_punctures > 0) return false;
  const int nc = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  if (!enter_at_tip(model, data, n, st, tip_contact(n), nc)) return false;
  st.puncture_contact_force = tip_force;
  st.puncture_tip_force = tip_force;
  return true;
}

void stop_needle_tunnels(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageNeedles;
  for (std::size_t k = 0; k < model.needles.size(); ++k) {
    const NeedleModel& n = model.needles[k];
    NeedleState& st = data.needles[k];
    if (st.num_punctures > 0 || !st.tip_previous_valid) continue;  // in a passage: the ties hold it
    BodyState& b = data.bodies[static_cast<std::size_t>(n.body)];
    const Vec3 a = st.tip_previous, tip = world_point(b, needle_tip(n));
    // Swept here up to where the tip is left: the next step's sweep starts there, and tests only
    // what moved the tip since (nothing, in a run of core::step()).
    st.tip_previous = tip;
    if ((tip - a).squaredNorm() == 0.0) continue;
    int face = -1;
    double u = 1.0;
    for (int net = 0; net < model.num_nets(); ++net) {
      double un = 1.0;
      const int f = first_inward_crossing(model, data, net, a, tip, &un);
      if (f >= 0 && (face < 0 || un < u)) face = f, u = un;
    }
    if (face < 0) continue;
    // The tip's centre's height over the crossed triangle's plane, from s_a at the step's start
    // to s_b < 0 now: stopped where it is kTunnelStopDepth r_w under the surface, or where it
    // started if that was deeper.
    const std::array<int, 3>& v = model.net_faces[static_cast<std::size_t>(face)];
    const Vec3& p0 = data.nodes[static_cast<std::size_t>(v[0])].position;
    const Vec3 o = face_normal(model, data, face);
    const double s_a = o.dot(a - p0), s_b = o.dot(tip - p0);
    const double s_stop = std::min(s_a, n.wire_radius * (1.0 - kTunnelStopDepth));
    const double stop = s_a > s_b ? std::clamp((s_a - s_stop) / (s_a - s_b), 0.0, 1.0) : 0.0;
    b.position += (a + stop * (tip - a)) - tip;
    st.tip_previous = world_point(b, needle_tip(n));
    const Vec3 v_tip = b.linear_velocity + b.angular_velocity.cross(st.tip_previous - b.position);
    if (const double vn = v_tip.dot(o); vn < 0.0) b.linear_velocity -= vn * o;
    ++st.tunnels_stopped;
  }
}

}  // namespace numen::core
