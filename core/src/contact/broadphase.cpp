/// @file broadphase.cpp
/// Static sphere grid (built at load time) and the sort-and-sweep order of the
/// dynamic bodies (paper §5, sphere-based collision).

#include "numen/core/broadphase.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "numen/core/model.hpp"

namespace numen::core {
namespace {

struct Entry {
  std::int32_t sphere;
  std::int32_t obstacle;
  std::int32_t material;
};

bool usable(const Sphere& s) {
  return s.center.allFinite() && std::isfinite(s.radius) && s.radius >= 0.0;
}

/// Sets cell_size, inv_cell_size and dims of `grid` for a cell of `cell` metres.
void set_cells(double cell, StaticSphereGrid& grid) {
  grid.cell_size = cell;
  grid.inv_cell_size = 1.0 / cell;
  for (int k = 0; k < 3; ++k) {
    const double n = std::ceil((grid.bounds_max[k] - grid.bounds_min[k]) / cell);
    grid.dims[k] = static_cast<int>(std::clamp(n, 1.0, 1.0e6));
  }
}

void build(const std::vector<Sphere>& spheres, const std::vector<Entry>& entries, double cell_size,
           StaticSphereGrid& grid) {
  grid = StaticSphereGrid{};
  if (entries.empty()) return;
  const auto& sp = [&](const Entry& e) -> const Sphere& {
    return spheres[static_cast<std::size_t>(e.sphere)];
  };

  grid.bounds_min = Vec3::Constant(std::numeric_limits<double>::infinity());
  grid.bounds_max = -grid.bounds_min;
  double radius_sum = 0.0;
  for (const Entry& e : entries) {
    const Sphere& s = sp(e);
    grid.bounds_min = grid.bounds_min.cwiseMin(s.center - Vec3::Constant(s.radius));
    grid.bounds_max = grid.bounds_max.cwiseMax(s.center + Vec3::Constant(s.radius));
    radius_sum += s.radius;
  }
  grid.origin = grid.bounds_min;
  grid.num_entries = static_cast<std::int32_t>(entries.size());

  const double n = static_cast<double>(entries.size());
  const double extent = (grid.bounds_max - grid.bounds_min).maxCoeff();
  double cell = cell_size;
  if (!(cell > 0.0) || !std::isfinite(cell)) {
    cell = 2.0 * radius_sum / n;  // the mean diameter
    if (!(cell > 0.0)) cell = extent > 0.0 ? extent / std::cbrt(n) : 1.0;
  }
  if (!(cell > 0.0)) cell = 1.0;

  // Enlarge the cells until the grid and its item list stay proportionate to
  // the number of entries (sparse scenes, or a few spheres much larger than
  // the mean one).
  const double max_cells = std::max(4096.0, 32.0 * n);
  const double max_items = std::max(4096.0, 32.0 * n);
  std::int64_t num_items = 0;
  for (;;) {
    set_cells(cell, grid);
    const double cells = static_cast<double>(grid.dims.x()) * grid.dims.y() * grid.dims.z();
    double items = 0.0;
    if (cells <= max_cells) {
      for (const Entry& e : entries) {
        const Sphere& s = sp(e);
        double c = 1.0;
        for (int k = 0; k < 3; ++k)
          c *= grid.cell_coord(s.center[k] + s.radius, k) -
               grid.cell_coord(s.center[k] - s.radius, k) + 1;
        items += c;
      }
      if (items <= max_items) {
        num_items = static_cast<std::int64_t>(items);
        break;
      }
    }
    cell *= 2.0;
  }

  // Counting pass, prefix sum, fill pass (compressed row storage).
  const int num_cells = grid.num_cells();
  grid.cell_start.assign(static_cast<std::size_t>(num_cells) + 1, 0);
  auto for_cells = [&](const Sphere& s, auto&& f) {
    const Vec3 lo = s.center - Vec3::Constant(s.radius);
    const Vec3 hi = s.center + Vec3::Constant(s.radius);
    const int x0 = grid.cell_coord(lo.x(), 0), x1 = grid.cell_coord(hi.x(), 0);
    const int y0 = grid.cell_coord(lo.y(), 1), y1 = grid.cell_coord(hi.y(), 1);
    const int z0 = grid.cell_coord(lo.z(), 2), z1 = grid.cell_coord(hi.z(), 2);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) f(grid.cell_index(x, y, z));
  };
  for (const Entry& e : entries)
    for_cells(sp(e), [&](int c) { ++grid.cell_start[static_cast<std::size_t>(c) + 1]; });
  for (int c = 0; c < num_cells; ++c)
    grid.cell_start[static_cast<std::size_t>(c) + 1] +=
        grid.cell_start[static_cast<std::size_t>(c)];
  for (std::vector<float>* v : {&grid.item_x, &grid.item_y, &grid.item_z, &grid.item_radius})
    v->resize(static_cast<std::size_t>(num_items));
  grid.item_entry.resize(static_cast<std::size_t>(num_items));
  grid.sphere_index.resize(static_cast<std::size_t>(num_items));
  grid.entries.resize(entries.size());
  std::vector<std::int32_t> fill(grid.cell_start.begin(), grid.cell_start.end() - 1);
  double max_radius = 0.0;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const Entry& e = entries[i];
    const Sphere& s = sp(e);
    max_radius = std::max(max_radius, s.radius);
    grid.entries[i] = GridEntry{s.center, s.radius, e.sphere, e.obstacle, e.material};
    const Vec3 rel = s.center - grid.origin;
    for_cells(s, [&](int c) {
      const auto pos = static_cast<std::size_t>(fill[static_cast<std::size_t>(c)]++);
      grid.item_x[pos] = static_cast<float>(rel.x());
      grid.item_y[pos] = static_cast<float>(rel.y());
      grid.item_z[pos] = static_cast<float>(rel.z());
      grid.item_radius[pos] = static_cast<float>(s.radius);
      grid.item_entry[pos] = static_cast<std::int32_t>(i);
      grid.sphere_index[pos] = e.sphere;
    });
  }
  // Float rounding: each coordinate (item and query, relative to the origin,
  // at most ~extent + radii apart from it) is off by ≤ 2⁻²⁴ of its magnitude,
  // the radii and the squared distance by a few ulps. 1e-6 of the scale covers
  // it with a wide margin (2⁻²⁴ ≈ 6e-8).
  grid.float_slack = static_cast<float>(1e-6 * (extent + 4.0 * max_radius) + 1e-12);
}

}  // namespace

void build_static_grid(const std::vector<Sphere>& spheres, double cell_size,
                       StaticSphereGrid& grid) {
  std::vector<Entry> entries;
  entries.reserve(spheres.size());
  for (std::size_t s = 0; s < spheres.size(); ++s)
    if (usable(spheres[s])) entries.push_back(Entry{static_cast<std::int32_t>(s), -1, 0});
  build(spheres, entries, cell_size, grid);
}

void build_static_grid(const std::vector<Sphere>& spheres, const std::vector<Obstacle>& obstacles,
                       double cell_size, StaticSphereGrid& grid) {
  std::vector<Entry> entries;
  for (std::size_t o = 0; o < obstacles.size(); ++o) {
    const Obstacle& ob = obstacles[o];
    if (ob.type != ShapeType::kSphereSet) continue;
    for (int s = ob.sphere_begin; s < ob.sphere_begin + ob.sphere_count; ++s) {
      if (s < 0 || static_cast<std::size_t>(s) >= spheres.size()) continue;
      if (usable(spheres[static_cast<std::size_t>(s)]))
        entries.push_back(Entry{s, static_cast<std::int32_t>(o), ob.material});
    }
  }
  build(spheres, entries, cell_size, grid);
}

void sort_sweep_order(const Vec3* aabb_min, int axis, std::int32_t* order, int count) noexcept {
  auto less = [&](std::int32_t a, std::int32_t b) {
    const double ka = aabb_min[a][axis];
    const double kb = aabb_min[b][axis];
    return ka < kb || (ka == kb && a < b);
  };
  for (int i = 1; i < count; ++i) {
    const std::int32_t v = order[i];
    int j = i - 1;
    while (j >= 0 && less(v, order[j])) {
      order[j + 1] = order[j];
      --j;
    }
    order[j + 1] = v;
  }
}

}  // namespace numen::core
