#pragma once
/// @file net_state.hpp
/// Mutable state, per-step outputs and contacts of the deformable nets
/// (net_model.hpp), held by core::Data. Sized once by make_data(); empty for
/// a model without nets (a scene pays only for what it has). The nets' solver
/// scratch is private to numen::core (core/src/scratch/net_scratch.hpp).

#include "numen/core/types.hpp"

namespace numen::core {

/// State of one net node: world position (m) and velocity (m/s).
struct NodeState {
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();
};

/// A penalty contact between a node's sphere and an obstacle or a dynamic
/// body's sphere, or one node's share of a contact between an organ's surface
/// triangle and a dynamic body's sphere (`face` ≥ 0; net_surface.hpp). Geometry
/// from detect_node_contacts(); force and linearisation from compute_net_forces();
/// weights from the implicit solve. Same penalty law as core::Contact
/// (contact_force.hpp), the node on side a.
///
/// A triangle contact is written as one NodeContact per node of the triangle with a
/// barycentric weight w > 0 at the closest point (consecutive, the same geometry):
/// its law acts once on the triangle's point velocity Σ w_m v_m, and this entry
/// carries the node's share w of its force and of its Jacobian coefficients
/// (`stiffness`, `damping`, `friction`), so that the shares sum to the contact.
struct NodeContact {
  int node = -1;           ///< Global node index, receives +force.
  int body_b = -1;         ///< Dynamic body receiving −force, or -1 for a static obstacle.
  int obstacle = -1;       ///< Obstacle index when body_b == -1, else -1.
  int sphere_b = -1;       ///< body_spheres index (body_b ≥ 0) or static_spheres index, or -1.
  int material_pair = 0;   ///< Index into Model::material_pairs.
  Vec3 position = Vec3::Zero();  ///< Contact point (m, world): middle of the overlap.
  Vec3 normal = Vec3::UnitZ();   ///< Unit, from b towards the node.
  double depth = 0.0;            ///< Penetration depth (m), > 0.
  Vec3 force = Vec3::Zero();     ///< Penalty force on the node (N, world); −force on body_b.
  Vec3 r_b = Vec3::Zero();       ///< Contact point − COM of body_b (m, world); 0 when static.
  /// v_n = n · (v_node − v_b(point)) at the step's start (m/s): the implicit step's h² K v₀ term.
  /// A triangle contact's share keeps its own node's velocity here (its law acts on the
  /// triangle's point velocity): the Jacobian is lumped on the nodes (docs/organs.md,
  /// "Surface contacts").
  double normal_velocity = 0.0;
  bool active = false;           ///< f_n > 0 (or `engaged`).
  /// A look-ahead candidate: set by the caller of the step (the multirate scene loop,
  /// docs/multirate.md, "Deformable god-objects"), never by detect_node_contacts(). Where the
  /// law is inactive at the step's start (the node separating, or depth ≤ 0),
  /// compute_net_forces() predicts the node's depth at the step's end, alone, implicit, with
  /// its tie and its force at the start: d − h n · v₁, v₁ = v + h (F − h k_tie (v − v_anchor))
  /// / (m + h γ_tie + h² k_tie). Below the surface there, the law acts unclamped, f_n = k d − c
  /// v_n whatever its sign, with k and c in the implicit step (no friction): the step holds a
  /// node that reaches the surface within it instead of finding it deep at the next step. Else
  /// the contact stays inactive and the flag is cleared. A triangle contact's shares (an organ's,
  /// `face` ≥ 0) are decided together before any contact force joins the nodes' forces, the
  /// triangle's point Σ w_m (v_m + Δv_m) predicted from each node alone so (F without contacts),
  /// and act with their share of max(0, k d − c v_n) at the start (never a pull there), k and c
  /// in the implicit step.
  bool engaged = false;
  /// An organ given by its material (NetModel::contact_modulus): this entry belongs to the
  /// deepest contact of its tool's sphere, where the two-scale law (net_tissue_contact.hpp) acts
  /// with its load patch; the sphere's other contacts act only past the law's switch depth, by
  /// the penalty (the net then carries the sphere itself). Set by detect_node_contacts().
  bool primary = false;
  /// An organ given by its material: this entry's contact's weight in where its sphere's
  /// two-scale law touches the organ (net_tissue_contact.hpp, kTissueTouchDepthScale): K(τ)
  /// exp((d − d_max) / (0.1 R)), 0 for an edge's or a vertex's contact; 0 elsewhere. Set by
  /// detect_node_contacts().
  double blend = 0.0;
  /// k_eff (N/m): the material pair's stiffness, clamped by the contact time-constant floor
  /// (SolverSettings::node_contact_max_omega_dt) on the node's mass and the body's effective mass.
  /// When active: the law's ∂f_n/∂d (contact_penalty_force(): k_eff for the linear law), the
  /// Jacobian's stiffness.
  double stiffness = 0.0;
  /// The law's damping and friction coefficients for the implicit step's Jacobian (N·s/m): the
  /// material pair's, faded in by a smoothed onset (contact_penalty_force()); set when active.
  double damping = 0.0;
  double friction = 0.0;         ///< See damping (N·s/m).
  double weight_normal = 0.0;    ///< α of the implicit weight W = α n nᵀ + β I (kg = N·s²/m).
  double weight_isotropic = 0.0; ///< β (kg).
  /// A triangle contact's share: its triangle (index into Model::net_faces), else −1 (a node
  /// sphere's contact).
  int face = -1;
  /// Barycentric weights of the closest point on `face`, one per node of Model::net_faces[face]
  /// (sum 1, each ≥ 0); unused when face < 0.
  Vec3 face_weights = Vec3::Zero();
  double share = 1.0;  ///< This node's weight w in face_weights (1 for a node sphere's contact).
  /// A grasp spring along `normal` (grasp.hpp), not a penalty contact: written by the grasp stage
  /// after the node contacts (Data::num_node_grasp_springs of them), three per held node (the
  /// world's axes), `position` the jaw's point at the step's start, `stiffness` and `damping` the
  /// grasper's, `force` the spring's share along `normal` at the step's start, f = (k n · (p − x)
  /// − c n · (v − v_p)) n; the forces stage applies it to the node and its opposite to the jaw,
  /// and the solve takes its Jacobian as a contact's.
  bool held = false;
};

/// What a net did in the last step (observable; traces and studies).
struct NetOutput {
  double max_tie_stretch = 0.0;    ///< Largest |x − a| of a node from its rest position (m), step's end.
  double max_strain = 0.0;         ///< Largest |l − L|/L of a structural spring, step's end.
  /// A net given by its material: its tetrahedra well shaped at rest (Model::net_tetrahedra; not
  /// the mesher's slivers, kInversionWatchQuality) whose signed volume is not positive at the
  /// step's end — turned inside out, flat, or not finite (0 for a net given per spring). Its
  /// central springs do not resist the turn, and the force the tool feels there is no longer
  /// the tissue's (docs/tissue.md, "Inversion").
  int inverted_tetrahedra = 0;
  double kinetic_energy = 0.0;     ///< Σ ½ m |v|² of the nodes, step's end (J).
  double max_node_speed = 0.0;     ///< Largest |v| of a node, step's end (m/s).
  /// The net's mechanical energy at the step's start (J), from the forces stage's own terms:
  /// Σ ½ m |v|² + Σ ½ k_tie |x − a|² (a the anchors on the rigid component's start pose)
  /// + Σ ½ k (l − L)² over the structural and bending springs − Σ m g · x (gravity's potential
  /// from the world origin) — paper §4.2's laws. That is the energy of the state the last step
  /// ended in, one step behind the other measures here.
  double start_energy = 0.0;
  Wrench tie_wrench;               ///< Σ tie forces on the rigid component at its COM, step's start (N, N·m).
  double max_penetration = 0.0;    ///< Deepest node contact this step (m), crossed ones included.
  /// Multirate scene loop only (0 in a single-rate step, which takes every contact): contacts of
  /// a god-object's sphere whose centre had got past this net's surface, behind a triangle that
  /// its true sphere overlaps (true depth from r to 2 r; or the surface folded over the sphere,
  /// its inner side towards it: not told apart), found at this scene step's sample and
  /// dropped there, since their law would hook the triangle onto the tool
  /// (detail::drop_back_face_contacts(), docs/organs.md "Organs in multirate").
  int crossed_contacts = 0;
  /// The deepest true depth of those (m, from r to 2 r; 0 without one): how far the sphere is
  /// past the surface, counted in max_penetration.
  double crossed_depth = 0.0;
  /// Nodes held out of this step's solve, at rest (NetModel::rest_speed; docs/organs.md,
  /// "Resting nodes"); 0 when the net's nodes may not rest.
  int resting_nodes = 0;
};

}  // namespace numen::core
