/// @file capacity.cpp
/// Per-model contact capacities (capacity.hpp).

#include "numen/core/capacity.hpp"

#include "numen/core/model.hpp"

namespace numen::core {
namespace {

/// True if two bodies lie in different articulations (bodies of one
/// articulation never collide with each other: ArticulationTopology::body_tree).
bool body_pair_can_collide(const Model& model) noexcept {
  const std::vector<int>& tree = model.articulation.body_tree;
  int first_tree = -1;
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const int t = b < tree.size() ? tree[b] : static_cast<int>(b);
    if (first_tree < 0) first_tree = t;
    else if (t != first_tree) return true;
  }
  return false;
}

}  // namespace

int contact_capacity(const Model& model) noexcept {
  return !model.obstacles.empty() || body_pair_can_collide(model)
             ? kMaxContacts
             : 0;
}

int cross_contact_capacity(const Model& model) noexcept {
  return body_pair_can_collide(model) ? kMaxContacts : 0;
}

}  // namespace numen::core
