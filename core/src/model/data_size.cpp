/// @file data_size.cpp
/// Bytes of Model and Data by buffer group (data_size.hpp).

#include "numen/core/data_size.hpp"

#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

#include "scratch/data_scratch.hpp"
#include "scratch/thread_scratch.hpp"

namespace numen::core {
namespace {

/// Heap bytes of the given vectors (capacity, not size: what was allocated).
template <class... V>
std::size_t heap(const V&... v) noexcept {
  return ((v.capacity() * sizeof(typename V::value_type)) + ... + 0);
}

}  // namespace

std::size_t DataFootprint::heap_bytes() const noexcept {
  std::size_t s = 0;
  for (const BufferGroupBytes& g : groups) s += g.heap_bytes;
  return s;
}

std::size_t ModelFootprint::heap_bytes() const noexcept {
  std::size_t s = 0;
  for (const BufferGroupBytes& g : groups) s += g.heap_bytes;
  return s;
}

DataFootprint data_footprint(const Data& d) noexcept {
  const DataScratch& scratch = *d.scratch;  // made by make_data(): never null
  const CollisionScratch& c = scratch.collision;
  const SolverScratch& s = scratch.solver;
  const ArticulationScratch& a = scratch.articulation;
  const NetScratch& n = scratch.net;
  DataFootprint f;
  f.sizeof_data = sizeof(Data);
  f.groups[0] = {"bodies", heap(d.bodies, d.applied_wrench, d.body_targets, d.body_feedback,
                                d.body_wrench, d.feedback_group, d.feedback_point, d.grasps, d.thread_reactions)};
  f.groups[1] = {"collision scratch",
                 heap(c.sphere_world, c.sphere_x, c.sphere_y, c.sphere_z, c.sphere_r,
                      c.body_aabb_min, c.body_aabb_max, c.sweep_order, c.near_a, c.near_b,
                      c.entry_stamp, c.pairs, c.pairs_prev)};
  f.groups[2] = {"contact solver scratch", heap(s.contact_terms, s.cross_contacts)};
  f.groups[3] = {"body solver scratch",
                 heap(s.saved_state, s.inertia_world, s.twist0, s.rhs, s.delta, s.residual,
                      s.precond_residual, s.direction, s.a_direction, s.block,
                      s.isotropic_moments, s.block_factor, s.in_solve, s.coupled,
                      s.target_coupled, s.imposed, s.stage_start, s.stage_move, s.stage_delta,
                      s.stage_gyro)};
  f.groups[4] = {"joints", heap(d.joint_prescribed, d.joints, s.joint_rhs, s.joint_y,
                                s.joint_y_correction, s.projected_residual, a.rows, a.known,
                                a.joint_active, a.off_diagonal, a.factor, a.coupling, a.work,
                                a.elimination_parent, a.reroot)};
  f.groups[5] = {
      "nets",
      heap(d.nodes, d.node_contacts, d.nets, n.saved, n.force, n.lever, n.node_diagonal, n.block,
           n.block_inverse, n.spring_block, n.tie_sums, n.rhs, n.delta, n.stage_velocity,
           n.stage_move, n.stage_delta, n.residual,
           n.precond_residual, n.direction, n.a_direction, n.sweep, n.body_schur, n.node_contact_head,
           n.node_contact_next, n.body_tmp,
           n.sweep_position, n.sweep_nodes, n.sweep_springs.direction_x,
           n.sweep_springs.direction_y, n.sweep_springs.direction_z, n.sweep_springs.weight_axial,
           n.sweep_springs.weight_isotropic, n.sweep_springs.high, n.spring_constants.rest_length,
           n.spring_constants.stiffness, n.spring_constants.damping, n.spring_length,
           n.spring_low_begin, n.spring_slot, n.near_obstacles, n.obstacle_axis,
           n.obstacle_rotation, n.near_bodies, n.near_sphere_end, n.near_spheres, n.near_order, n.near_key,
           n.face_candidates, n.face_lo, n.face_hi, n.node_outcode, n.surface_candidates, n.surface_lo,
           n.surface_hi, n.surface_sphere_mask, n.group_candidates, n.surface_face_slot, n.surface_face_stamp,
           n.surface_point_stamp, n.surface_position, n.surface_net_stamp, n.surface_net_torn,
           n.rest_count, n.rest_flags, n.pass_position,
           n.pass_velocity, n.still_flags, n.still_force, n.still_energy, n.active_nodes,
           n.active_positions, n.pass_positions, n.active_count, n.pass_count, n.patch_nodes,
           n.patch_weights)};
  std::size_t threads = heap(d.needles, d.threads, scratch.threads);
  for (const ThreadState& t : d.threads) threads += heap(t.position, t.velocity, t.external_force);
  for (const ThreadScratch& t : scratch.threads)
    threads += heap(t.band.diag, t.band.lower1, t.band.lower2, t.band.rhs, t.terms, t.saved_position,
                    t.trial_position, t.trial_velocity, t.whole_update, t.sweep_order, t.segment_min,
                    t.segment_max, t.run_min, t.run_max, t.touched_before, t.touched, t.self_pairs,
                    t.tissue_hits, t.tissue_order, t.tissue_key, t.net_node_outcode);
  f.groups[6] = {"needles and threads", threads};
  f.groups[7] = {"scratch block", sizeof(DataScratch)};
  return f;
}

ModelFootprint model_footprint(const Model& m) noexcept {
  const StaticSphereGrid& g = m.static_grid;
  const ArticulationTopology& t = m.articulation;
  ModelFootprint f;
  f.sizeof_model = sizeof(Model);
  f.groups[0] = {"bodies", heap(m.bodies, m.body_spheres, m.material_names, m.material_pairs)};
  f.groups[1] = {"obstacles", heap(m.obstacles, m.static_spheres, g.cell_start, g.sphere_index,
                                   g.item_entry, g.item_x, g.item_y, g.item_z, g.item_radius,
                                   g.entries)};
  f.groups[2] = {"joints", heap(m.joints, t.nodes, t.body_node, t.joint_node, t.body_tree)};
  f.groups[3] = {"nets", heap(m.nets, m.net_springs, m.node_rest, m.node_mass, m.node_radius,
                              m.node_net, m.node_sweep_order, m.node_spring_begin, m.node_springs,
                              m.net_faces, m.net_tetrahedra, m.net_surface_points, m.net_surface_faces,
                              m.net_face_surface_begin, m.net_face_surface_faces,
                              m.net_face_surface_cluster, m.net_surface_clusters)};
  std::size_t meshes = heap(m.meshes);
  for (const MeshShape& s : m.meshes) meshes += s.memory_bytes();
  f.groups[4] = {"meshes", meshes};
  return f;
}

}  // namespace numen::core
