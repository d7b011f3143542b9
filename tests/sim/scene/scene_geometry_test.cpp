// Tests of sim/scene: the default scene's geometry keeps its promise (the recorded tool tip
// goes at least 10 mm into the tissue and into the organ).
#include "numen/sim/scene/scene.hpp"

#include <gtest/gtest.h>

#include "lattice_scene.hpp"
#include "sanitizer.hpp"
#include "scene_text.hpp"
#include "temp_dir.hpp"

#include "numen/core/data.hpp"
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "numen/hal/device/device_config.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/input/input_error.hpp"

#include "articulation/joint_system.hpp"
#include "build_features.hpp"

namespace {


using numen::core::ShapeType;
using numen::core::Sphere;
using numen::core::Vec3;
using numen::sim::load_scene;
using numen::sim::Scene;

// ---------------------------------------------------------------- default scene geometry

/// The spheres of a sphere set bucketed in a uniform grid, for fast "is this
/// point covered by the union?" queries (brute force over the 27 cells around).
class SphereUnion {
 public:
  explicit SphereUnion(std::vector<Sphere> spheres) : spheres_(std::move(spheres)) {
    double r_max = 0.0;
    lo_ = Vec3::Constant(1e300);
    Vec3 hi = Vec3::Constant(-1e300);
    for (const Sphere& sp : spheres_) {
      r_max = std::max(r_max, sp.radius);
      lo_ = lo_.cwiseMin(sp.center - Vec3::Constant(sp.radius));
      hi = hi.cwiseMax(sp.center + Vec3::Constant(sp.radius));
    }
    cell_ = 2.0 * r_max;
    for (int k = 0; k < 3; ++k) n_[k] = static_cast<int>(std::ceil((hi[k] - lo_[k]) / cell_)) + 1;
    cells_.resize(static_cast<std::size_t>(n_[0] * n_[1] * n_[2]));
    for (std::size_t i = 0; i < spheres_.size(); ++i) cells_[index(cell_of(spheres_[i].center))].push_back(i);
    centre_ = 0.5 * (lo_ + hi);
    bound_ = 0.5 * (hi - lo_).norm();
  }
  /// True if `p` lies strictly inside one of the spheres.
  bool covered(const Vec3& p) const {
    const Eigen::Vector3i c = cell_of(p);
    for (int i = c.x() - 1; i <= c.x() + 1; ++i)
      for (int j = c.y() - 1; j <= c.y() + 1; ++j)
        for (int k = c.z() - 1; k <= c.z() + 1; ++k) {
          if (i < 0 || j < 0 || k < 0 || i >= n_[0] || j >= n_[1] || k >= n_[2]) continue;
          for (std::size_t s : cells_[index(Eigen::Vector3i(i, j, k))]) {
            const Sphere& sp = spheres_[s];
            if ((p - sp.center).squaredNorm() < sp.radius * sp.radius) return true;
          }
        }
    return false;
  }
  /// Distance from `p` beyond which no sphere lies.
  double reach(const Vec3& p) const { return (p - centre_).norm() + bound_; }
  const std::vector<Sphere>& spheres() const { return spheres_; }

 private:
  Eigen::Vector3i cell_of(const Vec3& p) const {
    return ((p - lo_) / cell_).array().floor().cast<int>().matrix();
  }
  std::size_t index(const Eigen::Vector3i& c) const {
    return static_cast<std::size_t>((c.x() * n_[1] + c.y()) * n_[2] + c.z());
  }
  std::vector<Sphere> spheres_;
  std::vector<std::vector<std::size_t>> cells_;
  Vec3 lo_, centre_;
  double cell_ = 1.0, bound_ = 0.0;
  int n_[3] = {0, 0, 0};
};

constexpr double kMarchStep = 0.00025;  // 0.25 mm

/// Depth of `p` below the union: distance to the nearest point not covered by
/// any sphere, estimated as the smallest distance, over `dirs`, at which a
/// march in 0.25 mm steps first finds an uncovered point. Enclosed voids count.
double depth_below_union(const SphereUnion& u, const Vec3& p, const std::vector<Vec3>& dirs) {
  if (!u.covered(p)) return 0.0;
  double best = u.reach(p);
  for (const Vec3& d : dirs)
    for (double s = kMarchStep; s < best; s += kMarchStep)
      if (!u.covered(p + s * d)) {
        best = s;
        break;
      }
  return best;
}

/// Depth of `p` inside the solid bounded by the union's outer surface:
/// smallest distance, over `dirs`, at which a ray leaves the union for the
/// last time (enclosed voids do not count as outside).
double depth_to_exterior(const SphereUnion& u, const Vec3& p, const std::vector<Vec3>& dirs) {
  if (!u.covered(p)) return 0.0;
  const double reach = u.reach(p);
  double best = reach;
  for (const Vec3& d : dirs) {
    double last_covered = 0.0;
    for (double s = kMarchStep; s < reach; s += kMarchStep)
      if (u.covered(p + s * d)) last_covered = s;
    best = std::min(best, last_covered + kMarchStep);
  }
  return best;
}

std::vector<Vec3> cube_directions() {  // the 26 neighbours of a cube cell
  std::vector<Vec3> d;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j)
      for (int k = -1; k <= 1; ++k)
        if (i || j || k) d.push_back(Vec3(i, j, k).normalized());
  return d;
}

std::vector<Vec3> dense_directions(int n) {  // the 26 plus n near-uniform (Fibonacci) ones
  std::vector<Vec3> d = cube_directions();
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z);
    d.push_back(Vec3(r * std::cos(golden * i), r * std::sin(golden * i), z));
  }
  return d;
}

const Scene& lattice_scene() {
  static const Scene s = load_scene(numen::test::lattice_scene_path());
  return s;
}

const numen::core::Obstacle* obstacle(const Scene& s, const std::string& name) {
  for (const auto& o : s.model.obstacles)
    if (o.name == name) return &o;
  return nullptr;
}

SphereUnion organ_union(const Scene& s) {
  const numen::core::Obstacle* organ = obstacle(s, "organ");
  EXPECT_NE(organ, nullptr);
  if (!organ) return SphereUnion({Sphere{}});
  EXPECT_EQ(organ->type, ShapeType::kSphereSet);
  return SphereUnion(std::vector<Sphere>(s.model.static_spheres.begin() + organ->sphere_begin,
                                         s.model.static_spheres.begin() + organ->sphere_begin + organ->sphere_count));
}

/// Recorded tip positions of the default scene every 10 ms that lie inside the
/// organ's union, deepest first by depth_to_exterior() over the 26 directions.
const std::vector<std::pair<double, Vec3>>& organ_tips() {
  static const std::vector<std::pair<double, Vec3>> inside = [] {
    const Scene& s = lattice_scene();
    const SphereUnion u = organ_union(s);
    const std::vector<Vec3> coarse = cube_directions();
    std::vector<std::pair<double, Vec3>> out;
    for (int k = 0; k * 0.01 <= s.trajectory.duration(); ++k) {
      const Vec3 p = s.trajectory.at(k * 0.01).pose.position;
      const double d = depth_to_exterior(u, p, coarse);
      if (d > 0.0) out.emplace_back(d, p);
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    return out;
  }();
  return inside;
}

TEST(LatticeSceneGeometry, RecordedTipGoesAtLeast10mmIntoTheTissue) {
  NUMEN_REQUIRE_ARTICULATION();
  const Scene& s = lattice_scene();
  const numen::core::Obstacle* tissue = obstacle(s, "tissue");
  ASSERT_NE(tissue, nullptr);
  ASSERT_EQ(tissue->type, ShapeType::kPlane);
  // The solid is below the plane (against the normal).
  const Vec3 n = tissue->pose.orientation * Vec3::UnitZ();
  double depth = 0.0;
  for (std::size_t idx = 0; idx < s.trajectory.size(); ++idx) {
    const auto sample = s.trajectory[idx];
    depth = std::max(depth, -(sample.pose.position - tissue->pose.position).dot(n));
  }
  std::printf("[   info   ] recorded tip depth below the tissue plane: max %.2f mm\n", depth * 1e3);
  EXPECT_GE(depth, 0.010);
}

TEST(LatticeSceneGeometry, RecordedTipGoesAtLeast10mmIntoTheOrgan) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "checks the shipped recording against the shipped organ (data, not code): 40 s under "
      "ASan+UBSan with coverage");
  NUMEN_REQUIRE_ARTICULATION();
  // Depth inside the solid the organ's spheres bound: distance to the nearest
  // point outside the union's outer surface.
  const Scene& s = lattice_scene();
  const SphereUnion u = organ_union(s);
  const auto& inside = organ_tips();
  ASSERT_FALSE(inside.empty()) << "the recorded tip never enters the organ";
  const std::vector<Vec3> fine = dense_directions(400);
  double depth = 0.0;
  for (std::size_t i = 0; i < std::min<std::size_t>(inside.size(), 12); ++i)
    depth = std::max(depth, depth_to_exterior(u, inside[i].second, fine));
  std::printf("[   info   ] recorded tip depth inside the organ's outer surface (%zu spheres): max %.2f mm "
              "(26 directions: %.2f mm; %zu of %zu sampled positions inside)\n",
              u.spheres().size(), depth * 1e3, inside.front().first * 1e3, inside.size(),
              static_cast<std::size_t>(s.trajectory.duration() / 0.01) + 1);
  EXPECT_GE(depth, 0.010);
}

TEST(LatticeSceneGeometry, RecordedTipGoesAtLeast10mmBelowTheUnionOfTheOrgansSpheres) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "checks the shipped recording against the shipped organ (data, not code): 60 s under "
      "ASan+UBSan with coverage");
  NUMEN_REQUIRE_ARTICULATION();
  // Depth below the union itself: distance to the nearest point that no
  // sphere covers (enclosed voids count), marched along 26 + 400 directions.
  const Scene& s = lattice_scene();
  const SphereUnion u = organ_union(s);
  const auto& inside = organ_tips();
  ASSERT_FALSE(inside.empty());
  const std::vector<Vec3> fine = dense_directions(400);
  double depth26 = 0.0, depth = 0.0;
  for (const auto& c : inside) depth26 = std::max(depth26, depth_below_union(u, c.second, cube_directions()));
  for (std::size_t i = 0; i < std::min<std::size_t>(inside.size(), 40); ++i)
    depth = std::max(depth, depth_below_union(u, inside[i].second, fine));

  // Diagnosis: lattice cells of the fill whose 8 corners are all organ spheres
  // but whose centre no sphere covers are voids inside the organ.
  int interior_cells = 0, void_cells = 0;
  const auto& sp = u.spheres();
  for (std::size_t a = 0; a < sp.size(); ++a) {
    // Cells are spanned by a sphere and its 3 lattice neighbours at the pitch.
    std::vector<Vec3> nb;
    double pitch = 1e300;
    for (std::size_t b = 0; b < sp.size(); ++b)
      if (b != a) pitch = std::min(pitch, (sp[b].center - sp[a].center).norm());
    for (std::size_t b = 0; b < sp.size(); ++b)
      if (std::abs((sp[b].center - sp[a].center).norm() - pitch) < 1e-9) nb.push_back(sp[b].center - sp[a].center);
    // Take the cell in the +e1 +e2 +e3 octant of a local lattice frame.
    if (nb.size() < 6) continue;
    const Vec3 e1 = nb[0];
    Vec3 e2 = Vec3::Zero(), e3 = Vec3::Zero();
    for (const Vec3& v : nb)
      if (std::abs(v.dot(e1)) < 1e-12) {
        if (e2.isZero()) e2 = v;
        else if (std::abs(v.dot(e2)) < 1e-12) e3 = v;
      }
    if (e2.isZero() || e3.isZero()) continue;
    bool all_corners = true;
    for (int c = 1; c < 8; ++c) {
      const Vec3 corner = sp[a].center + ((c & 1) ? e1 : Vec3::Zero()) + ((c & 2) ? e2 : Vec3::Zero()) +
                          ((c & 4) ? e3 : Vec3::Zero());
      bool found = false;
      for (const Sphere& q : sp) found = found || (q.center - corner).norm() < 1e-9;
      all_corners = all_corners && found;
    }
    if (!all_corners) continue;
    ++interior_cells;
    if (!u.covered(sp[a].center + 0.5 * (e1 + e2 + e3))) ++void_cells;
  }
  std::printf("[   info   ] recorded tip depth below the union of the organ's spheres: max %.2f mm over 26+400 "
              "directions (%.2f mm over the 26 alone); %d of %d interior lattice cells have an uncovered centre\n",
              depth * 1e3, depth26 * 1e3, void_cells, interior_cells);
  EXPECT_GE(depth, 0.010) << "the union of the organ's spheres has enclosed voids: " << void_cells << " of "
                          << interior_cells
                          << " interior lattice cells have their centre uncovered (sphere_radius < spacing·√3/2)";
}

}  // namespace
