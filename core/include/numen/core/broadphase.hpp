#pragma once
/// @file broadphase.hpp
/// Broad phase of the collision stage (paper §5, sphere-based collision):
/// - a uniform grid over the static sphere sets, built once when the Model is
///   finalized and queried without allocation during step();
/// - the sort-and-sweep order of the dynamic bodies' world AABBs (insertion
///   sort of a preallocated index array, coherent between steps).

#include <cstdint>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct Sphere;
struct Obstacle;

/// A grid entry: a static sphere (world frame, exact) and the sphere-set
/// obstacle it belongs to. Read only for candidates that pass the float test.
struct GridEntry {
  Vec3 center = Vec3::Zero();  ///< World centre (m).
  double radius = 0.0;         ///< m.
  std::int32_t sphere = -1;    ///< Index into Model::static_spheres.
  std::int32_t obstacle = -1;  ///< Owning sphere-set obstacle, -1 for a bare sphere list.
  std::int32_t material = 0;   ///< Material of the owning obstacle (0 for a bare sphere list).
};

/// Uniform grid over the static spheres of a Model (world frame), built once.
/// Each cell lists the spheres whose bounding box overlaps it (compressed row
/// storage: cell_start has num_cells + 1 entries; cells are numbered
/// x fastest, then y, then z, so a run of cells along x is one contiguous
/// range of items). A sphere straddling several cells appears once per cell:
/// queries de-duplicate hits with a per-entry stamp (CollisionScratch).
///
/// An *entry* is a (sphere, obstacle) pair: a static sphere listed by two
/// sphere-set obstacles is two entries (and gives two contacts).
struct StaticSphereGrid {
  Vec3 origin = Vec3::Zero();  ///< World position of the grid's min corner (m).
  double cell_size = 0.0;      ///< Edge length of a cubic cell (m); 0 = empty grid.
  double inv_cell_size = 0.0;  ///< 1 / cell_size (1/m), 0 for an empty grid.
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< Cells along x, y, z.
  Vec3 bounds_min = Vec3::Zero();                  ///< Union of the entries' bounding boxes (m).
  Vec3 bounds_max = Vec3::Zero();                  ///< Union of the entries' bounding boxes (m).
  std::int32_t num_entries = 0;                    ///< Distinct (sphere, obstacle) entries.
  /// Absolute slack (m) added to the radii sum in the float prefilter so that it
  /// never rejects a pair the exact double test accepts (float rounding of
  /// coordinates up to the grid's extent); a query adds 1e-6 of its own radius.
  float float_slack = 0.0f;
  std::vector<std::int32_t> cell_start;    ///< Offsets into the per-item arrays, size cells+1.
  std::vector<std::int32_t> sphere_index;  ///< Sphere indices, grouped by cell.
  std::vector<std::int32_t> item_entry;    ///< Same order: entry of each item.
  /// Same order, structure of arrays: compact float copy of each item's sphere,
  /// centre relative to `origin` and radius (m). Only a conservative prefilter
  /// (see float_slack); the exact test uses the double GridEntry.
  std::vector<float> item_x, item_y, item_z, item_radius;
  std::vector<GridEntry> entries;  ///< Size num_entries.

  /// True when no static sphere is registered.
  bool empty() const noexcept { return cell_size <= 0.0; }

  /// Number of items (entries listed per cell, duplicates included).
  int num_items() const noexcept { return static_cast<int>(item_entry.size()); }

  /// Number of cells.
  int num_cells() const noexcept { return dims.x() * dims.y() * dims.z(); }

  /// Linear index of cell (x, y, z).
  int cell_index(int x, int y, int z) const noexcept { return (z * dims.y() + y) * dims.x() + x; }

  /// Cell coordinate of world coordinate `v` along `axis`, clamped to the grid
  /// (NaN gives 0). Clamping to [0, dims − 1] first makes the truncation a
  /// floor, without a call to std::floor (slow without SSE4.1).
  int cell_coord(double v, int axis) const noexcept {
    double f = (v - origin[axis]) * inv_cell_size;
    f = f > 0.0 ? f : 0.0;
    const double hi = static_cast<double>(dims[axis] - 1);
    f = f < hi ? f : hi;
    return static_cast<int>(f);
  }

  /// Cells overlapped by the world box [lo, hi]: false when the box misses
  /// every entry (outside bounds_min/max, or NaN), else the inclusive cell ranges.
  bool cell_range(const Vec3& lo, const Vec3& hi, Eigen::Vector3i& first,
                  Eigen::Vector3i& last) const noexcept {
    if (empty()) return false;
    if (!((hi.array() >= bounds_min.array()).all() && (lo.array() <= bounds_max.array()).all()))
      return false;
    for (int k = 0; k < 3; ++k) {
      first[k] = cell_coord(lo[k], k);
      last[k] = cell_coord(hi[k], k);
    }
    return true;
  }
};

/// Builds the grid over every sphere of `spheres` (world frame), entry e =
/// sphere e, obstacle -1 (spheres with a non-finite centre or a negative radius
/// are left out). cell_size <= 0 picks a cell of about the mean sphere diameter;
/// any cell size is enlarged if the grid would exceed max(4096, 32·n) cells or
/// max(4096, 32·n) items (n entries).
/// Allocates; call at load time only.
void build_static_grid(const std::vector<Sphere>& spheres, double cell_size,
                       StaticSphereGrid& grid);

/// Builds the grid over the sphere-set obstacles of `obstacles` (their ranges of
/// `spheres`, in obstacle order; other shapes are ignored). Same cell-size rule.
/// Entry ids follow the obstacles' order.
/// Allocates; call at load time only.
void build_static_grid(const std::vector<Sphere>& spheres, const std::vector<Obstacle>& obstacles,
                       double cell_size, StaticSphereGrid& grid);

/// Sort-and-sweep order: sorts `order[0, count)` (body indices) by
/// (aabb_min[i][axis], i) ascending with an insertion sort, O(count) when the
/// order of the previous step is nearly right. The tie-break on the index makes
/// the result a pure function of the keys (deterministic, history-free).
void sort_sweep_order(const Vec3* aabb_min, int axis, std::int32_t* order, int count) noexcept;

}  // namespace numen::core
