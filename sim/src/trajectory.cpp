/// @file trajectory.cpp
/// Uniformly sampled target motion: interpolation, finite-difference twist,
/// placement and resampling (see trajectory.hpp).

#include "numen/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "numen/sim/input_error.hpp"

namespace numen::sim {
namespace {

/// Below this norm of the quaternion's vector part (≈ half the angle, rad)
/// the series forms are used; their error is O(n²) relative, i.e. < 1e-16.

/// A time within this fraction of a period of a sample instant is that
/// instant, so that at(i · period) returns sample i bit for bit.
constexpr double kSnap = 1e-9;

[[noreturn]] void fail(const std::string& key, const std::string& message) {
  throw InputError("", 0, 0, key, message);
}

bool finite(const core::Vec3& v) { return v.allFinite(); }

}  // namespace

core::Quat slerp_shortest(const core::Quat& q0, const core::Quat& q1, double s) noexcept {
  const core::Vec3 v = core::quat_log(q1 * q0.conjugate());
  core::Quat q = core::quat_exp(s * v) * q0;
  q.normalize();
  return q;
}

Trajectory::Trajectory(double period, std::vector<core::Pose> poses, std::vector<double> jaw) {
  if (!std::isfinite(period) || period <= 0.0) {
    fail("trajectory.period", "must be finite and > 0 s, got " + format_input_number(period));
  }
  if (poses.empty()) fail("trajectory.samples", "a trajectory needs at least one sample");
  if (!jaw.empty() && jaw.size() != poses.size()) {
    fail("trajectory.jaw", "has " + std::to_string(jaw.size()) + " values for " +
                               std::to_string(poses.size()) + " poses");
  }
  period_ = period;
  samples_.resize(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::string where = "trajectory.samples[" + std::to_string(i) + "]";
    TrajectorySample& s = samples_[i];
    s.time = static_cast<double>(i) * period;
    s.pose.position = poses[i].position;
    if (!finite(s.pose.position)) fail(where + ".position", "is not finite");
    if (s.pose.position.stableNorm() > kMaxTargetDistance) {
      fail(where + ".position", "the target at " + format_input_number(s.time) + " s is " +
                                    format_input_number(s.pose.position.stableNorm()) +
                                    " m from the origin; a target beyond " +
                                    format_input_number(kMaxTargetDistance) +
                                    " m is not instrument motion (a wrong unit or a corrupt input?)");
    }
    core::Quat q = poses[i].orientation;
    const double norm = q.norm();
    if (!std::isfinite(norm) || norm < 1e-9) {
      fail(where + ".orientation", "quaternion is not finite or has zero norm");
    }
    q.coeffs() /= norm;
    // Sign continuity: q and -q are the same rotation; keep the one closest to
    // the previous sample (the first one with w >= 0).
    const double dot = i == 0 ? q.w() : q.dot(samples_[i - 1].pose.orientation);
    if (dot < 0.0) q.coeffs() = -q.coeffs();
    s.pose.orientation = q;
    s.jaw = jaw.empty() ? 0.0 : jaw[i];
    if (!std::isfinite(s.jaw)) fail(where + ".jaw", "is not finite");
  }
}

double Trajectory::duration() const noexcept {
  return samples_.size() <= 1 ? 0.0 : static_cast<double>(samples_.size() - 1) * period_;
}

TrajectorySample Trajectory::at(double t) const noexcept {
  if (samples_.empty()) return TrajectorySample{};
  const std::size_t last = samples_.size() - 1;
  if (!(t > 0.0) || last == 0) {  // also NaN
    TrajectorySample s = samples_.front();
    s.time = 0.0;
    return s;
  }
  const double u = t / period_;
  if (u >= static_cast<double>(last)) {
    TrajectorySample s = samples_.back();
    s.time = duration();
    return s;
  }
  const double nearest = std::round(u);
  if (std::abs(u - nearest) <= kSnap) {
    TrajectorySample s = samples_[static_cast<std::size_t>(nearest)];
    s.time = t;
    return s;
  }
  std::size_t i = static_cast<std::size_t>(std::floor(u));
  if (i >= last) i = last - 1;
  const double f = u - static_cast<double>(i);
  const TrajectorySample& a = samples_[i];
  const TrajectorySample& b = samples_[i + 1];
  TrajectorySample s;
  s.time = t;
  s.pose.position = a.pose.position + f * (b.pose.position - a.pose.position);
  s.pose.orientation = slerp_shortest(a.pose.orientation, b.pose.orientation, f);
  s.jaw = a.jaw + f * (b.jaw - a.jaw);
  return s;
}

core::Twist Trajectory::twist_at(double t) const noexcept {
  core::Twist twist;
  if (samples_.size() < 2 || !(t >= 0.0)) return twist;
  const std::size_t last = samples_.size() - 1;
  const double u = t / period_;
  if (u > static_cast<double>(last) + kSnap) return twist;
  const double nearest = std::round(u);
  double fi = std::abs(u - nearest) <= kSnap ? nearest : std::floor(u);
  std::size_t i = static_cast<std::size_t>(fi);
  if (i >= last) i = last - 1;
  const TrajectorySample& a = samples_[i];
  const TrajectorySample& b = samples_[i + 1];
  const double inv = 1.0 / period_;
  twist.linear = (b.pose.position - a.pose.position) * inv;
  twist.angular = core::quat_log(b.pose.orientation * a.pose.orientation.conjugate()) * inv;
  return twist;
}

core::Vec3 apply(const Placement& placement, const core::Vec3& p) noexcept {
  return placement.pose.position +
         placement.pose.orientation.normalized() * (placement.scale * (p - placement.origin));
}

Trajectory transformed(const Trajectory& trajectory, const Placement& placement) {
  if (!std::isfinite(placement.scale) || placement.scale <= 0.0) {
    fail("placement.scale", "must be finite and > 0, got " + format_input_number(placement.scale));
  }
  const double norm = placement.pose.orientation.norm();
  if (!std::isfinite(norm) || norm < 1e-9) {
    fail("placement.orientation", "quaternion is not finite or has zero norm");
  }
  if (!finite(placement.pose.position) || !finite(placement.origin)) {
    fail("placement.position", "origin and position must be finite");
  }
  if (trajectory.empty()) return Trajectory{};
  const core::Quat r = placement.pose.orientation.normalized();
  std::vector<core::Pose> poses(trajectory.size());
  std::vector<double> jaw(trajectory.size());
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    poses[i].position = apply(placement, trajectory[i].pose.position);
    poses[i].orientation = r * trajectory[i].pose.orientation;
    jaw[i] = trajectory[i].jaw;
  }
  return Trajectory(trajectory.period(), std::move(poses), std::move(jaw));
}

Trajectory resample(const Trajectory& trajectory, double dt) {
  if (!std::isfinite(dt) || dt <= 0.0) {
    fail("resample.dt", "must be finite and > 0 s, got " + format_input_number(dt));
  }
  if (trajectory.empty()) fail("resample.trajectory", "cannot resample an empty trajectory");
  const double m = trajectory.duration() / dt;
  const double last = std::floor(m + kSnap * std::max(1.0, m));
  if (!(last < 1e9)) fail("resample.dt", "gives more than 1e9 samples; dt is too small");
  const std::size_t n = static_cast<std::size_t>(last) + 1;
  std::vector<core::Pose> poses(n);
  std::vector<double> jaw(n);
  for (std::size_t k = 0; k < n; ++k) {
    const TrajectorySample s = trajectory.at(static_cast<double>(k) * dt);
    poses[k] = s.pose;
    jaw[k] = s.jaw;
  }
  return Trajectory(dt, std::move(poses), std::move(jaw));
}

}  // namespace numen::sim
