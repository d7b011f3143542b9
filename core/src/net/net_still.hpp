#pragma once
/// @file net_still.hpp
/// Private to numen::core (core/src/net; tests reach it through numen_core_internal).
/// Still neighbourhoods of an organ's net: the force pass's reuse of its own last result.
///
/// A node's force after the springs (gravity, its tie and every spring at it, summed in the
/// pass's fixed order) and its springs' energy term are functions of its own state and its
/// neighbours' (position and velocity), of its anchored body (which never moves) and of
/// constants. A node **still** at a force pass — its state and every neighbour's (every node it
/// shares a spring with) equal, bit for bit, to what they were at the net's last force pass —
/// therefore has last pass's force and energy to the bit. The resting nodes of net_rest.hpp
/// are held with a zero velocity where they are: the inner ones of a resting region are still
/// from their second resting step on, and on the shipped organ most of the net is (docs/organs.md,
/// "Resting nodes"). The springs' pass (net_springs.cpp) takes a still node's force and energy from
/// its last pass, and skips the springs from a still node to still later nodes altogether (their
/// directions and lengths are those stored by the pass that last computed them, from the same
/// states): the same forces, energies, directions and lengths to the bit as computing them.
///
/// Only the nets whose nodes may rest (net_can_rest(): an anchored body, one linearised solve a
/// step); every other net's nodes are never still. The comparison is of the states themselves
/// (not of the resting flags), so anything that moves a node between passes (a rollback, a
/// caller editing Data::nodes) makes it and its neighbours not still. The model's constants
/// (masses, rest anchors, ties, gravity, the springs' constants copied by make_data()) are the
/// model's between make_data() and the run's end, as the rest of the step expects.

#include <cstdint>

#include "numen/core/model.hpp"

namespace numen::core {

struct Data;

namespace detail {

/// NetScratch::still_flags bits.
inline constexpr std::uint8_t kStateChangedBit = 1;  ///< Its state differs from the last pass's.
inline constexpr std::uint8_t kNearChangeBit = 2;    ///< It or a neighbour changed: not still.

/// Marks each node's NetScratch::still_flags (0: still) against the states stored at the last
/// force pass (NetScratch::pass_position, pass_velocity; none before the first pass after
/// make_data(): no node still), and stores the current ones. Nodes of a net that cannot rest
/// get both bits. Returns whether any net's nodes may be still (a net that can rest): the
/// force pass then keeps every node's force and energy for the next pass (a pass that did not
/// would leave them stale). Call after hold_resting_nodes(), once per force pass. No
/// allocation.
bool mark_still_nodes(const Model& model, Data& data) noexcept;

}  // namespace detail
}  // namespace numen::core
