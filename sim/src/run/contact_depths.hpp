#pragma once
/// @file contact_depths.hpp
/// The deepest contacts of a run's measurements (run_measurements.cpp, target_measurement.cpp,
/// admittance_run.cpp):
/// the tool's as the step found them and the target's on a ghost Data. Depths in m.

#include <algorithm>
#include <cstddef>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::sim::detail {

/// Deepest contact (m) involving `body` among data's contacts; 0 if none.
/// `count` receives their number, `deepest_index` the index of the deepest (unchanged if none).
inline double deepest_contact_of(const core::Data& data, int body, int* count = nullptr,
                          int* deepest_index = nullptr) {
  double deepest = 0.0;
  int n = 0;
  for (int i = 0; i < data.num_contacts; ++i) {
    const core::Contact& c = data.contacts[static_cast<std::size_t>(i)];
    if (c.body_a == body || c.body_b == body) {
      if (c.depth > deepest && deepest_index) *deepest_index = i;
      deepest = std::max(deepest, c.depth);
      ++n;
    }
  }
  if (count) *count = n;
  return deepest;
}

/// Deepest node contact (m) of the nets whose rigid component belongs to
/// articulation `tree`; 0 if none. `count` receives their number.
inline double deepest_node_contact_of_tree(const core::Model& model, const core::Data& data, int tree,
                                    int* count) {
  double deepest = 0.0;
  int n = 0;
  for (int i = 0; i < data.num_node_contacts; ++i) {
    const core::NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    const int net = model.node_net[static_cast<std::size_t>(c.node)];
    const int body = model.nets[static_cast<std::size_t>(net)].body;
    if (model.articulation.body_tree[static_cast<std::size_t>(body)] != tree) continue;
    deepest = std::max(deepest, c.depth);
    ++n;
  }
  if (count) *count = n;
  return deepest;
}

/// Deepest node contact (m) of the nets of other bodies (an organ's, on an anchored body) with
/// the bodies of articulation `tree` (the tool pushing the organ); 0 if none. `count` receives
/// their number.
inline double deepest_tool_contact_on_nets(const core::Model& model, const core::Data& data, int tree,
                                    int* count) {
  double deepest = 0.0;
  int n = 0;
  const std::vector<int>& tree_of = model.articulation.body_tree;
  for (int i = 0; i < data.num_node_contacts; ++i) {
    const core::NodeContact& c = data.node_contacts[static_cast<std::size_t>(i)];
    if (c.body_b < 0 || tree_of[static_cast<std::size_t>(c.body_b)] != tree) continue;
    const int net = model.node_net[static_cast<std::size_t>(c.node)];
    if (tree_of[static_cast<std::size_t>(model.nets[static_cast<std::size_t>(net)].body)] == tree)
      continue;
    deepest = std::max(deepest, c.depth);
    ++n;
  }
  if (count) *count = n;
  return deepest;
}

}  // namespace numen::sim::detail
