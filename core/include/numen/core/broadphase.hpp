#pragma once
/// @file broadphase.hpp
/// Broad phase for static sphere sets: a uniform grid built once when the
/// Model is finalized, queried without allocation during step().

#include <cstdint>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct Sphere;

/// Uniform grid over the static spheres of a Model (world frame), built once.
/// Each cell lists the indices of the spheres whose bounding box overlaps it
/// (compressed row storage: cell_start has num_cells + 1 entries).
struct StaticSphereGrid {
  Vec3 origin = Vec3::Zero();   ///< World position of the grid's min corner (m).
  double cell_size = 0.0;       ///< Edge length of a cubic cell (m); 0 = empty grid.
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< Cells along x, y, z.
  std::vector<std::int32_t> cell_start;  ///< Offsets into sphere_index, size cells+1.
  std::vector<std::int32_t> sphere_index;  ///< Sphere indices, grouped by cell.

  /// True when no static sphere is registered.
  bool empty() const noexcept { return cell_size <= 0.0; }
};

/// Builds the grid over `spheres` (world frame). cell_size <= 0 picks a cell of
/// about twice the mean sphere diameter. Allocates; call at load time only.
void build_static_grid(const std::vector<Sphere>& spheres, double cell_size,
                       StaticSphereGrid& grid);

}  // namespace numen::core
