#pragma once
/// @file net_scratch.hpp
/// Private to numen::core (core/src/scratch; tests and benchmarks reach it through
/// numen_core_internal): the scratch of the nets' force stage, collision stage and
/// coupled implicit solve (net_forces.hpp, net_collision.hpp, net_solve.hpp) — the
/// springs' linearisation in the sweep order and the solve's vectors. Held in
/// DataScratch (data_scratch.hpp) behind Data::scratch; sized once by make_data(),
/// empty for a model without nets.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "numen/core/net_state.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// Linearisation of one spring for the implicit solve (a copy of one entry
/// of SweepSprings; tests and diagnostics): the spring's contribution to
/// A = M − hD − h²K is W_e = α d̂d̂ᵀ + β I on the two diagonal blocks and −W_e
/// off the diagonal.
struct SweepSpring {
  /// d̂ = d / l, d = x_high − x_low (from the spring's node earlier in the
  /// sweep order to the later one, Model::node_sweep_order) at the step's
  /// start; a spring of zero length keeps its last direction.
  Vec3 direction = Vec3::UnitX();
  double weight_axial = 0.0;       ///< α = h γ + h² k − β (kg = N·s²/m).
  double weight_isotropic = 0.0;   ///< β = h² k max(0, 1 − L/l) (kg).
  std::int32_t high = 0;           ///< The spring's node later in the sweep order (global index).
};

/// The springs' linearisation in the order of the SSOR sweeps
/// (NetScratch::sweep_springs; net_solve.hpp), as a structure of arrays —
/// one array per component, so that the sweeps load two consecutive springs'
/// components with one SIMD load and handle two springs at once. Written by
/// compute_net_forces() (directions) and linearize_nets() (the weights, linearly
/// implicit integrators); the fields are those of SweepSpring.
struct SweepSprings {
  std::vector<double> direction_x, direction_y, direction_z;  ///< d̂ (unit, world).
  std::vector<double> weight_axial;      ///< α (kg).
  std::vector<double> weight_isotropic;  ///< β (kg).
  std::vector<std::int32_t> high;        ///< Node later in the sweep order (global index).
  /// Number of springs.
  std::size_t size() const noexcept { return high.size(); }
  /// Spring j (< size()) as one value.
  SweepSpring operator[](std::size_t j) const noexcept {
    return SweepSpring{Vec3(direction_x[j], direction_y[j], direction_z[j]), weight_axial[j],
                       weight_isotropic[j], high[j]};
  }
  /// Sizes every array for `n` springs (direction d̂ = x, weights 0, high 0). Allocates.
  void assign(std::size_t n);
};

/// The springs' constants (NetSpring) copied in the sweep order by
/// NetScratch::resize(), one array each, so that the force pass reads them
/// in order, two springs per load.
struct SweepSpringConstants {
  std::vector<double> rest_length;  ///< L (m).
  std::vector<double> stiffness;    ///< k (N/m).
  std::vector<double> damping;      ///< γ (N·s/m).
};

/// A node's part of the SSOR sweeps (net_solve.hpp), stored by sweep
/// position (NetScratch::sweep_nodes) so that the sweeps read it in order:
/// A_kk⁻¹ as its 6 distinct entries (it is symmetric) and the lever arm.
/// Written by build_net_system() (model without joints).
struct SweepNode {
  /// A_kk⁻¹ (1/kg): entries (0,0), (0,1), (0,2), (1,1), (1,2), (2,2).
  double inverse[6] = {1.0, 0.0, 0.0, 1.0, 0.0, 1.0};
  Vec3 lever = Vec3::Zero();  ///< ρ = R_b r of the node (m, world), as NetScratch::lever.
};

/// A symmetric 3×3 matrix as its 6 distinct entries (upper triangle, row by
/// row), so that a sum of symmetric blocks adds 6 entries instead of 9 and
/// two consecutive entries in one SIMD operation.
struct SymmetricBlock {
  /// Entries (0,0), (0,1), (0,2), (1,1), (1,2), (2,2).
  double entry[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
};

/// A net's sums over its nodes i of the tie terms that enter its rigid
/// component's rows of the implicit system (net_solve.hpp): Σ ρ_i, Σ ρ_i ρ_iᵀ
/// and Σ J_iᵀ (v_i − v_a,i) with J_i = [I, −[ρ_i]×], ρ_i = R_b r_i (m, world)
/// and v_a,i the anchor's velocity at the step's start. Written by
/// linearize_nets() (linearly implicit integrators), read by add_net_body_terms().
struct NetTieSums {
  Vec3 lever_sum = Vec3::Zero();     ///< Σ ρ_i (m).
  Mat3 lever_moment = Mat3::Zero();  ///< Σ ρ_i ρ_iᵀ (m²), full and exactly symmetric.
  Vec6 relative = Vec6::Zero();      ///< Σ J_iᵀ (v_i − v_a,i): (Σ Δv (m/s), Σ ρ × Δv (m²/s)).
};

/// Scratch of the nets' force stage and of the coupled implicit solve, sized
/// once by resize() (everything empty without nets).
struct NetScratch {
  std::vector<NodeState> saved;     ///< Node states before the step (non-finite rollback).
  std::vector<Vec3> force;          ///< Explicit force on each node this step (N).
  std::vector<Vec3> lever;          ///< ρ = R_b r: anchor − COM of the rigid component (m, world).
  std::vector<double> node_diagonal;  ///< m_i + c_tie: the isotropic part of A_ii (kg).
  std::vector<Mat3> block;          ///< A_ii: 3×3 diagonal block of each node (all terms).
  /// Σ_e W_e over the springs e at each node (the springs' part of A_ii, kg),
  /// summed by linearize_nets() and added into `block` by build_net_system().
  std::vector<SymmetricBlock> spring_block;
  std::vector<NetTieSums> tie_sums;  ///< Per net (Model::nets order): the ties' sums.
  /// A_ii⁻¹ (the arrowhead preconditioner): sized by resize() and written by
  /// build_net_system() for a model with joints only, empty without (the
  /// sweeps read sweep_nodes).
  std::vector<Mat3> block_inverse;
  std::vector<Vec3> rhs;            ///< b of the node rows.
  std::vector<Vec3> delta;          ///< Δv of the node rows (m/s); warm start of the next step.
  // TR-BDF2 (integrator_tr_bdf2.cpp), per node: v0, the trapezoidal stage's displacement
  // Δx_γ = γh (v0 + Δv½) (m) and velocity change Δv_γ (m/s).
  std::vector<Vec3> stage_velocity, stage_move, stage_delta;
  /// PCG vectors of the nodes. Without joints (Eisenstat's CG, net_solve.hpp):
  /// w, t, q and K q; with joints: r, z, p and A p.
  std::vector<Vec3> residual, precond_residual, direction, a_direction;
  std::vector<Vec3> sweep;          ///< Nodes: g = q + (D − 2D̃) t of the Eisenstat product.
  std::vector<Mat6> body_schur;     ///< Per body: Schur block S_b of the arrowhead preconditioner (joints).
  /// The arrowhead preconditioner's node contacts grouped by node (joints; build_net_system()):
  /// per node the last of its body-coupling contacts in Data::node_contacts, or -1 (reset to -1
  /// after use), and per contact the node's previous one, or -1. For a model with joints only:
  /// the heads sized by resize(), the links by make_data() (Data::node_contacts' capacity).
  std::vector<std::int32_t> node_contact_head, node_contact_next;
  std::vector<Vec6> body_tmp;       ///< Per body: reduced residual (joints) or g (no joints).
  /// The SSOR sweeps (net_solve.hpp) visit the nodes in the order
  /// Model::node_sweep_order (reverse Cuthill–McKee per net, computed once by
  /// finalize_model()); sweep_position is its inverse: node -> position.
  std::vector<std::int32_t> sweep_position;
  /// Per sweep position p: A_kk⁻¹ and ρ of node Model::node_sweep_order[p].
  std::vector<SweepNode> sweep_nodes;
  /// The springs in the order of the SSOR sweeps, grouped by their earlier
  /// node in Model::node_sweep_order ("low"; ascending positions; Model::net_springs
  /// order within a node); the other node is SweepSprings::high. Position
  /// p's springs are [spring_low_begin[p], spring_low_begin[p + 1]).
  /// compute_net_forces() (forces) and linearize_nets() (linearisation) go
  /// through them in that order; the backward sweep gathers them into the
  /// earlier node's row, the forward sweep scatters the earlier node's value
  /// through them to the later nodes. Spring e of Model::net_springs is at
  /// spring_slot[e].
  SweepSprings sweep_springs;
  SweepSpringConstants spring_constants;  ///< Sweep order (fixed, resize()).
  std::vector<double> spring_length;  ///< l at the step's start (m), sweep order.
  std::vector<std::int32_t> spring_low_begin;  ///< Per position, size num_nodes + 1 (fixed topology, resize()).
  std::vector<std::int32_t> spring_slot;       ///< Per Model::net_springs: its index in sweep_springs.
  // Collision stage (detect_node_contacts(), net_collision.hpp), rebuilt per
  // net; sized by the Model's obstacles, bodies and body spheres.
  /// Primitive obstacles whose bounds meet the net's AABB (index order).
  std::vector<std::int32_t> near_obstacles;
  std::vector<Vec3> obstacle_axis;      ///< Per near obstacle: plane normal or capsule axis.
  std::vector<Mat3> obstacle_rotation;  ///< Per near obstacle: box rotation (box → world).
  /// Bodies whose world AABB meets the net's AABB (index order), outside its articulation.
  std::vector<std::int32_t> near_bodies;
  std::vector<std::int32_t> near_sphere_end;  ///< Per near body: end of its run of near_spheres.
  std::vector<std::int32_t> near_spheres;     ///< Body spheres near the net, by near body.
  /// An organ's fine surface (net_surface.cpp, gather_surface_candidates()): the near spheres
  /// with a finite centre as their indices into near_spheres, in ascending order of their
  /// centre's coordinate along the query box's longest axis, and those coordinates (m, world).
  std::vector<std::int32_t> near_order;
  std::vector<double> near_key;
  /// An organ's surface contacts (net_surface.hpp): the net's triangles (Model::net_faces
  /// indices) whose bounds meet the near spheres' bounds, and those bounds (m, world). Sized by
  /// the largest NetModel::face_count.
  std::vector<std::int32_t> face_candidates;
  std::vector<Vec3> face_lo, face_hi;
  /// Per node (global): its outcode against the query box of the net's last surface cull
  /// (net_surface.cpp, node_outcodes()): per axis one bit for "below the box", one for "above".
  std::vector<std::uint8_t> node_outcode;
  /// An organ's fine surface (net_surface_map.hpp): the fine triangles (Model::net_surface_faces
  /// indices) riding on the net triangles near the tool, whose bounds meet the near spheres'
  /// bounds, and those bounds (m, world); sized by the largest NetModel::surface_face_count.
  std::vector<std::int32_t> surface_candidates;
  std::vector<Vec3> surface_lo, surface_hi;
  /// Per candidate: bit i set where near sphere i (its index in near_spheres; bit 63 for every
  /// index from 63 on) comes within its radius plus the net's surface_reach of a net triangle
  /// the candidate rides on — the only spheres it can touch (net_surface.cpp).
  std::vector<std::uint64_t> surface_sphere_mask;
  /// The candidates (indices into face_candidates or surface_candidates) whose bounds meet a run
  /// of a body's spheres (net_surface.cpp, collide_candidates()); sized as the larger of the two.
  std::vector<std::int32_t> group_candidates;
  /// Per fine triangle (global): its index among this call's candidates, −1 where the call
  /// rejected it (valid where surface_face_stamp is the call's).
  std::vector<std::int32_t> surface_face_slot;
  /// Per fine triangle and per fine vertex (global): the stamp of the last call that gathered
  /// it, and the vertex's position computed then (m, world): each is gathered and computed once
  /// a call, whatever the number of net triangles it rides on.
  std::vector<std::uint32_t> surface_face_stamp, surface_point_stamp;
  std::vector<Vec3> surface_position;
  /// Per net triangle (global): the stamp of the call that judged its tear, and the verdict
  /// (1: torn), once a call whatever the number of fine vertices riding on it.
  std::vector<std::uint32_t> surface_net_stamp;
  std::vector<std::uint8_t> surface_net_torn;
  /// The fine-surface patches (Model::net_surface_clusters) the last call skipped, no near sphere
  /// reaching them (a count for tests and profiles).
  int surface_patches_skipped = 0;
  std::uint32_t surface_stamp = 0;  ///< The current call's stamp (0: never; wraps by clearing).
  // Resting nodes (net_rest.hpp): per node, its consecutive quiet steps (saturating at
  // detail::kRestSteps) and its state bits (resting, eligible, boundary; net_rest.cpp).
  std::vector<std::uint8_t> rest_count;
  std::vector<std::uint8_t> rest_flags;
  /// Still neighbourhoods (net_still.hpp), per node: its state at the net's last force pass
  /// (none before the first: pass_stored), its bits (0: still), and its force after the springs
  /// (N) and its springs' energy term (J) from the last pass that computed them (net_springs.cpp).
  std::vector<Vec3> pass_position, pass_velocity;
  bool pass_stored = false;  ///< Whether pass_position and pass_velocity hold a pass's states.
  std::vector<std::uint8_t> still_flags;
  std::vector<Vec3> still_force;
  std::vector<double> still_energy;
  /// The nodes in the solve (not resting), each net's in its own slots: net k's are
  /// active_nodes[node_begin, node_begin + active_count[k]) as node indices (ascending) and
  /// active_positions[the same] as sweep positions (ascending); every node when none rests.
  std::vector<std::int32_t> active_nodes, active_positions;
  /// The sweep positions whose springs (grouped by their earlier node) touch a node in the
  /// solve: those of the nodes in the solve and of the resting nodes next to one;
  /// pass_positions[node_begin, node_begin + pass_count[k]) for net k.
  std::vector<std::int32_t> pass_positions;
  std::vector<int> active_count, pass_count;  ///< Per net.
  /// The load patch of the last tissue contact (net_tissue.cpp; net_tissue_contact.hpp): its
  /// surface nodes (global) and normalised weights, the first patch_count of them, about the
  /// rest point patch_at of the net whose first node is patch_net (-1: none yet; the entries of
  /// one contact follow one another and reuse it), and the contact's depth as detected on the
  /// fine surface (m; its backstop's). Sized by the largest NetModel::surface_node_area.
  std::vector<std::int32_t> patch_nodes;
  std::vector<double> patch_weights;
  int patch_count = 0;
  int patch_net = -1;
  Vec3 patch_at = Vec3::Zero();
  double patch_fine_depth = 0.0;
  /// Sizes every buffer for `model` (all empty when it has no net). Allocates: make_data() only.
  void resize(const Model& model);

 private:
  // resize()'s parts, for `n` nodes and `nb` bodies (none without nodes).
  /// The solve's per-node and per-body vectors.
  void resize_solve(const Model& model, std::size_t n, std::size_t nb);
  /// The sweep order's positions and the springs by their earlier node in it.
  void order_springs(const Model& model, std::size_t n);
  /// The resting nodes' bookkeeping: none rests yet, every node in the solve.
  void reset_resting(const Model& model, std::size_t n);
  /// The contact search's room: near obstacles, bodies and spheres, the largest net's
  /// triangles and fine triangles, the fine surface's stamps and patches, the load patch.
  void resize_contact_search(const Model& model, std::size_t n, std::size_t nb);
};

}  // namespace numen::core
