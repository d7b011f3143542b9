/// @file net_state.cpp
/// Sizing of the nets' scratch (net_state.hpp).

#include "numen/core/net_state.hpp"

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
  body_schur.assign(nb, Mat6::Identity());
  body_schur_factor.assign(nb, BlockCholesky{});
  body_tmp.assign(nb, Vec6::Zero());
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
