/// @file net_state.cpp
/// Sizing of the nets' scratch (net_state.hpp).

#include "numen/core/net_state.hpp"

#include <algorithm>

#include "numen/core/model.hpp"

namespace numen::core {

void NetScratch::resize(const Model& model) {
  const auto n = static_cast<std::size_t>(model.num_nodes());
  const auto nb = n > 0 ? static_cast<std::size_t>(model.num_bodies()) : 0;
  saved.assign(n, NodeState{});
  force.assign(n, Vec3::Zero());
  lever.assign(n, Vec3::Zero());
  springs.assign(n > 0 ? model.net_springs.size() : 0, SpringTerm{});
  for (std::size_t e = 0; e < springs.size(); ++e) {
    springs[e].node_a = model.net_springs[e].node_a;
    springs[e].node_b = model.net_springs[e].node_b;
  }
  node_diagonal.assign(n, 1.0);
  block.assign(n, Mat3::Identity());
  block_inverse.assign(n, Mat3::Identity());
  rhs.assign(n, Vec3::Zero());
  delta.assign(n, Vec3::Zero());
  residual.assign(n, Vec3::Zero());
  precond_residual.assign(n, Vec3::Zero());
  direction.assign(n, Vec3::Zero());
  a_direction.assign(n, Vec3::Zero());
  sweep.assign(n, Vec3::Zero());
  body_schur.assign(nb, Mat6::Identity());
  body_tmp.assign(nb, Vec6::Zero());
  // Springs by their smaller and by their larger node (counting sort: stable,
  // so each node's springs stay in Model::net_springs order).
  const auto group = [&](bool high, std::vector<std::int32_t>& begin, std::vector<std::int32_t>& index) {
    begin.assign(n > 0 ? n + 1 : 0, 0);
    index.assign(springs.size(), 0);
    if (n == 0) return;
    const auto key = [&](const SpringTerm& t) {
      return static_cast<std::size_t>(high ? std::max(t.node_a, t.node_b) : std::min(t.node_a, t.node_b));
    };
    for (const SpringTerm& t : springs) ++begin[key(t) + 1];
    for (std::size_t i = 0; i < n; ++i) begin[i + 1] += begin[i];
    std::vector<std::int32_t> next(begin.begin(), begin.end() - 1);
    for (std::size_t e = 0; e < springs.size(); ++e)
      index[static_cast<std::size_t>(next[key(springs[e])]++)] = static_cast<std::int32_t>(e);
  };
  group(false, spring_low_begin, spring_low);
  group(true, spring_high_begin, spring_high);
  const auto no = n > 0 ? model.obstacles.size() : 0;
  near_obstacles.assign(no, 0);
  obstacle_axis.assign(no, Vec3::UnitZ());
  obstacle_rotation.assign(no, Mat3::Identity());
  near_bodies.assign(nb, 0);
  near_sphere_end.assign(nb, 0);
  std::size_t body_spheres = 0;  // Σ sphere_count: room even if bodies shared a range
  for (const BodyModel& b : model.bodies) body_spheres += static_cast<std::size_t>(b.sphere_count);
  near_spheres.assign(n > 0 ? body_spheres : 0, 0);
}

}  // namespace numen::core
