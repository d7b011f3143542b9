#pragma once
/// @file net_tissue_contact.hpp
/// The contact of a tool's sphere with an organ given by its material (docs/tissue.md, "The
/// contact"): two scales, each where it is exact.
///
/// Below the load patch radius ρ the tissue's deformation under a sphere of radius R is the
/// elastic half-space's (Hertz 1882; Johnson 1985, "Contact Mechanics", §4.2 and §3.8): the
/// approach δ_loc(F) = (3 F / (4 E* √R))^(2/3), E* = E / (1 − ν²), while the contact's radius
/// a = √(R δ) is below R; past it (δ_loc = R, F_R = 4/3 E* R²) the sphere is submerged and its
/// contact radius stays R, a flat punch's: δ_loc = R + (F − F_R) / (2 E* R) (C¹ at F_R, where
/// Hertz's stiffness 2 E* a is the punch's 2 E* R). Above ρ the deformation is the organ's net's:
/// the contact's force is laid on the net's surface nodes within ρ of the contact's material
/// point with the weights K(|x_j − p| / ρ) A_j / Σ, K(s) = (1 − s²)² (A_j the node's share of the
/// surface's area), a load the net resolves where its edge is well below ρ. The contact sees the
/// net through the same weights: its depth d is the sphere's penetration into the plane through
/// the touched point of the organ's surface moved by the patch's mean displacement
/// ū = Σ w_j u_j (not its own triangle's) and normal to the patch's mean rest normal — a surface
/// smooth over ρ, whatever the net's edge, so that force and observation are one operator and a
/// sphere sunk below the net's triangles keeps one depth. A half-space under the spread load has
/// ū = c_ρ F, c_ρ = kPatchMeanCompliance / (E* ρ) (Boussinesq's displacement field averaged
/// over the load: docs/tissue.md gives the quadrature); the net moves so, plus what the organ's
/// finite shape and support add. So the contact's own depth takes the rest:
///   d(F) = δ_loc(F) − c_ρ F,
/// and the sum of d and the net's move is the half-space's approach with the organ's far field
/// on top, at any net size. The law is that relation inverted for F(d); where dd/dF falls to
/// 1 / k (k the material pair's penalty stiffness: a patch too small for the sphere, c_ρ above
/// the submerged sphere's compliance) it goes on linearly with slope k (C¹ where that falls in
/// Hertz's range; at F_R, where the submerged branch would be stiffer than k, C⁰). A sphere pushed
/// past the net's resolution sinks below the net-carried surface (the tissue would wrap it;
/// the net cannot): half its radius below the touched fine surface, the penalty of the pair
/// joins on the touched triangles' nodes with a C¹ onset, as a net given per spring meets a tool
/// (kTissueBackstopDepth, kTissueBackstopOnset; net_tissue.cpp).
///
/// Real-time safe: no allocation, no exception.

namespace numen::core {

/// The half-space's displacement under a force F spread by the kernel over a disc of radius ρ
/// (pressure p ∝ K(r / ρ)), averaged with the pressure's weights, is this F / (E* ρ):
/// (1 / F²) ∫∫ p(x) p(y) / (π |x − y|) dA dA by quadrature (docs/tissue.md, "The contact"). At the
/// centre it would be 16 / (5π) = 1.0186.
inline constexpr double kPatchMeanCompliance = 0.7665437;

/// The load patch kernel K(s) = (1 − s²)² for s = r / ρ < 1, else 0 (C¹ at s = 1).
inline double load_patch_kernel(double s) noexcept {
  if (!(s < 1.0)) return 0.0;
  const double t = 1.0 - s * s;
  return t * t;
}

/// The law of one contact (see the file comment), built by make_tissue_contact_law().
struct TissueContactLaw {
  double hertz = 0.0;           ///< A = (3 / (4 E* √R))^(2/3) (m/N^(2/3)): δ_loc = A F^(2/3).
  double patch = 0.0;           ///< c_ρ (m/N): the spread load's half-space mean compliance.
  double radius = 0.0;          ///< R (m).
  double submerge_force = 0.0;  ///< F_R = 4/3 E* R² (N): Hertz's contact radius reaches R.
  double punch = 0.0;           ///< c_p = 1 / (2 E* R) (m/N): the submerged sphere's compliance.
  double penalty = 0.0;         ///< k (N/m): the slope past the switch.
  double switch_force = 0.0;    ///< F_s (N): where the law turns linear (+∞: never).
  double switch_depth = 0.0;    ///< d_s = d(F_s) (m; +∞: never).
};

/// The backstop depth of a tissue contact, in sphere radii: the touched fine surface's depth
/// past which the pair's penalty joins the law (net_tissue_contact.hpp's file comment).
inline constexpr double kTissueBackstopDepth = 1.5;

/// The backstop's onset, in sphere radii: the pair's penalty joins over it with contact_force.hpp's
/// C¹ quadratic onset (MaterialPair::onset_depth), so that it never steps the force.
inline constexpr double kTissueBackstopOnset = 0.25;

/// The law for a tissue of plane-strain modulus `contact_modulus` E* (Pa, > 0), a sphere of
/// `sphere_radius` R (m, > 0), a load patch of `patch_radius` ρ (m, > 0) and the pair's penalty
/// stiffness `penalty` k (N/m, > 0). The switch: the force where dd/dF = 1/k, if any.
TissueContactLaw make_tissue_contact_law(double contact_modulus, double sphere_radius,
                                         double patch_radius, double penalty) noexcept;

/// d(F) (m) of `law` for a patch force `force` (N) up to the switch (0 for F ≤ 0).
double tissue_contact_depth(const TissueContactLaw& law, double force) noexcept;

/// The elastic force of the law at the contact's depth (m).
struct TissueContactForce {
  double force = 0.0;      ///< F(d) (N), ≥ 0, laid on the load patch; 0 for d ≤ 0.
  double stiffness = 0.0;  ///< dF/dd (N/m), ≥ 0, at most k: the implicit step's Jacobian.
};

/// F(d) and dF/dd of `law` at `depth` (m). Below F_R, F solves A F^(2/3) − c_ρ F = d
/// (safeguarded Newton on x = F^(1/3), to 1e-12 relative); on the submerged branch it is linear;
/// past the switch F_s + k (d − d_s).
TissueContactForce tissue_contact_force(const TissueContactLaw& law, double depth) noexcept;

}  // namespace numen::core
