/// @file thread_tissue.cpp
/// A thread through tissue (thread.hpp, "Through tissue"; docs/thread.md "The thread through
/// tissue"): the puncture points its needle lets go past the tail taken over as eyelets on the
/// net's material points, those eyelets moved with the net's nodes, and their forces given back
/// to the nodes as held node springs in the nets' implicit step.

#include <array>
#include <cstddef>

#include "net/net_terms.hpp"
#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {
namespace {

/// Whether `face` indexes Model::net_faces.
bool valid_face(const Model& model, int face) noexcept {
  return face >= 0 && static_cast<std::size_t>(face) < model.net_faces.size();
}

}  // namespace

void take_over_punctures(const Model& model, const Data& data, const ThreadModel& thread,
                         ThreadState& state) noexcept {
  if (thread.needle < 0 || static_cast<std::size_t>(thread.needle) >= data.needles.size()) return;
  if (state.broken_segment == 0) return;  // cut at the needle: the rest of it does not follow
  const NeedleModel& n = model.needles[static_cast<std::size_t>(thread.needle)];
  const NeedleState& ns = data.needles[static_cast<std::size_t>(thread.needle)];
  for (int r = 0; r < ns.num_tail_releases; ++r) {
    const NeedlePuncture& p = ns.tail_releases[static_cast<std::size_t>(r)];
    ThreadEyelet* free = nullptr;
    for (ThreadEyelet& e : state.eyelets)
      if (!e.active) {
        free = &e;
        break;
      }
    if (free == nullptr) {
      ++state.eyelets_dropped;
      continue;
    }
    *free = ThreadEyelet{};
    free->active = true;
    free->face = p.face;
    free->weights = p.weights;
    free->position = p.position;
    free->friction = thread.tissue_friction;
    free->stiffness = n.tie_stiffness;  // the tissue's hold across, as on the needle
    free->drag = n.friction;            // and its viscous friction along
    ++state.eyelets_taken;
  }
}

void place_tissue_eyelets(const Model& model, const Data& data, ThreadState& state) noexcept {
  for (ThreadEyelet& e : state.eyelets) {
    if (!e.active || e.face < 0) continue;
    if (!valid_face(model, e.face)) {  // not a triangle of this model's nets: nothing to follow
      e.active = false;
      continue;
    }
    const std::array<int, 3>& f = model.net_faces[static_cast<std::size_t>(e.face)];
    e.position.setZero();
    e.velocity.setZero();
    for (int m = 0; m < 3; ++m) {
      const NodeState& node = data.nodes[static_cast<std::size_t>(f[static_cast<std::size_t>(m)])];
      e.position += e.weights[m] * node.position;
      e.velocity += e.weights[m] * node.velocity;
    }
  }
}

void tie_tissue_eyelets(const Model& model, Data& data, const ThreadState& state,
                        const ThreadScratch& scratch) noexcept {
  for (std::size_t k = 0; k < state.eyelets.size(); ++k) {
    const ThreadEyelet& e = state.eyelets[k];
    const ThreadEyeletTerm& t = scratch.eyelet_terms[k];
    if (!e.active || e.face < 0 || !t.set || !valid_face(model, e.face)) continue;
    const Vec3 e1 = t.axis.unitOrthogonal();
    const std::array<Vec3, 3> axes{t.axis, e1, t.axis.cross(e1)};
    // On the nodes: the eyelet's force on the thread, reversed, by their weights; stiff across
    // the thread towards its point, damped along it (the friction), the point as given.
    detail::write_face_springs(model, data, e.face, e.weights, axes, {0.0, t.stiffness, t.stiffness},
                               {t.damping, 0.0, 0.0}, -t.force, -1, t.point, Vec3::Zero(), t.velocity,
                               data.num_node_contacts + data.num_node_grasp_springs + data.num_node_needle_ties,
                               data.num_node_thread_ties);
  }
}

}  // namespace numen::core
