#pragma once
/// @file tissue_dimple.hpp
/// The dimple a tool's sphere presses into an organ given by its material, as the outputs draw
/// it: the OpenIGTLink organ surfaces (igtl_world_server.cpp) here, the browser page by its own
/// copy (sim/viewer/js/tissue_dimple.js; docs/viewer.md "Page", docs/openigtlink.md "The
/// organs"). The organ's net carries the tissue's deformation on the scale of the contact's load
/// patch; the half-space's own approach under it is the two-scale contact law's, and no node
/// shows it (docs/tissue.md, "The contact"). It is drawn as a Hertzian dimple (Johnson 1985,
/// "Contact Mechanics", §3.4): a view only, nothing goes back into the step.

#include <array>
#include <cstdint>
#include <span>

#include "numen/core/types.hpp"

namespace numen::sim {

/// How far a dimple reaches, in contact radii (the page's kReachRadii).
inline constexpr double kDimpleReachRadii = 6.0;

/// A sphere that presses: centre (world) and radius, in the surface's length unit.
struct DimpleSphere {
  core::Vec3 centre = core::Vec3::Zero();
  double radius = 0.0;
};

/// Hertz's surface displacement at distance `rho` from the axis of a sphere of radius `radius`
/// pressed `depth` (> 0) into a half-space: δ − ρ²/(2R) within a = √(R δ), beyond it
/// (δ/π)[(2 − ρ²/a²) asin(a/ρ) + (ρ/a) √(1 − a²/ρ²)] (Johnson 1985, eq. 3.42); 0 for depth ≤ 0.
double hertz_surface_displacement(double rho, double radius, double depth) noexcept;

/// Each vertex's unit normal from `triangles` (outward, indices into `points`): the sum of its
/// triangles' area vectors, normalised; zero for a vertex of none. `normals` has points' size.
void vertex_normals(std::span<const core::Vec3> points, std::span<const std::array<std::uint32_t, 3>> triangles,
                    std::span<core::Vec3> normals) noexcept;

/// Moves the vertices `points` of an organ's surface into the dimples `spheres` press into it
/// (the page's pressDimples()); `normals` their unit outward normals before, `moves` scratch of
/// points' size. Per sphere reaching the surface's bounds: the vertex nearest its centre within
/// its radius gives the axis (its normal n₀) and the depth δ (the sphere's reach below that
/// vertex's tangent plane); each vertex facing that way (n · n₀ > 0), within kDimpleReachRadii
/// contact radii of the axis and of that vertex's level along it, moves along −n by the largest
/// displacement a sphere gives it (hertz_surface_displacement() less its value at the reach);
/// then any vertex still inside a sphere is put on its surface along −n. Returns the largest
/// move. Allocates nothing.
double press_tissue_dimples(std::span<core::Vec3> points, std::span<const core::Vec3> normals,
                            std::span<const DimpleSphere> spheres, std::span<double> moves) noexcept;

}  // namespace numen::sim
