#pragma once
/// @file net_rest.hpp
/// Private to numen::core (core/src/net; tests reach it through numen_core_internal).
/// Resting nodes of an organ's net (docs/organs.md, "Resting nodes"): the sleeping
/// (deactivation) of rigid-body engines — Bullet's activation states, PhysX's sleep
/// threshold — applied node by node to a deformable net on an anchored body. A node that
/// has been quiet for kRestSteps steps in a row — speed at most NetModel::rest_speed v_r,
/// explicit force at most the rest force f_r (below), no node contact of any kind (candidate,
/// look-ahead, grasp) — and whose neighbours (every node it shares a spring with) are quiet
/// as long, rests: from the next step it is held where it is with a zero velocity, and the
/// step solves the same linear system restricted to the other nodes, the resting ones as a
/// Dirichlet boundary (Δv = 0: their columns meet zero, their rows are left out). The force
/// pass covers every node (the energies, the tie wrench and the wake test are exact), taking
/// the still ones' from its last pass (net_still.hpp); the springs' linearisation, the node
/// rows' assembly and the solve run over the nodes in the solve (NetScratch::active_*) and the
/// springs that touch one.
///
/// A resting node wakes, in the step where it happens and before that step's linearisation,
/// when its force exceeds f_r, a node contact reaches it, or a neighbour stops being quiet.
/// The rest force is the force that would change the node's speed by v_r in one step, the node
/// alone on its tie (the look-ahead's estimate, net_forces.cpp):
///   f_r,i = v_r (m_i + h γ_tie + h² k_tie) / h.
/// Held with a velocity below v_r dropped: the kinetic energy given up is below ½ m_i v_r² per
/// node (3.2e-14 J for a 70 mg node at the default 3e-5 m/s).
///
/// Only nets on an anchored body (BodyModel::anchored, whose anchors never move) with
/// rest_speed > 0, and only with the linearly implicit Euler or the trapezoidal rule (one
/// linearised solve a step); every other net keeps every node in the solve. The passes over a
/// node's neighbours go through the springs of the nodes that move (Model::node_springs).

#include <cstddef>
#include <cstdint>

#include "scratch/net_scratch.hpp"
#include "numen/core/model.hpp"

namespace numen::core {

struct Data;

namespace detail {

/// Consecutive quiet steps a node and its neighbours need before it rests.
inline constexpr std::uint8_t kRestSteps = 10;

/// Whether `net`'s nodes may rest in `model` (see file comment; and the model's per-node spring
/// lists, Model::node_springs, made by finalize_model(), are there).
bool net_can_rest(const Model& model, const NetModel& net) noexcept;

/// Each node's neighbours, through its springs in Model::node_springs (made by
/// finalize_model()). Raw pointers: the passes store through std::uint8_t*, which may alias the
/// vectors' own pointers and would make them reloaded per spring.
struct NodeNeighbours {
  const std::int32_t* spring_begin;  ///< Model::node_spring_begin.
  const std::int32_t* springs;       ///< Model::node_springs.
  const NetSpring* net_springs;      ///< Model::net_springs.
  explicit NodeNeighbours(const Model& model) noexcept
      : spring_begin(model.node_spring_begin.data()),
        springs(model.node_springs.data()),
        net_springs(model.net_springs.data()) {}
  /// Calls f(j) for the other node j of each spring at node v, in Model::node_springs order.
  template <class F>
  void for_each(int v, F f) const noexcept {
    const auto i = static_cast<std::size_t>(v);
    for (std::int32_t q = spring_begin[i]; q < spring_begin[i + 1]; ++q) {
      const NetSpring& e = net_springs[springs[q]];
      f(static_cast<std::size_t>(e.node_a == v ? e.node_b : e.node_a));
    }
  }
};

/// Holds the nodes found eligible at the last step's update_resting_nodes(): a zero velocity,
/// and (newly resting) zero entries in the solve's node vectors (the warm start and the CG
/// vectors the restricted sweeps read). Called at the start of compute_net_forces(), before
/// any force is computed. No allocation.
void hold_resting_nodes(const Model& model, Data& data) noexcept;

/// After the force pass and the node contacts (end of compute_net_forces()): counts each
/// node's quiet steps (NetScratch::rest_count), wakes the resting nodes that are no longer
/// eligible, marks those eligible for the next step, and rebuilds the lists of the nodes in
/// the solve (NetScratch::active_nodes, active_positions, pass_positions) and
/// NetOutput::resting_nodes. No allocation.
void update_resting_nodes(const Model& model, Data& data) noexcept;

/// Calls f(i) for every node i in the solve (NetScratch::active_nodes), net by net, each in
/// ascending order: every node when none rests.
template <class F>
[[gnu::always_inline]] inline void for_active_nodes(const Model& model, const NetScratch& s,
                                                    F&& f) noexcept {
  for (std::size_t n = 0; n < model.nets.size(); ++n) {
    const NetModel& net = model.nets[n];
    const int end = s.active_count[n];
    if (end == net.node_count) {  // every node in the solve: the contiguous loop (vectorised)
      for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v)
        f(static_cast<std::size_t>(v));
      continue;
    }
    const std::int32_t* active = s.active_nodes.data() + net.node_begin;
    for (int a = 0; a < end; ++a) f(static_cast<std::size_t>(active[a]));
  }
}

}  // namespace detail
}  // namespace numen::core
