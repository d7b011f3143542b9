/// @file net_springs.hpp
/// Private: the deformable nets' spring forces (net_springs.cpp).
#pragma once

namespace numen::core {
struct Model;
struct Data;
namespace detail {

/// Adds every net's structural and bending springs' forces to NetScratch::force and twice their
/// elastic energy, Σ k (l − L)², to NetOutput::start_energy, storing each spring's direction,
/// length and implicit weights for linearize_nets(). A still node's force and energy come from
/// its last pass (net_still.hpp: marks them first), to the bit as without. Expects
/// NetScratch::force = gravity + ties on entry. No allocation.
void add_spring_forces(const Model& model, Data& data) noexcept;

}  // namespace detail
}  // namespace numen::core
