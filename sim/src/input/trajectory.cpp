/// @file trajectory.cpp
/// Target motion with uniform knots, stored or computed from a ComputedMotion:
/// interpolation, finite-difference twist and placement (see trajectory.hpp).

#include "numen/sim/input/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "numen/sim/input/input_error.hpp"
#include "numen/sim/input/computed_motion.hpp"

namespace numen::sim {
namespace {

/// A time within this fraction of a period of a sample instant is that
/// instant, so that at(i · period) returns sample i bit for bit.
constexpr double kSnap = 1e-9;

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
    fail_at_key("trajectory.period", "must be finite and > 0 s, got " + format_input_number(period));
  }
  if (poses.empty()) fail_at_key("trajectory.samples", "a trajectory needs at least one sample");
  if (!jaw.empty() && jaw.size() != poses.size()) {
    fail_at_key("trajectory.jaw", "has " + std::to_string(jaw.size()) + " values for " +
                               std::to_string(poses.size()) + " poses");
  }
  period_ = period;
  size_ = poses.size();
  samples_.resize(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::string where = "trajectory.samples[" + std::to_string(i) + "]";
    TrajectorySample& s = samples_[i];
    s.time = static_cast<double>(i) * period;
    s.pose.position = poses[i].position;
    if (!finite(s.pose.position)) fail_at_key(where + ".position", "is not finite");
    if (s.pose.position.stableNorm() > kMaxTargetDistance) {
      fail_at_key(where + ".position", "the target at " + format_input_number(s.time) + " s is " +
                                    format_input_number(s.pose.position.stableNorm()) +
                                    " m from the origin; a target beyond " +
                                    format_input_number(kMaxTargetDistance) +
                                    " m is not instrument motion (a wrong unit or a corrupt input?)");
    }
    core::Quat q = poses[i].orientation;
    const double norm = q.norm();
    if (!std::isfinite(norm) || norm < 1e-9) {
      fail_at_key(where + ".orientation", "quaternion is not finite or has zero norm");
    }
    q.coeffs() /= norm;
    // Sign continuity: q and -q are the same rotation; keep the one closest to
    // the previous sample (the first one with w >= 0).
    const double dot = i == 0 ? q.w() : q.dot(samples_[i - 1].pose.orientation);
    if (dot < 0.0) q.coeffs() = -q.coeffs();
    s.pose.orientation = q;
    s.jaw = jaw.empty() ? 0.0 : jaw[i];
    if (!std::isfinite(s.jaw)) fail_at_key(where + ".jaw", "is not finite");
  }
}

Trajectory::Trajectory(std::shared_ptr<const ComputedMotion> path, double period, std::size_t count) {
  if (!std::isfinite(period) || period <= 0.0) {
    fail_at_key("trajectory.period", "must be finite and > 0 s, got " + std::to_string(period));
  }
  if (count == 0 || !path) fail_at_key("trajectory.samples", "a trajectory needs at least one sample");
  period_ = period;
  size_ = count;
  path_ = std::move(path);
}

double Trajectory::duration() const noexcept {
  return size_ <= 1 ? 0.0 : static_cast<double>(size_ - 1) * period_;
}

TrajectorySample Trajectory::operator[](std::size_t i) const noexcept {
  if (!path_) return samples_[i];
  const double t = static_cast<double>(i) * period_;
  TrajectorySample s = path_->evaluate(std::min(t, path_->duration()));
  s.time = t;
  s.pose.position = apply(placement_, s.pose.position);
  s.pose.orientation = (placement_.pose.orientation * s.pose.orientation).normalized();
  return s;
}

std::size_t Trajectory::memory_bytes() const noexcept {
  return samples_.capacity() * sizeof(TrajectorySample) + (path_ ? path_->memory_bytes() : 0);
}

TrajectorySample Trajectory::at(double t) const noexcept {
  if (size_ == 0) return TrajectorySample{};
  const std::size_t last = size_ - 1;
  if (!(t > 0.0) || last == 0) {  // also NaN
    TrajectorySample s = (*this)[0];
    s.time = 0.0;
    return s;
  }
  const double u = t / period_;
  if (u >= static_cast<double>(last)) {
    TrajectorySample s = (*this)[last];
    s.time = duration();
    return s;
  }
  const double nearest = std::round(u);
  if (std::abs(u - nearest) <= kSnap) {
    TrajectorySample s = (*this)[static_cast<std::size_t>(nearest)];
    s.time = t;
    return s;
  }
  std::size_t i = static_cast<std::size_t>(std::floor(u));
  if (i >= last) i = last - 1;
  const double f = u - static_cast<double>(i);
  const TrajectorySample a = (*this)[i];
  const TrajectorySample b = (*this)[i + 1];
  TrajectorySample s;
  s.time = t;
  s.pose.position = a.pose.position + f * (b.pose.position - a.pose.position);
  s.pose.orientation = slerp_shortest(a.pose.orientation, b.pose.orientation, f);
  s.jaw = a.jaw + f * (b.jaw - a.jaw);
  return s;
}

core::Twist Trajectory::twist_at(double t) const noexcept {
  core::Twist twist;
  if (size_ < 2 || !(t >= 0.0)) return twist;
  const std::size_t last = size_ - 1;
  const double u = t / period_;
  if (u > static_cast<double>(last) + kSnap) return twist;
  const double nearest = std::round(u);
  double fi = std::abs(u - nearest) <= kSnap ? nearest : std::floor(u);
  std::size_t i = static_cast<std::size_t>(fi);
  if (i >= last) i = last - 1;
  const TrajectorySample a = (*this)[i];
  const TrajectorySample b = (*this)[i + 1];
  const double inv = 1.0 / period_;
  twist.linear = (b.pose.position - a.pose.position) * inv;
  twist.angular = core::quat_log(b.pose.orientation * a.pose.orientation.conjugate()) * inv;
  return twist;
}

core::Vec3 apply(const Placement& placement, const core::Vec3& p) noexcept {
  return placement.pose.position +
         placement.pose.orientation.normalized() * (placement.scale * (p - placement.origin));
}

Trajectory sample_motion(std::shared_ptr<const ComputedMotion> motion, double dt,
                         const std::string& dt_key) {
  if (!std::isfinite(dt) || dt <= 0.0) fail_at_key(dt_key, "must be finite and > 0 s, got " + format_input_number(dt));
  const double m = motion->duration() / dt;
  const double intervals = std::ceil(m - 1e-9 * std::max(1.0, m));
  if (!(intervals < 1e9)) fail_at_key(dt_key, "gives more than 1e9 samples; dt is too small");
  const std::size_t n = static_cast<std::size_t>(std::max(0.0, intervals)) + 1;
  return Trajectory(std::move(motion), dt, n);
}

Trajectory transformed(const Trajectory& trajectory, const Placement& placement) {
  if (!std::isfinite(placement.scale) || placement.scale <= 0.0) {
    fail_at_key("placement.scale", "must be finite and > 0, got " + format_input_number(placement.scale));
  }
  const double norm = placement.pose.orientation.norm();
  if (!std::isfinite(norm) || norm < 1e-9) {
    fail_at_key("placement.orientation", "quaternion is not finite or has zero norm");
  }
  if (!finite(placement.pose.position) || !finite(placement.origin)) {
    fail_at_key("placement.position", "origin and position must be finite");
  }
  if (trajectory.empty()) return Trajectory{};
  const core::Quat r = placement.pose.orientation.normalized();
  if (trajectory.path_) {
    // Compose: p'' = P2 + R2 s2 (P1 + R1 s1 (p - o1) - o2) = [P2 + R2 s2 (P1 - o2)] + R2 R1 s2 s1 (p - o1).
    Trajectory moved = trajectory;
    const Placement& inner = trajectory.placement_;
    moved.placement_.origin = inner.origin;
    moved.placement_.pose.position = apply(placement, inner.pose.position);
    moved.placement_.pose.orientation = (r * inner.pose.orientation.normalized()).normalized();
    moved.placement_.scale = placement.scale * inner.scale;
    const ComputedMotion::FarthestPoint far = moved.path_->farthest_point(moved.placement_);
    if (!(far.distance <= kMaxTargetDistance)) {
      fail_at_key("trajectory.placement",
           "the target at " + format_input_number(far.time) + " s is " +
               format_input_number(far.distance) + " m from the origin; a target beyond " +
               format_input_number(kMaxTargetDistance) +
               " m is not instrument motion (a wrong unit or a corrupt input?)");
    }
    return moved;
  }
  std::vector<core::Pose> poses(trajectory.size());
  std::vector<double> jaw(trajectory.size());
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const TrajectorySample s = trajectory[i];
    poses[i].position = apply(placement, s.pose.position);
    poses[i].orientation = r * s.pose.orientation;
    jaw[i] = s.jaw;
  }
  return Trajectory(trajectory.period(), std::move(poses), std::move(jaw));
}

}  // namespace numen::sim
