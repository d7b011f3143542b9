/// @file net_rest.cpp
/// Resting nodes of an organ's net (net/net_rest.hpp; docs/organs.md, "Resting nodes").

#include "net/net_rest.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "scratch/data_scratch.hpp"
#include "net/net_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core::detail {
namespace {

/// NetScratch::rest_flags bits.
constexpr std::uint8_t kRestingBit = 1;  ///< Held this step (out of the solve).
constexpr std::uint8_t kEligibleBit =
    2;  ///< Quiet, with quiet neighbours: rests from the next step.
constexpr std::uint8_t kBoundaryBit = 4;  ///< Resting, with a neighbour in the solve.

/// Zeroes node i's entries in the solve's node vectors: its Δv (the warm start, which the
/// restricted sweeps read as the Dirichlet value) and the CG vectors whose entries of a node
/// out of the solve the sweeps and products read (net_sweeps.cpp, net_arrowhead.cpp).
void clear_solve_entries(NetScratch& s, std::size_t i) noexcept {
  s.delta[i].setZero();
  s.residual[i].setZero();
  s.precond_residual[i].setZero();
  s.direction[i].setZero();
  s.a_direction[i].setZero();
  s.sweep[i].setZero();
}

/// The quiet steps of net `net`'s nodes (NetScratch::rest_count), from their velocity and
/// explicit force at the step's start (the contacts are counted by the caller).
void count_quiet_steps(const Model& model, Data& data, const NetModel& net) noexcept {
  NetScratch& s = data.scratch->net;
  const double h = model.dt;
  const double v2 = net.rest_speed * net.rest_speed;
  const double tie = h * net.tie_damping + h * h * net.tie_stiffness;  // kg
  const double scale = net.rest_speed / h;                             // f_r,i = scale (m_i + tie)
  // kScaled: the ties per node (NetModel::tie_scale); else every tie alike, s = 1 folded away.
  const auto count = [&]<bool kScaled>() {
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      const double ts = kScaled ? net.tie_scale[static_cast<std::size_t>(v - net.node_begin)] : 1.0;
      const double fr = scale * (model.node_mass[i] + ts * tie);
      const bool quiet =
          data.nodes[i].velocity.squaredNorm() <= v2 && s.force[i].squaredNorm() <= fr * fr;
      std::uint8_t& c = s.rest_count[i];
      c = quiet ? static_cast<std::uint8_t>(std::min<int>(c + 1, kRestSteps)) : std::uint8_t{0};
    }
  };
  if (net.tie_scale.empty())
    count.template operator()<false>();
  else
    count.template operator()<true>();
}

/// Net k's eligibility (quiet for kRestSteps, and its neighbours too), its resting nodes
/// woken where they are no longer eligible, the boundary, and its lists of the nodes in the
/// solve; returns its resting nodes' count.
int select_resting_nodes(const Model& model, Data& data, std::size_t k) noexcept {
  NetScratch& s = data.scratch->net;
  const NetModel& net = model.nets[k];
  const std::uint8_t* count = s.rest_count.data();
  std::uint8_t* flags = s.rest_flags.data();
  const std::int32_t* order = model.node_sweep_order.data();
  const int begin = net.node_begin, end = net.node_begin + net.node_count;
  // Eligible: quiet long enough, and every neighbour too. A node not calm takes the bit from
  // each neighbour through its own springs (Model::node_springs): most of an organ is calm, so
  // this passes over the springs of the few nodes that move (the same bits as a pass over every
  // spring; one branch per node, none per spring).
  // Where fewer nodes are calm than not (a net pressed as a whole: a material organ under the
  // tool), the calm ones look at their neighbours instead — the same bits over fewer springs.
  const NodeNeighbours neighbours(model);
  int calm_count = 0;
  for (int v = begin; v < end; ++v) {
    const auto i = static_cast<std::size_t>(v);
    const bool calm = count[i] >= kRestSteps;
    calm_count += calm;
    flags[i] = static_cast<std::uint8_t>((flags[i] & kRestingBit) | (calm ? kEligibleBit : 0));
  }
  if (2 * calm_count >= net.node_count) {
    for (int v = begin; v < end; ++v) {
      if (count[static_cast<std::size_t>(v)] >= kRestSteps) continue;
      neighbours.for_each(
          v, [&](std::size_t j) { flags[j] &= static_cast<std::uint8_t>(~kEligibleBit); });
    }
  } else if (calm_count > 0) {
    for (int v = begin; v < end; ++v) {
      if (count[static_cast<std::size_t>(v)] < kRestSteps) continue;
      bool all_calm = true;
      neighbours.for_each(v, [&](std::size_t j) { all_calm &= count[j] >= kRestSteps; });
      if (!all_calm) flags[static_cast<std::size_t>(v)] &= static_cast<std::uint8_t>(~kEligibleBit);
    }
  }
  // Woken: a resting node no longer eligible (its force, a contact, a neighbour).
  int resting = 0;
  for (int v = begin; v < end; ++v) {
    const auto i = static_cast<std::size_t>(v);
    flags[i] &= static_cast<std::uint8_t>(((flags[i] & kEligibleBit) >> 1) | ~kRestingBit);
    resting += flags[i] & kRestingBit;
  }
  // Boundary: resting with a neighbour in the solve: a node in the solve sets the bit (its
  // neighbour's kRestingBit shifted) on each resting neighbour, through its own springs; where
  // fewer rest than not, each resting node looks at its neighbours instead (the same bits).
  static_assert(kRestingBit << 2 == kBoundaryBit);
  if (2 * resting >= net.node_count) {
    for (int v = begin; v < end; ++v) {
      if (flags[static_cast<std::size_t>(v)] & kRestingBit) continue;
      neighbours.for_each(v, [&](std::size_t j) {
        flags[j] |= static_cast<std::uint8_t>((flags[j] & kRestingBit) << 2);
      });
    }
  } else if (resting > 0) {
    for (int v = begin; v < end; ++v) {
      if (!(flags[static_cast<std::size_t>(v)] & kRestingBit)) continue;
      bool any_active = false;
      neighbours.for_each(v, [&](std::size_t j) { any_active |= !(flags[j] & kRestingBit); });
      if (any_active) flags[static_cast<std::size_t>(v)] |= kBoundaryBit;
    }
  }
  // The lists, in the net's own slots [begin, begin + count).
  int active = 0, pass = 0;
  for (int p = begin; p < end; ++p) {
    const std::uint8_t f = flags[static_cast<std::size_t>(order[p])];
    if (!(f & kRestingBit)) s.active_positions[static_cast<std::size_t>(begin + active++)] = p;
    if (!(f & kRestingBit) || (f & kBoundaryBit))
      s.pass_positions[static_cast<std::size_t>(begin + pass++)] = p;
  }
  int nodes = 0;
  for (int v = begin; v < end; ++v)
    if (!(flags[static_cast<std::size_t>(v)] & kRestingBit))
      s.active_nodes[static_cast<std::size_t>(begin + nodes++)] = v;
  s.active_count[k] = active;
  s.pass_count[k] = pass;
  return net.node_count - active;
}

}  // namespace

bool net_can_rest(const Model& model, const NetModel& net) noexcept {
  return net.rest_speed > 0.0 && model.bodies[static_cast<std::size_t>(net.body)].anchored &&
         (model.integrator == Integrator::kLinearlyImplicitEuler ||
          model.integrator == Integrator::kTrapezoidal) &&
         node_springs_indexed(model);
}

void hold_resting_nodes(const Model& model, Data& data) noexcept {
  NetScratch& s = data.scratch->net;
  for (const NetModel& net : model.nets) {
    if (!net_can_rest(model, net)) continue;
    for (int v = net.node_begin; v < net.node_begin + net.node_count; ++v) {
      const auto i = static_cast<std::size_t>(v);
      std::uint8_t& f = s.rest_flags[i];
      if (f & kEligibleBit) {
        if (!(f & kRestingBit)) clear_solve_entries(s, i);
        f = kRestingBit | kEligibleBit;
        data.nodes[i].velocity.setZero();
      } else {
        f = 0;
      }
    }
  }
}

void update_resting_nodes(const Model& model, Data& data) noexcept {
  NetScratch& s = data.scratch->net;
  bool any = false;
  for (const NetModel& net : model.nets) {
    if (!net_can_rest(model, net)) continue;
    count_quiet_steps(model, data, net);
    any = true;
  }
  if (!any) return;
  // Any node contact (a candidate, a look-ahead, a grasp's held node) keeps its node awake.
  const int nc = node_contact_count(data);
  for (int c = 0; c < nc; ++c)
    s.rest_count[static_cast<std::size_t>(data.node_contacts[static_cast<std::size_t>(c)].node)] =
        0;
  for (std::size_t k = 0; k < model.nets.size(); ++k)
    if (net_can_rest(model, model.nets[k]))
      data.nets[k].resting_nodes = select_resting_nodes(model, data, k);
}

}  // namespace numen::core::detail
