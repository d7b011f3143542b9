#pragma once
/// @file net_model.hpp
/// Compiled description of a deformable god-object (paper §4.2, Fig. 4;
/// Meseure & Chaillou, "Deformable body model for surgical simulation",
/// J. Visualization and Computer Animation 11(4), 2000): a mass-spring surface
/// net built from a triangle mesh — one node per vertex, a structural spring
/// per edge, a bending spring across each pair of adjacent triangles — whose
/// every node is tied by a zero-length damped spring to its rest position
/// carried by a rigid component. The rigid component is an ordinary dynamic
/// body of the Model (the paper's hidden rigid god-object following the
/// device; give it no spheres so that it does not collide). Node spheres
/// collide; the net's forces act back on the rigid component.

#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// A spring between two nodes of a net: f_a = −f_b = k (l − L) d̂ + γ (d̂·(v_b − v_a)) d̂
/// with d = x_b − x_a, l = |d|, d̂ = d/l (damping along the spring only).
struct NetSpring {
  int node_a = -1;           ///< Global node index (Model::node_*), node_a < node_b.
  int node_b = -1;           ///< Global node index.
  double rest_length = 0.0;  ///< L (m), > 0: the mesh's rest distance.
  double stiffness = 0.0;    ///< k (N/m), ≥ 0.
  double damping = 0.0;      ///< γ (N·s/m), ≥ 0.
};

/// One net of a Model. Its nodes are [node_begin, node_begin + node_count) of
/// the Model's node arrays, its springs [spring_begin, spring_begin +
/// structural_count + bending_count) of Model::net_springs (structural first),
/// its surface triangles [face_begin, face_begin + face_count) of Model::net_faces.
struct NetModel {
  std::string name;
  int body = -1;              ///< Rigid component: index into Model::bodies.
  int node_begin = 0;
  int node_count = 0;
  int spring_begin = 0;
  int structural_count = 0;
  int bending_count = 0;
  int face_begin = 0;  ///< First of the net's triangles in Model::net_faces.
  int face_count = 0;  ///< The mesh's triangles (0 for a net built by hand without faces).
  /// The net's tetrahedra watched for inversion in Model::net_tetrahedra (a net given by its
  /// material: those well shaped at rest; count 0 for one given per spring).
  int tetrahedron_begin = 0;
  int tetrahedron_count = 0;
  /// The fine surface mapped on the net (add_net_surface(), net_surface_map.hpp): its vertices
  /// [surface_point_begin, + surface_point_count) of Model::net_surface_points, its triangles
  /// [surface_face_begin, + surface_face_count) of Model::net_surface_faces. Counts 0 without
  /// one (the tool then touches the net's own triangles).
  int surface_point_begin = 0;
  int surface_point_count = 0;
  int surface_face_begin = 0;
  int surface_face_count = 0;
  /// How far from a net triangle a fine triangle riding on it may reach at rest (m): the largest
  /// |offset| of a fine vertex plus the longest fine edge. The organ's contacts look for the
  /// fine triangles of the net triangles within this of the tool (net_surface.hpp).
  double surface_reach = 0.0;
  /// Zero-length spring of every node to its rest position on the rigid
  /// component (paper §4.2): f = −k_tie (x − a) − γ_tie (v − v_a), a = x_b + R_b r.
  double tie_stiffness = 0.0;  ///< k_tie (N/m) per node, > 0.
  double tie_damping = 0.0;    ///< γ_tie (N·s/m) per node, ≥ 0.
  int material = 0;            ///< Contact material of the node spheres.
  double mass = 0.0;           ///< Σ node masses (kg), derived.
  /// Resting nodes (docs/organs.md, "Resting nodes"): on an anchored body, a node quiet for
  /// some steps — speed at most this, force at most the force that would change its speed by
  /// this in one step, no contact — with quiet neighbours is held out of the solve until its
  /// force, a contact or a neighbour wakes it (m/s, ≥ 0; 0: every node always in the solve).
  /// Ignored on a body that is not anchored.
  double rest_speed = 0.0;
  /// An organ given by its material (add_material_net(), net_material.hpp): the tissue's
  /// plane-strain modulus E* = E / (1 − ν²) (Pa) in the two-scale contact law of the tools'
  /// spheres on its surface (net_tissue_contact.hpp; docs/tissue.md, "The contact"); 0: the
  /// material pair's penalty law (contact_force.hpp), one contact per touching triangle.
  double contact_modulus = 0.0;
  /// With contact_modulus: the tissue's Poisson's ratio ν, in (−1, 0.5): the row of the contact
  /// law's neo-Hookean half-space (net_tissue_contact.hpp).
  double contact_poisson_ratio = 0.0;
  /// With contact_modulus: the tissue's strain stiffening b in [0, kMaxStrainStiffening]
  /// (NetMaterial::strain_stiffening): the block of the contact law's half-space.
  double contact_stiffening = 0.0;
  /// ρ (m, > 0 with contact_modulus): the radius of the load patch that lays a contact's force
  /// on the surface's nodes (net_tissue_contact.hpp).
  double load_patch_radius = 0.0;
  /// With contact_modulus: the surface's nodes are [node_begin, node_begin + size()) and this is
  /// each one's share of the surface's area (m²: a third of every triangle at each corner), the
  /// load patch's weights. Empty otherwise.
  std::vector<double> surface_node_area;
  /// With contact_modulus: each surface node's outward unit normal at rest (body frame; the
  /// area-weighted normals of its triangles), the load patch's mean normal. Empty otherwise.
  std::vector<Vec3> surface_node_normal;
  /// Per node of the net (size node_count) or empty: node i's tie is s_i k_tie, s_i γ_tie
  /// (tie_scale(); k_tie, γ_tie then the mean per node). A material net's ties are a stiffness
  /// per volume, so s_i is its node's lumped volume over the mean (add_material_net()). Empty:
  /// every node's tie is k_tie, γ_tie. Only on an anchored rigid component (its rows are not in
  /// the solve, whose tie sums take every tie alike: finalize_model() checks).
  std::vector<double> tie_scale;
};

/// s_v of node `v` (a global node index of `net`): NetModel::tie_scale's entry, or 1.
inline double tie_scale(const NetModel& net, int v) noexcept {
  return net.tie_scale.empty() ? 1.0 : net.tie_scale[static_cast<std::size_t>(v - net.node_begin)];
}

/// Creation settings of a net (SI units). Per-spring and per-node constants
/// as in a mass-spring model: a finer mesh with the same constants is
/// stiffer in bending and in shape memory (not a continuum discretisation).
struct NetSettings {
  std::string name;
  int body = -1;                 ///< Rigid component (index into Model::bodies).
  int material = 0;              ///< Index into Model::material_names.
  double mass = 0.0;             ///< Total mass (kg, > 0), lumped by vertex area.
  double stiffness = 0.0;        ///< Structural spring k (N/m, ≥ 0), every edge.
  double damping = 0.0;          ///< Structural spring γ (N·s/m, ≥ 0).
  double bending_stiffness = 0.0;  ///< Bending spring k (N/m, ≥ 0).
  double bending_damping = 0.0;    ///< Bending spring γ (N·s/m, ≥ 0).
  double tie_stiffness = 0.0;    ///< Zero-length tie k (N/m, > 0), per node.
  double tie_damping = 0.0;      ///< Zero-length tie γ (N·s/m, ≥ 0), per node.
  /// Collision sphere radius of every node (m); 0: from the mesh, the mean
  /// incident edge length over √3 (the circumradius of an equilateral
  /// triangle of that side, so the spheres cover the surface).
  double node_radius = 0.0;
  /// NetModel::rest_speed (m/s, ≥ 0; 0: off). The default, 30 µm/s: a resting node's force is
  /// at most f_r = v_r (m + h γ_tie + h² k_tie) / h, 10 µN on the shipped organ at 1 ms (0.1 µm
  /// on its tie); the default scene's summary figures are those of 10 µm/s to 1e-8 of their
  /// values, its step 13 % cheaper at the median and 9 % at p99 (docs/organs.md, "Resting nodes").
  double rest_speed = 3e-5;
};

/// Checks a net's rigid component `body` (an index into Model::bodies) and contact `material`
/// (an index into Model::material_names, or 0 in a model without materials yet, which
/// finalize_model() gives "default"): "" when both are in range, else a message naming the
/// first that is not. What add_net() and add_material_net() check first.
std::string validate_net_owner(const Model& model, int body, int material);

/// Appends a net to `model` from `mesh`, given in the rigid component's body
/// frame (origin at its COM; the rest shape). Nodes start at their rest
/// positions at the body's initial pose with its initial point velocities.
/// Call before finalize_model(). Returns "" on success, else a message naming
/// the net and the offending setting or mesh element (validate_mesh()).
/// Allocates: load time only.
std::string add_net(Model& model, const TriangleMesh& mesh, const NetSettings& settings);

/// Fills Model::node_sweep_order: per net, the reverse Cuthill–McKee order of
/// its spring graph (structural and bending springs as edges; Boost.Graph's
/// cuthill_mckee_ordering), as global node indices within the net's range.
/// Called by finalize_model() after the nets are validated. Allocates: load
/// time only.
void order_net_nodes(Model& model);

/// Fills Model::node_spring_begin and Model::node_springs, the springs at each node (a
/// compressed incidence list: each spring at both its nodes, ascending within a node), from
/// Model::net_springs. Called by finalize_model() after the nets are validated. Allocates: load
/// time only.
void index_node_springs(Model& model);

}  // namespace numen::core
