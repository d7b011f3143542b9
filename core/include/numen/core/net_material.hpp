#pragma once
/// @file net_material.hpp
/// An organ given by its material: a volumetric spring net on a tetrahedral mesh of the organ,
/// every constant derived from Young's modulus, Poisson's ratio, density and a Rayleigh damping
/// coefficient and the geometry, whatever the net's size (docs/tissue.md).
///
/// The model. Every tetrahedron edge is a spring whose stiffness is identified from the
/// continuum (Van Gelder 1998, "Approximate simulation of elastic membranes by triangulated
/// spring meshes", J. Graphics Tools 3(2); Lloyd, Székely & Harders 2007, "Identification of
/// spring parameters for deformable object simulation", IEEE TVCG 13(5)):
///   k_e = E_net · Σ_{t ∋ e} V_t / L_e²,
/// which under an affine strain ε stores the energy density (E_net/5)((tr ε)² + 2 ε:ε) for an
/// isotropic spread of edge directions: a linear-elastic solid of modulus E_net and Poisson's
/// ratio 1/4, whatever the tetrahedra's size. A central-force net has that Poisson's ratio
/// only, so E_net is chosen to give the material's plane-strain modulus E* = E / (1 − ν²),
/// the one constant that sets a half-space's response to any normal indentation (Hertz,
/// Boussinesq): E_net = kNetAffineCorrection · (15/16) · E / (1 − ν²). Every node is held on
/// the rigid component by a zero-length tie of the organ's support, a stiffness per volume
/// κ = E_net / ℓ² (ℓ the support length) lumped as the masses are: node i's tie is κ V_i for its
/// lumped volume V_i (NetModel::tie_stiffness the mean κ V / N, NetModel::tie_scale V_i N / V;
/// an elastic foundation in the volume: what holds the organ in the body, whose field decays
/// over ℓ). Masses are lumped: ρ V_t / 4 on each corner of a tetrahedron. Damping is
/// stiffness-proportional (Rayleigh): γ_e = β k_e on the springs, γ_tie = β k_tie. The tools'
/// spheres meet the surface through the two-scale contact law of net_tissue_contact.hpp
/// (NetModel::contact_modulus, load_patch_radius, surface_node_area).
///
/// Load time only: everything here allocates; nothing is called from step().

#include <array>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// Six times the signed volume of the tetrahedron (a, b, c, d) (m³): (b − a) × (c − a) · (d − a),
/// positive when d lies on the side of (b − a) × (c − a). Not finite where a corner is not.
inline double tetrahedron_six_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) noexcept {
  return (b - a).cross(c - a).dot(d - a);
}

/// A tetrahedral mesh of a closed surface, in the rigid component's body frame (m).
/// Node i < surface.num_vertices() is the surface's vertex i; node surface.num_vertices() + j
/// is interior[j]. Every tetrahedron's indices are in [0, num_nodes()), distinct, its volume
/// positive (any winding is accepted: the volume is taken as its absolute value) and every node
/// a corner of at least one tetrahedron.
struct TetrahedralMesh {
  TriangleMesh surface;                        ///< Closed, outward winding; the net's triangles.
  std::vector<Vec3> interior;                  ///< Nodes inside the surface (m).
  std::vector<std::array<int, 4>> tetrahedra;  ///< Node indices.
  int num_nodes() const noexcept {
    return surface.num_vertices() + static_cast<int>(interior.size());
  }
  /// Node i's position (m).
  const Vec3& node(int i) const noexcept {
    return i < surface.num_vertices() ? surface.vertices[static_cast<std::size_t>(i)]
                                      : interior[static_cast<std::size_t>(i - surface.num_vertices())];
  }
};

/// Tissue as a material (SI units).
struct NetMaterial {
  double youngs_modulus = 0.0;      ///< E (Pa), > 0.
  double poisson_ratio = 0.0;       ///< ν, in (−1, 0.5).
  double density = 0.0;             ///< ρ (kg/m³), > 0.
  double rayleigh_stiffness = 0.0;  ///< β (s), ≥ 0: γ = β k on every spring and tie.
  double support_length = 0.0;      ///< ℓ (m), > 0: the ties' stiffness per volume κ = E_net/ℓ².
  /// b, in [0, kMaxStrainStiffening] (net_tissue_contact.hpp): the tissue's exponential
  /// (Demiray 1972) strain stiffening in the contact law's half-space,
  /// W = μ/(2b) (exp(b Q) − 1) + λ/2 (ln J)², Q = I₁ − 3 − 2 ln J (0: the compressible
  /// neo-Hookean law). The small-strain response, and so the net's springs and ties, are E's and
  /// ν's whatever b.
  double strain_stiffening = 0.0;
};

/// The constants add_material_net() derived (what `numen info` reports).
struct MaterialNetConstants {
  double net_modulus = 0.0;    ///< E_net (Pa).
  double volume = 0.0;         ///< V (m³), Σ of the tetrahedra's volumes.
  double mass = 0.0;           ///< ρ V (kg).
  double tie_stiffness = 0.0;  ///< k_tie (N/m) per node.
  double tie_damping = 0.0;    ///< γ_tie (N·s/m) per node.
  double spring_stiffness_min = 0.0;  ///< Smallest k_e (N/m).
  double spring_stiffness_max = 0.0;  ///< Largest k_e (N/m).
  int springs = 0;             ///< Edges of the tetrahedra.
  /// The largest time step of the explicit (symplectic Euler) integrator for this net (s):
  /// (2 / ω_max)(√(1 + ζ²) − ζ), ζ = β ω_max / 2 the Rayleigh damping's ratio at ω_max, with
  /// ω_max² ≤ max over nodes of (k_tie + Σ_{e ∋ i} 4 k_e) / m_i (Gershgorin bound on the net's
  /// stiffness over its mass). The limit of symplectic Euler with its damping explicit: on
  /// x'' + 2ζω x' + ω² x = 0 its step matrix has determinant 1 − 2ζωh and trace
  /// 2 − ω²h² − 2ζωh, inside the unit circle for ωh ≤ 2(√(1 + ζ²) − ζ) (Jury's test;
  /// Belytschko, Liu & Moran, "Nonlinear Finite Elements", §6.3, for the central difference).
  /// Stiffness-proportional damping lowers it: 2 / ω_max undamped, about 2 / (β ω_max²) once
  /// ζ ≫ 1. The implicit integrators have none.
  double explicit_step_limit = 0.0;
  double contact_modulus = 0.0;    ///< E* = E / (1 − ν²) (Pa) of the contact law.
  double strain_stiffening = 0.0;  ///< b of the contact law (NetMaterial::strain_stiffening).
  double load_patch_radius = 0.0;  ///< ρ (m) of the contact law.
  double surface_mean_edge = 0.0;  ///< The surface net's mean edge (m).
};

/// E_net / ((15/16) E / (1 − ν²)): the measured ratio of the net's plane-strain modulus under the
/// affine identification to the one it gives once its nodes relax (a random net is softer than
/// its affine bound). Measured on tetrahedralised blocks (tests/core/net_material_test.cpp,
/// docs/tissue.md "Identification").
inline constexpr double kNetAffineCorrection = 1.0;

/// Settings of a material net.
struct MaterialNetSettings {
  std::string name;
  int body = -1;       ///< Rigid component (index into Model::bodies).
  int material = 0;    ///< Contact material (index into Model::material_names).
  NetMaterial tissue;  ///< The tissue.
  /// Collision sphere radius of every node (m); 0: the mean incident tetrahedron edge over √3.
  double node_radius = 0.0;
  double rest_speed = 3e-5;  ///< NetModel::rest_speed (m/s, ≥ 0).
  /// ρ (m, ≥ 0): the contact's load patch radius (NetModel::load_patch_radius,
  /// net_tissue_contact.hpp); 0: default_load_patch_radius().
  double load_patch_radius = 0.0;
};

/// The edges a load patch's radius spans at the coarsest net it is made for, so that the net
/// resolves the patch's load. Three, not two: under a patch of two edges the finer nets' springs
/// let their tetrahedra turn inside out once a 2.5 mm sphere pressed the shipped organ's lobe
/// past 4 mm with b = 1, and nets of 500 to 10 000 nodes differed by 36 % of the finest's peak at
/// 6 mm; with three, by at most 4.1 % (issue 67's figure 1; docs/tissue.md, "Why three edges").
inline constexpr double kLoadPatchEdges = 3.0;

/// The least quality q = 6√2 V / l_max³ at rest (1 for the regular tetrahedron, 0 for a flat
/// one; V its volume, l_max its longest edge) of a tetrahedron whose turning inside out the
/// net reports (Model::net_tetrahedra, NetOutput::inverted_tetrahedra). Below it are the
/// mesher's slivers — on the shipped organ's 500-node net 264 of 1 955, every one of the 193
/// made of four surface nodes among them — which turn over as soon as the surface under a
/// dimple bends the other way (the default recording turned up to 6 of q ≤ 0.03 over; figure
/// 1's nets turned slivers of q < 0.06 over from 0.2 mm, and tetrahedra of q = 0.14–0.35 only
/// deep; docs/tissue.md, "Inversion").
inline constexpr double kInversionWatchQuality = 0.1;

/// The surface node count whose net the default load patch is made for (issue 67's figure 1:
/// nets from 500 to 10 000 nodes feel alike).
inline constexpr int kLoadPatchCoarsestNodes = 500;

/// The default load patch radius (m) of a surface of area `surface_area` (m², > 0):
/// kLoadPatchEdges times the edge of the equilateral triangles of a kLoadPatchCoarsestNodes-node
/// net of that area, √(2 A / (√3 N)) (a closed net of N nodes has about 2N triangles). The same
/// for every net of the organ, whatever its size: what makes them feel alike. A net coarser than
/// that resolves the patch poorly (the scene warns when its mean edge passes 0.6 ρ).
double default_load_patch_radius(double surface_area) noexcept;


/// Checks `material`: "" when valid, else a message on the first bad field; `key`, when given,
/// is then set to that field's scene key (`youngs_modulus_kpa`, `poisson_ratio`, `density`,
/// `rayleigh_stiffness`, `support_length`; docs/scenes.md), for a located error.
std::string validate_material(const NetMaterial& material, const char** key = nullptr);

/// Appends the material net of `mesh` to `model` (see the file comment): nodes in the mesh's
/// order, one spring per tetrahedron edge (NetModel::structural_count; no bending springs), the
/// surface's triangles as the net's faces. Call before finalize_model(). Returns "" on success
/// (filling `constants` when given), else a message naming the net and the material field or
/// the mesh element at fault; the model is then left as it was.
std::string add_material_net(Model& model, const TetrahedralMesh& mesh,
                             const MaterialNetSettings& settings,
                             MaterialNetConstants* constants = nullptr);

}  // namespace numen::core
