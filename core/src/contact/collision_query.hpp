#pragma once
/// @file collision_query.hpp
/// Broad-phase helpers shared by the collision stages of the dynamic bodies
/// (collision.cpp) and of the deformable nets' nodes (net_collision.cpp):
/// conservative box tests and the query of the static sphere grid
/// (Model::static_grid) for one sphere. Private to numen_core.

#include <algorithm>
#include <cstdint>
#include <limits>

#include "numen/core/broadphase.hpp"
#include "numen/core/types.hpp"

#include "scratch/collision_scratch.hpp"

namespace numen::core::collision_detail {

/// Inflation of every broad-phase box (m): keeps the culling conservative with
/// respect to rounding; the narrow phase decides.
inline constexpr double kMargin = 1e-9;

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// Squared distance from `p` to the box [lo, hi] (inf for an inverted box).
inline double box_distance2(const Vec3& p, const Vec3& lo, const Vec3& hi) noexcept {
  return (p - p.cwiseMax(lo).cwiseMin(hi)).squaredNorm();
}

/// True when the boxes [amin, amax] and [bmin, bmax] overlap (inflated by
/// kMargin); false for an inverted box or NaN bounds.
inline bool boxes_overlap(const Vec3& amin, const Vec3& amax, const Vec3& bmin,
                          const Vec3& bmax) noexcept {
  return amin.x() <= bmax.x() + kMargin && amin.y() <= bmax.y() + kMargin &&
         amin.z() <= bmax.z() + kMargin && bmin.x() <= amax.x() + kMargin &&
         bmin.y() <= amax.y() + kMargin && bmin.z() <= amax.z() + kMargin;
}

/// Spheres s in [begin, end), given as flat arrays of centres (X, Y, Z) and
/// radii R (m, world), whose centre is within R[s] + kMargin of the box
/// [lo, hi] along every axis (a conservative sphere–box test): written to
/// `out` in index order, their count returned. Branch-free.
inline int spheres_near_box(const double* X, const double* Y, const double* Z, const double* R,
                            int begin, int end, const Vec3& lo, const Vec3& hi,
                            std::int32_t* out) noexcept {
  const double lx = lo.x(), ly = lo.y(), lz = lo.z(), hx = hi.x(), hy = hi.y(), hz = hi.z();
  int n = 0;
  for (int s = begin; s < end; ++s) {
    // Distance of the centre outside the box, per axis, against r.
    const double dx = std::max(lx - X[s], X[s] - hx);
    const double dy = std::max(ly - Y[s], Y[s] - hy);
    const double dz = std::max(lz - Z[s], Z[s] - hz);
    out[n] = s;
    n += std::max(dx, std::max(dy, dz)) <= R[s] + kMargin ? 1 : 0;
  }
  return n;
}

/// Query of the static sphere grid for the sphere (centre `c`, radius `r`, m,
/// world): calls `visit(const GridEntry&)` once for every entry that may
/// overlap it, in a fixed order (cell rows z, then y, then x; items in cell
/// order; the first copy of an entry listed by several cells). A vectorized
/// float prefilter over each row of cells collects candidates (conservative:
/// StaticSphereGrid::float_slack), a per-entry stamp drops the copies; the
/// caller's exact double test decides. `stamps` has grid.num_entries entries
/// and `stamp` is the id of the last query (both kept between calls, e.g.
/// CollisionScratch::entry_stamp/stamp; cleared when the id wraps). The
/// visited set and order depend only on the grid and the query sphere.
/// No allocation, no exception.
template <class Visit>
inline void query_static_grid(const StaticSphereGrid& grid, const Vec3& c, double r,
                              std::uint32_t* stamps, std::uint32_t& stamp, Visit&& visit) noexcept {
  const Vec3 ext = Vec3::Constant(r + kMargin);
  Eigen::Vector3i first, last;
  if (!grid.cell_range(c - ext, c + ext, first, last)) return;
  if (++stamp == 0) {  // wrapped: forget every stamp
    std::fill(stamps, stamps + grid.num_entries, 0u);
    stamp = 1;
  }
  const std::uint32_t id = stamp;
  const std::int32_t* cell_start = grid.cell_start.data();
  const float* item_x = grid.item_x.data();
  const float* item_y = grid.item_y.data();
  const float* item_z = grid.item_z.data();
  const float* item_r = grid.item_radius.data();
  const std::int32_t* item_entry = grid.item_entry.data();
  const GridEntry* entries = grid.entries.data();
  constexpr int kChunk = 64;
  std::int32_t candidates[kChunk];
  float gap[kChunk];
  const Vec3 rel = c - grid.origin;
  const float qx = static_cast<float>(rel.x());
  const float qy = static_cast<float>(rel.y());
  const float qz = static_cast<float>(rel.z());
  const float qr = static_cast<float>(r) * (1.0f + 1e-6f) + grid.float_slack;
  for (int z = first.z(); z <= last.z(); ++z) {
    for (int y = first.y(); y <= last.y(); ++y) {
      // Cells first.x..last.x of a row are one contiguous range of items.
      int k = cell_start[grid.cell_index(first.x(), y, z)];
      const int k_end = cell_start[grid.cell_index(last.x(), y, z) + 1];
      for (; k < k_end; k += kChunk) {
        const int m = std::min(k_end - k, kChunk);
        const float* ix = item_x + k;
        const float* iy = item_y + k;
        const float* iz = item_z + k;
        const float* ir = item_r + k;
        int hits = 0;
        for (int i = 0; i < m; ++i) {  // vectorized: no branch, no dependency
          const float dx = ix[i] - qx, dy = iy[i] - qy, dz = iz[i] - qz;
          const float sr = ir[i] + qr;
          gap[i] = dx * dx + dy * dy + dz * dz - sr * sr;
          hits += gap[i] <= 0.0f ? 1 : 0;
        }
        if (hits == 0) continue;
        int n = 0;
        for (int i = 0; n < hits; ++i) {  // compaction, stops at the last hit
          candidates[n] = k + i;
          n += gap[i] <= 0.0f ? 1 : 0;
        }
        for (int i = 0; i < n; ++i) {
          // Every copy of an entry gives the same answer: test it once.
          const std::int32_t e = item_entry[candidates[i]];
          if (stamps[e] == id) continue;
          stamps[e] = id;
          visit(entries[e]);
        }
      }
    }
  }
}

}  // namespace numen::core::collision_detail
