/// @file net_scratch.cpp
/// Sizing of the nets' scratch (scratch/net_scratch.hpp).

#include "scratch/net_scratch.hpp"

#include <algorithm>
#include <cstddef>

#include "numen/core/model.hpp"

namespace numen::core {

void SweepSprings::assign(std::size_t n) {
  direction_x.assign(n, 1.0);
  direction_y.assign(n, 0.0);
  direction_z.assign(n, 0.0);
  weight_axial.assign(n, 0.0);
  weight_isotropic.assign(n, 0.0);
  high.assign(n, 0);
}

void NetScratch::resize(const Model& model) {
  const auto n = static_cast<std::size_t>(model.num_nodes());
  const auto nb = n > 0 ? static_cast<std::size_t>(model.num_bodies()) : 0;
  resize_solve(model, n, nb);
  order_springs(model, n);
  reset_resting(model, n);
  resize_contact_search(model, n, nb);
}

void NetScratch::resize_solve(const Model& model, std::size_t n, std::size_t nb) {
  saved.assign(n, NodeState{});
  force.assign(n, Vec3::Zero());
  lever.assign(n, Vec3::Zero());
  node_diagonal.assign(n, 1.0);
  block.assign(n, Mat3::Identity());
  block_inverse.assign(model.joints.empty() ? 0 : n, Mat3::Identity());  // arrowhead only
  spring_block.assign(n, SymmetricBlock{});
  tie_sums.assign(n > 0 ? model.nets.size() : 0, NetTieSums{});
  rhs.assign(n, Vec3::Zero());
  delta.assign(n, Vec3::Zero());
  stage_velocity.assign(n, Vec3::Zero());
  stage_move.assign(n, Vec3::Zero());
  stage_delta.assign(n, Vec3::Zero());
  residual.assign(n, Vec3::Zero());
  precond_residual.assign(n, Vec3::Zero());
  direction.assign(n, Vec3::Zero());
  a_direction.assign(n, Vec3::Zero());
  sweep.assign(n, Vec3::Zero());
  body_schur.assign(nb, Mat6::Identity());
  node_contact_head.assign(model.joints.empty() ? 0 : n, -1);  // arrowhead only
  body_tmp.assign(nb, Vec6::Zero());
}

void NetScratch::order_springs(const Model& model, std::size_t n) {
  const std::size_t num_springs = n > 0 ? model.net_springs.size() : 0;
  // Positions in the sweep order Model::node_sweep_order (reverse Cuthill–McKee per net).
  sweep_position.assign(n, 0);
  sweep_nodes.assign(n, SweepNode{});
  for (std::size_t p = 0; p < n; ++p) {
    const std::int32_t node = model.node_sweep_order[p];
    sweep_position[static_cast<std::size_t>(node)] = static_cast<std::int32_t>(p);
  }
  // Springs by their earlier node in the sweep order (counting sort: stable,
  // so each node's springs stay in Model::net_springs order).
  sweep_springs.assign(num_springs);
  spring_constants.rest_length.assign(num_springs, 0.0);
  spring_constants.stiffness.assign(num_springs, 0.0);
  spring_constants.damping.assign(num_springs, 0.0);
  spring_length.assign(num_springs, 0.0);
  spring_low_begin.assign(n > 0 ? n + 1 : 0, 0);
  spring_slot.assign(num_springs, 0);
  if (n > 0) {
    const auto pos = [&](int node) { return sweep_position[static_cast<std::size_t>(node)]; };
    const auto low = [&](const NetSpring& sp) {
      return static_cast<std::size_t>(std::min(pos(sp.node_a), pos(sp.node_b)));
    };
    for (std::size_t e = 0; e < num_springs; ++e) ++spring_low_begin[low(model.net_springs[e]) + 1];
    for (std::size_t i = 0; i < n; ++i) spring_low_begin[i + 1] += spring_low_begin[i];
    std::vector<std::int32_t> next(spring_low_begin.begin(), spring_low_begin.end() - 1);
    for (std::size_t e = 0; e < num_springs; ++e) {
      const NetSpring& sp = model.net_springs[e];
      const std::int32_t slot = next[low(sp)]++;
      spring_slot[e] = slot;
      const auto j = static_cast<std::size_t>(slot);
      sweep_springs.high[j] = pos(sp.node_a) < pos(sp.node_b) ? sp.node_b : sp.node_a;
      spring_constants.rest_length[j] = sp.rest_length;
      spring_constants.stiffness[j] = sp.stiffness;
      spring_constants.damping[j] = sp.damping;
    }
  }
}

void NetScratch::reset_resting(const Model& model, std::size_t n) {
  // Resting nodes (net_rest.hpp): none yet, every node in the solve.
  rest_count.assign(n, 0);
  rest_flags.assign(n, 0);
  pass_position.assign(n, Vec3::Zero());
  pass_velocity.assign(n, Vec3::Zero());
  pass_stored = false;
  still_flags.assign(n, 0);
  still_force.assign(n, Vec3::Zero());
  still_energy.assign(n, 0.0);
  active_nodes.assign(n, 0);
  active_positions.assign(n, 0);
  pass_positions.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    active_nodes[i] = static_cast<std::int32_t>(i);
    active_positions[i] = static_cast<std::int32_t>(i);
    pass_positions[i] = static_cast<std::int32_t>(i);
  }
  active_count.assign(n > 0 ? model.nets.size() : 0, 0);
  pass_count.assign(active_count.size(), 0);
  for (std::size_t k = 0; k < active_count.size(); ++k) {
    active_count[k] = model.nets[k].node_count;
    pass_count[k] = model.nets[k].node_count;
  }
}

void NetScratch::resize_contact_search(const Model& model, std::size_t n, std::size_t nb) {
  const auto no = n > 0 ? model.obstacles.size() : 0;
  near_obstacles.assign(no, 0);
  obstacle_axis.assign(no, Vec3::UnitZ());
  obstacle_rotation.assign(no, Mat3::Identity());
  near_bodies.assign(nb, 0);
  near_sphere_end.assign(nb, 0);
  std::size_t body_spheres = 0;  // Σ sphere_count: room even if bodies shared a range
  for (const BodyModel& b : model.bodies) body_spheres += static_cast<std::size_t>(b.sphere_count);
  near_spheres.assign(n > 0 ? body_spheres : 0, 0);
  near_order.assign(n > 0 && !model.net_surface_points.empty() ? body_spheres : 0, 0);
  near_key.assign(near_order.size(), 0.0);
  // Room for the largest net's count of `what` (none without nodes).
  const auto largest = [&](int NetModel::*what) {
    std::size_t most = 0;
    for (const NetModel& net : model.nets) most = std::max(most, static_cast<std::size_t>(net.*what));
    return n > 0 ? most : std::size_t{0};
  };
  const std::size_t faces = largest(&NetModel::face_count);
  face_candidates.assign(faces, 0);
  face_lo.assign(faces, Vec3::Zero());
  face_hi.assign(faces, Vec3::Zero());
  node_outcode.assign(faces > 0 ? n : 0, 0);
  const std::size_t fine = largest(&NetModel::surface_face_count);
  surface_candidates.assign(fine, 0);
  surface_lo.assign(fine, Vec3::Zero());
  surface_hi.assign(fine, Vec3::Zero());
  surface_sphere_mask.assign(fine, 0);
  group_candidates.assign(std::max(faces, fine), 0);
  surface_face_slot.assign(n > 0 ? model.net_surface_faces.size() : 0, -1);
  surface_face_stamp.assign(n > 0 ? model.net_surface_faces.size() : 0, 0);
  surface_point_stamp.assign(n > 0 ? model.net_surface_points.size() : 0, 0);
  surface_position.assign(n > 0 ? model.net_surface_points.size() : 0, Vec3::Zero());
  const std::size_t carriers = n > 0 && !model.net_surface_points.empty() ? model.net_faces.size() : 0;
  surface_net_stamp.assign(carriers, 0);
  surface_net_torn.assign(carriers, 0);
  surface_patches_skipped = 0;
  surface_stamp = 0;
  std::size_t patch = 0;
  for (const NetModel& net : model.nets) patch = std::max(patch, net.surface_node_area.size());
  patch_nodes.assign(n > 0 ? patch : 0, 0);
  patch_weights.assign(n > 0 ? patch : 0, 0.0);
  patch_count = 0;
  patch_net = -1;
  patch_at.setZero();
  patch_fine_depth = 0.0;
}

}  // namespace numen::core
