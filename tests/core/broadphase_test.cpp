// Broad phase (core/src/contact/broadphase.cpp): the static sphere grid lists every
// sphere in every cell its box overlaps, queries return a superset of the
// overlapping spheres, sizes stay bounded, and the sort-and-sweep order is a
// pure function of the keys.
#include "numen/core/broadphase.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "numen/core/model.hpp"

namespace numen::core {
namespace {

std::vector<Sphere> random_spheres(std::mt19937& rng, int n, double half_width, double rmin,
                                   double rmax) {
  std::uniform_real_distribution<double> pos(-half_width, half_width);
  std::uniform_real_distribution<double> rad(rmin, rmax);
  std::vector<Sphere> out(static_cast<std::size_t>(n));
  for (Sphere& s : out) {
    s.center = Vec3(pos(rng), pos(rng), pos(rng));
    s.radius = rad(rng);
  }
  return out;
}

bool box_overlap(const Vec3& amin, const Vec3& amax, const Vec3& bmin, const Vec3& bmax) {
  return (amin.array() <= bmax.array()).all() && (bmin.array() <= amax.array()).all();
}

/// Spheres listed in the cells of the query box [lo, hi].
std::set<int> query(const StaticSphereGrid& grid, const Vec3& lo, const Vec3& hi) {
  std::set<int> out;
  Eigen::Vector3i f, l;
  if (!grid.cell_range(lo, hi, f, l)) return out;
  for (int z = f.z(); z <= l.z(); ++z)
    for (int y = f.y(); y <= l.y(); ++y)
      for (int x = f.x(); x <= l.x(); ++x) {
        const int c = grid.cell_index(x, y, z);
        for (int k = grid.cell_start[static_cast<std::size_t>(c)];
             k < grid.cell_start[static_cast<std::size_t>(c) + 1]; ++k)
          out.insert(grid.sphere_index[static_cast<std::size_t>(k)]);
      }
  return out;
}

void expect_csr_consistent(const StaticSphereGrid& grid) {
  ASSERT_EQ(grid.cell_start.size(), static_cast<std::size_t>(grid.num_cells()) + 1);
  ASSERT_EQ(grid.entries.size(), static_cast<std::size_t>(grid.num_entries));
  EXPECT_EQ(grid.cell_start.front(), 0);
  EXPECT_EQ(grid.cell_start.back(), grid.num_items());
  EXPECT_EQ(grid.item_entry.size(), grid.sphere_index.size());
  EXPECT_EQ(grid.item_x.size(), grid.sphere_index.size());
  EXPECT_EQ(grid.item_y.size(), grid.sphere_index.size());
  EXPECT_EQ(grid.item_z.size(), grid.sphere_index.size());
  EXPECT_EQ(grid.item_radius.size(), grid.sphere_index.size());
  for (std::size_t c = 0; c + 1 < grid.cell_start.size(); ++c) {
    ASSERT_LE(grid.cell_start[c], grid.cell_start[c + 1]);
    std::set<int> in_cell;
    for (int k = grid.cell_start[c]; k < grid.cell_start[c + 1]; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const int e = grid.item_entry[kk];
      ASSERT_GE(e, 0);
      ASSERT_LT(e, grid.num_entries);
      const GridEntry& en = grid.entries[static_cast<std::size_t>(e)];
      EXPECT_EQ(en.sphere, grid.sphere_index[kk]);
      // The compact copy is the entry's sphere relative to the origin, in float.
      const Vec3 rel = en.center - grid.origin;
      EXPECT_EQ(grid.item_x[kk], static_cast<float>(rel.x()));
      EXPECT_EQ(grid.item_y[kk], static_cast<float>(rel.y()));
      EXPECT_EQ(grid.item_z[kk], static_cast<float>(rel.z()));
      EXPECT_EQ(grid.item_radius[kk], static_cast<float>(en.radius));
      EXPECT_TRUE(in_cell.insert(e).second) << "entry " << e << " twice in cell " << c;
    }
  }
}

TEST(BroadphaseGrid, EmptyListGivesAnEmptyGrid) {
  StaticSphereGrid grid;
  build_static_grid({}, 0.0, grid);
  EXPECT_TRUE(grid.empty());
  Eigen::Vector3i f, l;
  EXPECT_FALSE(grid.cell_range(Vec3::Constant(-1), Vec3::Constant(1), f, l));
}

TEST(BroadphaseGrid, QueriesReturnEveryOverlappingSphere) {
  std::mt19937 rng(1234);
  const std::vector<Sphere> spheres = random_spheres(rng, 600, 0.1, 0.004, 0.012);
  StaticSphereGrid grid;
  build_static_grid(spheres, 0.0, grid);
  ASSERT_FALSE(grid.empty());
  EXPECT_EQ(grid.num_entries, 600);
  EXPECT_GT(grid.num_cells(), 8);  // a real subdivision, not a single bucket
  expect_csr_consistent(grid);

  // Auto cell size: about the mean diameter.
  double mean_r = 0.0;
  for (const Sphere& s : spheres) mean_r += s.radius / 600.0;
  EXPECT_NEAR(grid.cell_size, 2.0 * mean_r, 1e-12);

  // Every entry is listed at least once.
  std::vector<int> seen(600, 0);
  for (int e : grid.item_entry) ++seen[static_cast<std::size_t>(e)];
  for (int s : seen) EXPECT_GE(s, 1);

  std::uniform_real_distribution<double> pos(-0.13, 0.13);
  std::uniform_real_distribution<double> rad(0.0, 0.03);
  int nonempty = 0;
  for (int q = 0; q < 2000; ++q) {
    const Vec3 c(pos(rng), pos(rng), pos(rng));
    const double r = rad(rng);
    const Vec3 lo = c - Vec3::Constant(r), hi = c + Vec3::Constant(r);
    const std::set<int> got = query(grid, lo, hi);
    for (std::size_t s = 0; s < spheres.size(); ++s) {
      const Vec3 smin = spheres[s].center - Vec3::Constant(spheres[s].radius);
      const Vec3 smax = spheres[s].center + Vec3::Constant(spheres[s].radius);
      if (box_overlap(lo, hi, smin, smax)) {
        EXPECT_TRUE(got.count(static_cast<int>(s))) << "query " << q << " misses sphere " << s;
        ++nonempty;
      }
    }
    // And it is a real cull: far fewer candidates than spheres.
    EXPECT_LT(got.size(), spheres.size() / 4);
  }
  EXPECT_GT(nonempty, 100);
}

TEST(BroadphaseGrid, ExplicitCellSizeIsKept) {
  std::mt19937 rng(7);
  const std::vector<Sphere> spheres = random_spheres(rng, 100, 1.0, 0.05, 0.1);
  StaticSphereGrid grid;
  build_static_grid(spheres, 0.5, grid);
  EXPECT_DOUBLE_EQ(grid.cell_size, 0.5);
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(grid.dims[k],
              static_cast<int>(std::ceil((grid.bounds_max[k] - grid.bounds_min[k]) / 0.5)));
  EXPECT_EQ(grid.origin, grid.bounds_min);
  expect_csr_consistent(grid);
}

TEST(BroadphaseGrid, SizesStayBoundedForSparseOrUnevenSets) {
  std::mt19937 rng(99);
  // Tiny spheres spread over a kilometre.
  std::vector<Sphere> spheres = random_spheres(rng, 1000, 500.0, 0.001, 0.002);
  StaticSphereGrid grid;
  build_static_grid(spheres, 0.0, grid);
  EXPECT_LE(grid.num_cells(), 32 * 1000);
  EXPECT_LE(static_cast<std::size_t>(grid.num_items()), 32u * 1000u);
  expect_csr_consistent(grid);
  // One huge sphere among small ones.
  spheres = random_spheres(rng, 500, 0.1, 0.001, 0.002);
  spheres.push_back(Sphere{Vec3::Zero(), 1.0});
  build_static_grid(spheres, 0.0, grid);
  EXPECT_LE(grid.num_cells(), 32 * 501);
  EXPECT_LE(static_cast<std::size_t>(grid.num_items()), 32u * 501u);
  expect_csr_consistent(grid);
  const std::set<int> got = query(grid, Vec3::Constant(0.9), Vec3::Constant(0.95));
  EXPECT_TRUE(got.count(500));
}

TEST(BroadphaseGrid, ObstacleEntriesCarryTheirObstacleAndMaterial) {
  std::vector<Sphere> spheres = {
      {Vec3(0, 0, 0), 0.1}, {Vec3(1, 0, 0), 0.1}, {Vec3(2, 0, 0), 0.1}, {Vec3(3, 0, 0), 0.1}};
  std::vector<Obstacle> obstacles(3);
  obstacles[0].type = ShapeType::kPlane;
  obstacles[1].type = ShapeType::kSphereSet;
  obstacles[1].sphere_begin = 0;
  obstacles[1].sphere_count = 3;
  obstacles[1].material = 1;
  obstacles[2].type = ShapeType::kSphereSet;  // shares sphere 2 with obstacle 1
  obstacles[2].sphere_begin = 2;
  obstacles[2].sphere_count = 2;
  obstacles[2].material = 2;
  StaticSphereGrid grid;
  build_static_grid(spheres, obstacles, 0.0, grid);
  EXPECT_EQ(grid.num_entries, 5);
  expect_csr_consistent(grid);
  std::set<std::tuple<int, int, int, int>> entries;  // entry, sphere, obstacle, material
  for (std::size_t e = 0; e < grid.entries.size(); ++e) {
    const GridEntry& en = grid.entries[e];
    entries.insert({static_cast<int>(e), en.sphere, en.obstacle, en.material});
    EXPECT_EQ(en.center, spheres[static_cast<std::size_t>(en.sphere)].center);
  }
  const std::set<std::tuple<int, int, int, int>> expected = {
      {0, 0, 1, 1}, {1, 1, 1, 1}, {2, 2, 1, 1}, {3, 2, 2, 2}, {4, 3, 2, 2}};
  EXPECT_EQ(entries, expected);
}

TEST(BroadphaseGrid, CellRangeRejectsBoxesOutsideAndNaN) {
  std::vector<Sphere> spheres = {{Vec3(0, 0, 0), 1.0}, {Vec3(4, 0, 0), 1.0}};
  StaticSphereGrid grid;
  build_static_grid(spheres, 1.0, grid);
  Eigen::Vector3i f, l;
  EXPECT_FALSE(grid.cell_range(Vec3(0, 0, 2.5), Vec3(1, 1, 3), f, l));
  EXPECT_FALSE(grid.cell_range(Vec3(6, 0, 0), Vec3(7, 1, 1), f, l));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(grid.cell_range(Vec3(nan, 0, 0), Vec3(nan, 0, 0), f, l));
  ASSERT_TRUE(grid.cell_range(Vec3(-5, -5, -5), Vec3(50, 50, 50), f, l));  // clamped
  EXPECT_EQ(f, Eigen::Vector3i::Zero());
  EXPECT_EQ(l, (grid.dims - Eigen::Vector3i::Ones()).eval());
}

TEST(BroadphaseSweep, OrderIsSortedWithIndexTieBreakWhateverTheStart) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> key(0, 6);  // many ties
  const int n = 40;
  std::vector<Vec3> mins(n);
  for (Vec3& m : mins) m = Vec3(0.5 * key(rng), 0.0, 0.0);
  std::vector<std::int32_t> reference(n);
  std::iota(reference.begin(), reference.end(), 0);
  std::stable_sort(reference.begin(), reference.end(), [&](int a, int b) {
    return mins[static_cast<std::size_t>(a)].x() < mins[static_cast<std::size_t>(b)].x();
  });
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::int32_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    sort_sweep_order(mins.data(), 0, order.data(), n);
    EXPECT_EQ(order, reference);
  }
  // Sorting along another axis uses that axis.
  std::vector<Vec3> ymins = {Vec3(0, 3, 0), Vec3(0, 1, 0), Vec3(0, 2, 0)};
  std::vector<std::int32_t> order = {0, 1, 2};
  sort_sweep_order(ymins.data(), 1, order.data(), 3);
  EXPECT_EQ(order, (std::vector<std::int32_t>{1, 2, 0}));
}

}  // namespace
}  // namespace numen::core
