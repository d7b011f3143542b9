/// @file trocar_placement.cpp
/// Trocar (RCM) estimators for recorded instrument motion (see trocar_placement.hpp).

#include "numen/sim/scene/trocar_placement.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

core::Vec3 centroid_of(const Trajectory& trajectory) {
  core::Vec3 c = core::Vec3::Zero();
  for (std::size_t i = 0; i < trajectory.size(); ++i) c += trajectory[i].pose.position;
  return c / static_cast<double>(trajectory.size());
}

/// Distance from point x to the line through p along unit d.
double line_distance(const core::Vec3& x, const core::Vec3& p, const core::Vec3& d) {
  const core::Vec3 r = x - p;
  return (r - r.dot(d) * d).norm();
}

}  // namespace

AxisIntersection least_squares_axis_intersection(const Trajectory& trajectory, int axis_column) {
  if (axis_column < 0 || axis_column > 2) {
    fail_at_key("trocar.axis_column", "must be 0 (x), 1 (y) or 2 (z), got " + std::to_string(axis_column));
  }
  if (trajectory.empty()) fail_at_key("trocar.trajectory", "the trajectory is empty");
  const std::size_t n = trajectory.size();
  // Centre the positions for conditioning: x = c + y, solve A y = b.
  const core::Vec3 c = centroid_of(trajectory);
  core::Mat3 a = core::Mat3::Zero();
  core::Vec3 b = core::Vec3::Zero();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const TrajectorySample s = trajectory[i];
    const core::Vec3 d = s.pose.orientation.toRotationMatrix().col(axis_column);
    const core::Mat3 projector = core::Mat3::Identity() - d * d.transpose();
    a += projector;
    b += projector * (s.pose.position - c);
  }
  a /= static_cast<double>(n);
  b /= static_cast<double>(n);
  const Eigen::SelfAdjointEigenSolver<core::Mat3> eig(a);
  AxisIntersection out;
  out.samples = n;
  out.conditioning = eig.eigenvalues().minCoeff();
  if (!(out.conditioning >= 1e-10)) {
    std::ostringstream os;
    os << "the tool axes are (nearly) parallel (conditioning " << out.conditioning
       << "): their intersection is undefined";
    fail_at_key("trocar.trajectory", os.str());
  }
  // A is symmetric positive definite: solve with its eigen-decomposition.
  const core::Vec3 y =
      eig.eigenvectors() *
      ((eig.eigenvectors().transpose() * b).array() / eig.eigenvalues().array()).matrix();
  out.point = c + y;
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const TrajectorySample s = trajectory[i];
    const core::Vec3 d = s.pose.orientation.toRotationMatrix().col(axis_column);
    const double r = line_distance(out.point, s.pose.position, d);
    sum_sq += r * r;
    out.max_residual = std::max(out.max_residual, r);
  }
  out.rms_residual = std::sqrt(sum_sq / static_cast<double>(n));
  return out;
}

ApproachTrocar trocar_from_approach(const Trajectory& trajectory, double standoff_m) {
  if (!std::isfinite(standoff_m) || standoff_m < 0.0) {
    fail_at_key("trocar.standoff", "must be finite and >= 0 m, got " + std::to_string(standoff_m));
  }
  if (trajectory.empty()) fail_at_key("trocar.trajectory", "the trajectory is empty");
  const std::size_t n = trajectory.size();
  ApproachTrocar out;
  out.centroid = centroid_of(trajectory);
  core::Vec3 mean_z = core::Vec3::Zero();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const TrajectorySample s = trajectory[i];
    mean_z += s.pose.orientation.toRotationMatrix().col(2);
  }
  mean_z /= static_cast<double>(n);
  out.approach_consistency = mean_z.norm();
  if (!(out.approach_consistency >= 1e-6)) {
    fail_at_key("trocar.trajectory", "the tip z axes average to zero: no mean approach direction");
  }
  out.approach = mean_z / out.approach_consistency;
  out.point = out.centroid - standoff_m * out.approach;
  double sum_sq = 0.0;
  out.min_depth = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const TrajectorySample s = trajectory[i];
    const core::Vec3 d = s.pose.orientation.toRotationMatrix().col(2);
    const double r = line_distance(out.point, s.pose.position, d);
    sum_sq += r * r;
    const double depth = (s.pose.position - out.point).norm();
    out.min_depth = std::min(out.min_depth, depth);
    out.max_depth = std::max(out.max_depth, depth);
  }
  out.rms_axis_distance = std::sqrt(sum_sq / static_cast<double>(n));
  return out;
}

}  // namespace numen::sim
