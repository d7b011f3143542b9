/// @file tissue_dimple.cpp
/// The tools' dimples on an organ given by its material, as the outputs draw them
/// (tissue_dimple.hpp; the page's sim/viewer/js/tissue_dimple.js does the same).

#include "view/tissue_dimple.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace numen::sim {

double hertz_surface_displacement(double rho, double radius, double depth) noexcept {
  if (!(depth > 0.0)) return 0.0;
  const double a = std::sqrt(radius * depth);
  if (rho <= a) return depth - rho * rho / (2.0 * radius);
  const double s = a / rho;
  return depth / std::numbers::pi * ((2.0 - 1.0 / (s * s)) * std::asin(s) + std::sqrt(1.0 - s * s) / s);
}

void vertex_normals(std::span<const core::Vec3> points, std::span<const std::array<std::uint32_t, 3>> triangles,
                    std::span<core::Vec3> normals) noexcept {
  std::fill(normals.begin(), normals.end(), core::Vec3::Zero());
  for (const auto& t : triangles) {
    if (t[0] >= points.size() || t[1] >= points.size() || t[2] >= points.size()) continue;
    const core::Vec3 n = (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]);
    for (const std::uint32_t v : t) normals[v] += n;
  }
  for (core::Vec3& n : normals) {
    const double len = n.norm();
    n = len > 0.0 ? core::Vec3(n / len) : core::Vec3::Zero();
  }
}

double press_tissue_dimples(std::span<core::Vec3> points, std::span<const core::Vec3> normals,
                            std::span<const DimpleSphere> spheres, std::span<double> moves) noexcept {
  const std::size_t count = std::min({points.size(), normals.size(), moves.size()});
  std::fill(moves.begin(), moves.begin() + static_cast<std::ptrdiff_t>(count), 0.0);
  core::Vec3 lo = core::Vec3::Constant(HUGE_VAL), hi = core::Vec3::Constant(-HUGE_VAL);
  for (std::size_t i = 0; i < count; ++i) {
    lo = lo.cwiseMin(points[i]);
    hi = hi.cwiseMax(points[i]);
  }
  const auto reaches = [&](const DimpleSphere& s) {
    return s.radius > 0.0 && (s.centre.array() > lo.array() - s.radius).all() &&
           (s.centre.array() < hi.array() + s.radius).all();
  };
  for (const DimpleSphere& s : spheres) {
    if (!reaches(s)) continue;
    const double r = s.radius;
    std::size_t best = count;
    double best2 = r * r;
    for (std::size_t i = 0; i < count; ++i) {
      const double d2 = (points[i] - s.centre).squaredNorm();
      if (d2 < best2) best2 = d2, best = i;
    }
    if (best == count) continue;
    const core::Vec3 n0 = normals[best];
    const double depth = r - (s.centre - points[best]).dot(n0);
    if (!(depth > 0.0)) continue;
    const double reach = kDimpleReachRadii * std::sqrt(r * depth);
    const double floor = hertz_surface_displacement(reach, r, depth);
    const double level = depth - r;  // the nearest vertex's place along the axis from the centre
    for (std::size_t i = 0; i < count; ++i) {
      if (!(normals[i].dot(n0) > 0.0)) continue;
      const core::Vec3 e = points[i] - s.centre;
      const double along = e.dot(n0);
      if (!(std::abs(along - level) < reach)) continue;
      const double rho = (e - along * n0).norm();
      if (!(rho < reach)) continue;
      moves[i] = std::max(moves[i], hertz_surface_displacement(rho, r, depth) - floor);
    }
  }
  double largest = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    if (!(moves[i] > 0.0)) continue;
    points[i] -= moves[i] * normals[i];
    largest = std::max(largest, moves[i]);
  }
  // What is still inside a sphere onto its surface: the exit of the line p − t n from it.
  for (const DimpleSphere& s : spheres) {
    if (!reaches(s)) continue;
    const double r2 = s.radius * s.radius;
    for (std::size_t i = 0; i < count; ++i) {
      const core::Vec3 e = points[i] - s.centre;
      const double e2 = e.squaredNorm();
      if (!(e2 < r2)) continue;
      const double en = e.dot(normals[i]);
      const double t = en + std::sqrt(en * en - e2 + r2);
      points[i] -= t * normals[i];
      largest = std::max(largest, moves[i] + t);
    }
  }
  return largest;
}

}  // namespace numen::sim
