/// @file thread_model.cpp
/// A thread's settings checked and derived, its initial state (thread.hpp).

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "scratch/thread_scratch.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {
namespace {

/// Terms a thread can hold in one step: two contacts per segment, the eyelets, the contacts
/// with tissue, room besides.
int thread_term_capacity(const ThreadModel& t) noexcept {
  return 4 * t.segments + kMaxThreadEyelets + kMaxThreadTissueContacts + 64;
}

std::string check_tie(ThreadTie& tie, const char* key, int num_bodies) {
  std::ostringstream err;
  if (tie.body < -2 || tie.body >= num_bodies) {
    err << key << ".body " << tie.body << " is not a body (0 … " << num_bodies - 1
        << ", −1 the world, −2 free)";
    return err.str();
  }
  if (!tie.point.allFinite()) return std::string(key) + ".point must be finite";
  if (tie.clamped) {
    const double n = tie.direction.norm();
    if (!(n > 0.0) || !std::isfinite(n)) return std::string(key) + ".direction must be non-zero";
    tie.direction /= n;
  }
  return "";
}

}  // namespace

std::string finalize_thread(ThreadModel& t, int num_bodies, int num_materials) {
  std::ostringstream err;
  auto bad = [&](const char* key, double v, const char* rule) {
    err << key << " must be " << rule << " (got " << v << ")";
    return err.str();
  };
  if (!(t.length > 0.0) || !std::isfinite(t.length)) return bad("length", t.length, "> 0");
  if (t.segments < 1) return bad("segments", t.segments, ">= 1");
  if (!(t.radius > 0.0) || !std::isfinite(t.radius)) return bad("radius", t.radius, "> 0");
  if (!(t.young_modulus > 0.0) || !std::isfinite(t.young_modulus))
    return bad("young_modulus", t.young_modulus, "> 0");
  if (!(t.density > 0.0) || !std::isfinite(t.density)) return bad("density", t.density, "> 0");
  if (!(t.damping >= 0.0) || !std::isfinite(t.damping)) return bad("damping", t.damping, ">= 0");
  if (!(t.break_strain > 0.0) || !std::isfinite(t.break_strain))
    return bad("break_strain", t.break_strain, "> 0");
  if (!(t.tissue_friction >= 0.0) || !std::isfinite(t.tissue_friction))
    return bad("tissue_friction", t.tissue_friction, ">= 0");
  if (!(t.self_friction >= 0.0) || !std::isfinite(t.self_friction))
    return bad("self_friction", t.self_friction, ">= 0");
  if (t.material < 0 || t.material >= num_materials)
    return bad("material", t.material, "a material index");
  if (!t.start.allFinite()) return "start must be finite";
  const double dn = t.direction.norm();
  if (!(dn > 0.0) || !std::isfinite(dn)) return "direction must be non-zero";
  t.direction /= dn;
  if (std::string e = check_tie(t.tie_start, "tie_start", num_bodies); !e.empty()) return e;
  if (std::string e = check_tie(t.tie_end, "tie_end", num_bodies); !e.empty()) return e;
  const double area = std::numbers::pi * t.radius * t.radius;
  const double inertia = std::numbers::pi * std::pow(t.radius, 4) / 4.0;
  t.rest_segment = t.length / t.segments;
  t.node_mass = t.density * area * t.rest_segment;
  t.stretch_stiffness = t.young_modulus * area / t.rest_segment;
  t.bend_stiffness = t.young_modulus * inertia / std::pow(t.rest_segment, 3);
  return "";
}

void reset_thread(const ThreadModel& t, ThreadState& s) noexcept {
  for (std::size_t i = 0; i < s.position.size(); ++i) {
    s.position[i] = t.start + (static_cast<double>(i) * t.rest_segment) * t.direction;
    s.velocity[i].setZero();
    s.external_force[i].setZero();
  }
  for (ThreadEyelet& e : s.eyelets) e = ThreadEyelet{};
  s.broken_segment = -1;
  s.eyelets_taken = s.eyelets_let_go = s.eyelets_dropped = 0;
  s.output = ThreadOutput{};
}

void copy_thread_state(const ThreadState& from, ThreadState& to) noexcept {
  const std::size_t n = std::min(from.position.size(), to.position.size());
  std::copy_n(from.position.begin(), n, to.position.begin());
  std::copy_n(from.velocity.begin(), std::min(n, std::min(from.velocity.size(), to.velocity.size())), to.velocity.begin());
  std::copy_n(from.external_force.begin(),
              std::min(n, std::min(from.external_force.size(), to.external_force.size())), to.external_force.begin());
  to.eyelets = from.eyelets;
  to.broken_segment = from.broken_segment;
  to.eyelets_taken = from.eyelets_taken;
  to.eyelets_let_go = from.eyelets_let_go;
  to.eyelets_dropped = from.eyelets_dropped;
  to.output = from.output;
}

void ThreadScratch::resize(const ThreadModel& t, int model_nodes, int graspers) {
  const auto nodes = static_cast<std::size_t>(t.segments + 1);
  band.resize(t.segments + 3);
  terms.assign(static_cast<std::size_t>(thread_term_capacity(t) + 2 * kMaxGraspThreadNodes * graspers),
               ThreadPointTerm{});
  num_terms = 0;
  saved_position.assign(nodes, Vec3::Zero());
  trial_position.assign(nodes, Vec3::Zero());
  trial_velocity.assign(nodes, Vec3::Zero());
  whole_update.assign(nodes + 2, Vec3::Zero());
  sweep_order.resize(static_cast<std::size_t>(t.segments));
  for (int s = 0; s < t.segments; ++s) sweep_order[static_cast<std::size_t>(s)] = s;
  self_pairs.assign(static_cast<std::size_t>(4 * t.segments), ThreadSelfPair{});
  num_self_pairs = 0;
  segment_min.assign(static_cast<std::size_t>(t.segments), Vec3::Zero());
  segment_max.assign(static_cast<std::size_t>(t.segments), Vec3::Zero());
  const auto runs = static_cast<std::size_t>((t.segments + kThreadSegmentRun - 1) / kThreadSegmentRun);
  run_min.assign(runs, Vec3::Zero());
  run_max.assign(runs, Vec3::Zero());
  touched_before.resize(static_cast<std::size_t>(t.segments));
  touched.resize(static_cast<std::size_t>(t.segments));
  forget_touches();
  sweep_axis = 0;
  tissue_hits.assign(nodes, ThreadTissueHit{});
  tissue_order.resize(nodes);
  for (std::size_t i = 0; i < nodes; ++i) tissue_order[i] = static_cast<std::int32_t>(i);
  tissue_key.assign(nodes, 0.0);
  net_node_outcode.assign(static_cast<std::size_t>(model_nodes), 0);
  num_tissue_terms = 0;
}

}  // namespace numen::core
