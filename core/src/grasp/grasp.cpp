/// @file grasp.cpp
/// Grasping (grasp.hpp, docs/grasping.md): the grasp stage, the springs' forces and their
/// terms in the linearised step.

#include "numen/core/grasp.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step_stages.hpp"

#include "scratch/data_scratch.hpp"
#include "grasp/grasp_terms.hpp"
#include "grasp/grasp_thread.hpp"
#include "net/net_terms.hpp"
#include "solver/solver_terms.hpp"

namespace numen::core {
namespace {

/// The force (N, world) of a zero-length damped spring of stiffness k (N/m) and damping c
/// (N·s/m) on a point at x moving at v, tied to a point at p moving at v_p.
Vec3 grasp_spring_force(double k, double c, const Vec3& p, const Vec3& v_p, const Vec3& x,
                        const Vec3& v) noexcept {
  return k * (p - x) + c * (v_p - v);
}

/// The jaw's turn about its joint (rad); 0 for a fixed jaw.
double jaw_angle(const Model& model, const Data& data, int joint) noexcept {
  if (joint < 0) return 0.0;
  const JointModel& jm = model.joints[static_cast<std::size_t>(joint)];
  const BodyState* parent = jm.parent >= 0 ? &data.bodies[static_cast<std::size_t>(jm.parent)] : nullptr;
  return joint_coordinate(jm, parent, data.bodies[static_cast<std::size_t>(jm.child)]);
}

/// Which jaw (0 or 1) `body` is, or -1.
int jaw_index(const GraspModel& g, int body) noexcept {
  return body == g.jaws[0] ? 0 : (body == g.jaws[1] ? 1 : -1);
}

/// The other body of a body–body contact with a jaw of `g`, and which jaw; -1 if none.
int grasped_side(const Model& model, const GraspModel& g, const Contact& c, int* jaw) noexcept {
  if (c.body_b < 0) return -1;
  int other = -1;
  int j = jaw_index(g, c.body_a);
  if (j >= 0) {
    other = c.body_b;
  } else {
    j = jaw_index(g, c.body_b);
    if (j < 0) return -1;
    other = c.body_a;
  }
  if (jaw_index(g, other) >= 0) return -1;  // jaw on jaw
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(other)];
  if (bm.anchored) return -1;
  // A body jointed to the jaws (the instrument itself) never collides with them; check anyway.
  const auto& tree = model.articulation.body_tree;
  if (!tree.empty() && tree[static_cast<std::size_t>(other)] == tree[static_cast<std::size_t>(g.jaws[static_cast<std::size_t>(j)])])
    return -1;
  *jaw = j;
  return other;
}

/// What `st` holds: the body, the net and the thread (each -1 if not), and its springs' or held
/// nodes' count (GraspRecord).
struct Held {
  int body = -1, net = -1, thread = -1, count = 0;
};
Held held_by(const GraspState& st) noexcept {
  return {st.body, st.net, st.thread,
          st.body >= 0 ? st.num_points : (st.thread >= 0 ? st.num_thread_nodes : st.num_nodes)};
}

/// Logs this step's event of `st` (GraspState::log), if there is room.
void log_event(GraspState& st, double time, const Held& held) noexcept {
  if (st.logged >= kGraspLogSize) return;
  st.log[static_cast<std::size_t>(st.logged++)] =
      GraspRecord{time, st.event, held.body, held.net, held.count, st.grip_force, held.thread};
}

/// A grasp started at `time` (s): the event, the count and the log.
void begin_grasp(GraspState& st, double time) noexcept {
  st.started = time;
  st.event = GraspEvent::kGrasp;
  ++st.grasps;
  log_event(st, time, held_by(st));
}

/// Lets go of whatever `st` holds (the event is the caller's).
void let_go(GraspState& st) noexcept {
  st.body = -1;
  st.num_points = 0;
  st.net = -1;
  st.num_nodes = 0;
  st.thread = -1;
  st.num_thread_nodes = 0;
}

/// Starts a grasp of `g` if both jaws touch one body this step: per jaw, five springs over its
/// grip (GraspModel::grip_radius) — at the mean point of its contacts with the body, and at ±r
/// along two axes of the plane normal to their mean normal.
void try_grasp(const Model& model, Data& data, const GraspModel& g, GraspState& st) noexcept {
  const int nc = std::clamp(data.num_contacts, 0, kMaxContacts);
  // The first body touched by jaw 0 that jaw 1 touches too.
  int body = -1;
  for (int i = 0; i < nc && body < 0; ++i) {
    int jaw = -1;
    const int b = grasped_side(model, g, data.contacts[static_cast<std::size_t>(i)], &jaw);
    if (b < 0 || jaw != 0) continue;
    for (int k = 0; k < nc; ++k) {
      int jaw2 = -1;
      if (grasped_side(model, g, data.contacts[static_cast<std::size_t>(k)], &jaw2) == b && jaw2 == 1) {
        body = b;
        break;
      }
    }
  }
  if (body < 0) return;
  const BodyState& held = data.bodies[static_cast<std::size_t>(body)];
  st.num_points = 0;
  for (int jaw = 0; jaw < 2; ++jaw) {
    Vec3 centre = Vec3::Zero();
    Vec3 normal = Vec3::Zero();
    int count = 0;
    for (int i = 0; i < nc; ++i) {
      const Contact& c = data.contacts[static_cast<std::size_t>(i)];
      int j = -1;
      if (grasped_side(model, g, c, &j) != body || j != jaw) continue;
      centre += c.position;
      normal += c.normal;
      ++count;
    }
    centre /= static_cast<double>(count);
    const double n_norm = normal.norm();
    const Vec3 n = n_norm > 0.0 ? Vec3(normal / n_norm) : Vec3::UnitZ();
    const Vec3 e1 = n.unitOrthogonal();
    const Vec3 e2 = n.cross(e1);
    const double r = g.grip_radius;
    const std::array<Vec3, kGripPointsPerJaw> at{centre, centre + r * e1, centre - r * e1,
                                                 centre + r * e2, centre - r * e2};
    const int jaw_body = g.jaws[static_cast<std::size_t>(jaw)];
    const BodyState& js = data.bodies[static_cast<std::size_t>(jaw_body)];
    for (const Vec3& p_world : at) {
      GraspPoint& p = st.points[static_cast<std::size_t>(st.num_points++)];
      p.jaw = jaw_body;
      p.jaw_point = js.orientation.conjugate() * (p_world - js.position);
      p.body_point = held.orientation.conjugate() * (p_world - held.position);
      p.force.setZero();
    }
  }
  st.body = body;
  begin_grasp(st, data.time);
}

/// Drops this step's contacts between the jaws of `g` and the body it holds.
void drop_held_contacts(const Model& model, Data& data, const GraspModel& g, const GraspState& st) noexcept {
  const int nc = std::clamp(data.num_contacts, 0, kMaxContacts);
  Contact* first = data.contacts.data();
  Contact* last = std::remove_if(first, first + nc, [&](const Contact& c) {
    int jaw = -1;
    return grasped_side(model, g, c, &jaw) == st.body;
  });
  if (last == first + nc) return;
  data.num_contacts = static_cast<int>(last - first);
  data.max_penetration = 0.0;
  for (const Contact* c = first; c != last; ++c) data.max_penetration = std::max(data.max_penetration, c->depth);
}

/// Starts a grasp of tissue if both jaws touch one net's nodes this step: each node a jaw touches
/// (up to kMaxGraspNodes) tied to the first jaw that touched it.
void try_grasp_tissue(const Model& model, Data& data, const GraspModel& g, GraspState& st) noexcept {
  const int nc = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  int net = -1;
  for (int i = 0; i < nc && net < 0; ++i) {
    const NodeContact& a = data.node_contacts[static_cast<std::size_t>(i)];
    if (a.body_b < 0 || a.body_b != g.jaws[0]) continue;
    const int n = model.node_net[static_cast<std::size_t>(a.node)];
    for (int k = 0; k < nc; ++k) {
      const NodeContact& b = data.node_contacts[static_cast<std::size_t>(k)];
      if (b.body_b == g.jaws[1] && model.node_net[static_cast<std::size_t>(b.node)] == n) {
        net = n;
        break;
      }
    }
  }
  if (net < 0) return;
  st.num_nodes = 0;
  for (int i = 0; i < nc && st.num_nodes < kMaxGraspNodes; ++i) {
    const NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (jaw_index(g, c.body_b) < 0 || model.node_net[static_cast<std::size_t>(c.node)] != net) continue;
    bool known = false;
    for (int k = 0; k < st.num_nodes; ++k) known = known || st.nodes[static_cast<std::size_t>(k)].node == c.node;
    if (known) continue;
    const BodyState& js = data.bodies[static_cast<std::size_t>(c.body_b)];
    GraspNode& n = st.nodes[static_cast<std::size_t>(st.num_nodes++)];
    n.node = c.node;
    n.jaw = c.body_b;
    n.jaw_point = js.orientation.conjugate() * (data.nodes[static_cast<std::size_t>(c.node)].position - js.position);
    n.force.setZero();
  }
  st.net = net;
  begin_grasp(st, data.time);
}

/// Drops this step's node contacts between the jaws of `g` and the net whose tissue it holds.
void drop_held_node_contacts(const Model& model, Data& data, const GraspModel& g, const GraspState& st) noexcept {
  const int nc = std::clamp(data.num_node_contacts, 0, static_cast<int>(data.node_contacts.size()));
  NodeContact* first = data.node_contacts.data();
  NodeContact* last = std::remove_if(first, first + nc, [&](const NodeContact& c) {
    return jaw_index(g, c.body_b) >= 0 && model.node_net[static_cast<std::size_t>(c.node)] == st.net;
  });
  data.num_node_contacts = static_cast<int>(last - first);
}

/// Writes the held nodes' springs of `g` after the node contacts (NodeContact::held): three per
/// node along the world's axes, each with its share of the spring's force at the step's start
/// (GraspNode::force, computed here once; the nets' forces stage applies them).
void write_node_springs(Data& data, const GraspModel& g, GraspState& st) noexcept {
  for (int k = 0; k < st.num_nodes; ++k) {
    GraspNode& n = st.nodes[static_cast<std::size_t>(k)];
    const BodyState& jaw = data.bodies[static_cast<std::size_t>(n.jaw)];
    const NodeState& node = data.nodes[static_cast<std::size_t>(n.node)];
    const Vec3 r = jaw.orientation * n.jaw_point;
    const Vec3 v_jaw = jaw.linear_velocity + jaw.angular_velocity.cross(r);
    n.force = grasp_spring_force(g.stiffness, g.damping, jaw.position + r, v_jaw, node.position, node.velocity);
    for (int axis = 0; axis < kGraspSpringsPerNode; ++axis) {
      const auto at = static_cast<std::size_t>(data.num_node_contacts + data.num_node_grasp_springs);
      if (at >= data.node_contacts.size()) return;  // make_data() gave them room: not reached
      const Vec3 e = Vec3::Unit(axis);
      detail::set_held_spring(data.node_contacts[at], n.node, n.jaw, jaw.position + r, r, e, g.stiffness,
                              g.damping, e.dot(n.force) * e, e.dot(node.velocity - v_jaw));
      ++data.num_node_grasp_springs;
    }
  }
}

}  // namespace

const char* to_string(GraspEvent event) noexcept {
  switch (event) {
    case GraspEvent::kNone: return "none";
    case GraspEvent::kGrasp: return "grasp";
    case GraspEvent::kRelease: return "release";
    case GraspEvent::kSlip: return "slip";
  }
  return "?";
}

void update_grasps(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageGrasp;
  data.num_node_grasp_springs = 0;
  for (std::size_t i = 0; i < model.grasps.size(); ++i) {
    const GraspModel& g = model.grasps[i];
    GraspState& st = data.grasps[i];
    st.event = GraspEvent::kNone;
    st.opening = std::abs(jaw_angle(model, data, g.jaw_joints[0]) - jaw_angle(model, data, g.jaw_joints[1]));
    if (st.holding()) {
      const Held held = held_by(st);
      if (st.opening > g.open_angle) {
        let_go(st);
        st.event = GraspEvent::kRelease;
        ++st.releases;
        log_event(st, data.time, held);
      } else {
        // The grip slips when the springs' net pull on what it holds at the last step exceeded
        // its limit (a NaN too).
        Vec3 pull = Vec3::Zero();
        for (int k = 0; k < st.num_points; ++k) pull += st.points[static_cast<std::size_t>(k)].force;
        for (int k = 0; k < st.num_nodes; ++k) pull += st.nodes[static_cast<std::size_t>(k)].force;
        for (int k = 0; k < st.num_thread_nodes; ++k) pull += st.thread_nodes[static_cast<std::size_t>(k)].force;
        st.grip_force = pull.norm();
        if (!(st.grip_force <= g.max_force)) {
          let_go(st);
          st.event = GraspEvent::kSlip;
          st.armed = false;  // no new grasp until the jaws open past θ_o
          ++st.slips;
          log_event(st, data.time, held);
        }
      }
    } else if (st.opening > g.open_angle) {
      st.armed = true;
    } else if (st.armed && st.opening < g.close_angle) {
      try_grasp(model, data, g, st);
      // A thread before tissue: a thread lying on tissue between the jaws is taken, not the
      // tissue under it (docs/thread.md "The thread in the jaws").
      if (!st.holding() && g.thread && !model.threads.empty() && take_thread(model, data, g, st)) begin_grasp(st, data.time);
      if (!st.holding() && g.tissue && model.num_nets() > 0) try_grasp_tissue(model, data, g, st);
    }
    if (st.body >= 0) drop_held_contacts(model, data, g, st);
    if (st.net >= 0) drop_held_node_contacts(model, data, g, st);
  }
  // The held nodes' springs after the node contacts the drops left.
  for (std::size_t i = 0; i < model.grasps.size(); ++i)
    if (data.grasps[i].net >= 0) write_node_springs(data, model.grasps[i], data.grasps[i]);
}

void apply_grasp_forces(const Model& model, Data& data) noexcept {
  for (std::size_t i = 0; i < model.grasps.size(); ++i) {
    const GraspModel& g = model.grasps[i];
    GraspState& st = data.grasps[i];
    if (st.body < 0) continue;  // held nodes: their forces are the nets' (write_node_springs())
    const auto b = static_cast<std::size_t>(st.body);
    const BodyState& held = data.bodies[b];
    for (int k = 0; k < st.num_points; ++k) {
      GraspPoint& p = st.points[static_cast<std::size_t>(k)];
      const auto j = static_cast<std::size_t>(p.jaw);
      const BodyState& jaw = data.bodies[j];
      const Vec3 r_j = jaw.orientation * p.jaw_point;
      const Vec3 r_b = held.orientation * p.body_point;
      p.force = grasp_spring_force(g.stiffness, g.damping, jaw.position + r_j,
                                   jaw.linear_velocity + jaw.angular_velocity.cross(r_j), held.position + r_b,
                                   held.linear_velocity + held.angular_velocity.cross(r_b));
      data.body_wrench[b].force += p.force;
      data.body_wrench[b].torque += r_b.cross(p.force);
      data.body_wrench[j].force -= p.force;
      data.body_wrench[j].torque -= r_j.cross(p.force);
    }
  }
}

namespace detail {

int grasp_point_capacity(const Model& model) noexcept { return model.num_grasps() * kMaxGraspPoints; }

void add_grasp_terms(const Model& model, Data& data) noexcept {
  SolverScratch& s = data.scratch->solver;
  const double h = s.system_step;
  for (std::size_t i = 0; i < model.grasps.size(); ++i) {
    const GraspModel& g = model.grasps[i];
    const GraspState& st = data.grasps[i];
    if (st.body < 0) continue;  // held nodes: their springs are node contacts (NodeContact::held)
    // W = β I, β = h c + h² k; b += −h² k Gᵀ (G u0) with G u0 the points' relative velocity.
    const double beta = h * g.damping + h * h * g.stiffness;
    const auto a = static_cast<std::size_t>(st.body);
    const BodyState& held = data.bodies[a];
    for (int k = 0; k < st.num_points; ++k) {
      const GraspPoint& p = st.points[static_cast<std::size_t>(k)];
      const auto b = static_cast<std::size_t>(p.jaw);
      const Vec3 r_a = held.orientation * p.body_point;
      const Vec3 r_b = data.bodies[b].orientation * p.jaw_point;
      const Vec3 u_rel = point_velocity(s.twist0[a], r_a) - point_velocity(s.twist0[b], r_b);
      const Vec3 impulse = (-h * h * g.stiffness) * u_rel;  // on the held body; −impulse on the jaw
      if (s.in_solve[a]) add_point_spring_terms(beta, impulse, r_a, s.rhs[a], s.isotropic_moments[a]);
      if (s.in_solve[b]) add_point_spring_terms(beta, -impulse, r_b, s.rhs[b], s.isotropic_moments[b]);
      if (s.in_solve[a] && s.in_solve[b] &&
          s.num_cross_contacts < static_cast<int>(s.cross_contacts.size())) {
        s.coupled[a] = 1;
        s.coupled[b] = 1;
        CrossContact& x = s.cross_contacts[static_cast<std::size_t>(s.num_cross_contacts++)];
        x.body_a = st.body;
        x.body_b = p.jaw;
        x.weight_normal = 0.0;
        x.weight_isotropic = beta;
        x.normal = Vec3::UnitZ();
        x.r_a = r_a;
        x.r_b = r_b;
      }
    }
  }
}

}  // namespace detail

std::string finalize_grasps(Model& model) {
  const int nb = model.num_bodies();
  for (GraspModel& g : model.grasps) {
    const std::string who = "grasp '" + g.name + "': ";
    for (int k = 0; k < 2; ++k) {
      const int b = g.jaws[static_cast<std::size_t>(k)];
      if (b < 0 || b >= nb) return who + "jaw " + std::to_string(k) + " is not a body";
      const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
      if (bm.anchored) return who + "jaw '" + bm.name + "' is anchored";
      if (bm.sphere_count <= 0) return who + "jaw '" + bm.name + "' has no spheres to touch with";
      g.jaw_joints[static_cast<std::size_t>(k)] = -1;
      for (int j = 0; j < model.num_joints(); ++j) {
        const JointModel& jm = model.joints[static_cast<std::size_t>(j)];
        if (jm.child == b && (jm.type == JointType::kRevolute || jm.type == JointType::kCylindrical))
          g.jaw_joints[static_cast<std::size_t>(k)] = j;
      }
    }
    if (g.jaws[0] == g.jaws[1]) return who + "both jaws are one body";
    if (!(g.close_angle >= 0.0) || !(g.open_angle > g.close_angle) || !std::isfinite(g.open_angle))
      return who + "open_angle must exceed close_angle ≥ 0 (rad), got close " +
             std::to_string(g.close_angle) + ", open " + std::to_string(g.open_angle) +
             ": a grasp would never end or never start";
    if (!(g.stiffness > 0.0) || !std::isfinite(g.stiffness)) return who + "stiffness must be > 0 (N/m)";
    if (!(g.damping >= 0.0) || !std::isfinite(g.damping)) return who + "damping must be ≥ 0 (N·s/m)";
    if (!(g.max_force > 0.0)) return who + "max_force must be > 0 (N)";
    if (!(g.grip_radius > 0.0) || !std::isfinite(g.grip_radius)) return who + "grip_radius must be > 0 (m)";
  }
  return {};
}

}  // namespace numen::core
