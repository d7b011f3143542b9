/// @file scripted_path.cpp
/// Scripted target motion: segment validation, start resolution, exact
/// evaluation and sampling (see scripted_path.hpp).

#include "numen/sim/input/scripted_path.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <sstream>

#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

/// Times within this of a segment boundary or of a step time count as at it (s).
constexpr double kTimeEpsilon = 1e-12;

std::string number(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

/// Message for a position `distance` m from the origin, beyond kMaxTargetDistance.
std::string too_far(double distance) {
  return "is " + number(distance) + " m from the world origin; a target beyond " +
         number(kMaxTargetDistance) + " m is not instrument motion (a wrong unit?)";
}

/// Builds "<prefix>[i].<field>" keys and throws InputError.
class Checker {
 public:
  Checker(const std::string& prefix, std::size_t index)
      : base_(prefix + "[" + std::to_string(index) + "]") {}

  [[noreturn]] void fail(const std::string& field, const std::string& message) const {
    throw InputError("", 0, 0, base_ + "." + field, message);
  }
  void finite(const std::string& field, double v) const {
    if (!std::isfinite(v)) fail(field, "must be a finite number");
  }
  void finite(const std::string& field, const core::Vec3& v) const {
    if (!v.allFinite()) fail(field, "must be finite");
  }
  /// A position (m, world): finite and within kMaxTargetDistance of the origin.
  void position(const std::string& field, const core::Vec3& v) const {
    finite(field, v);
    if (v.stableNorm() > kMaxTargetDistance) fail(field, too_far(v.stableNorm()));
  }
  void positive(const std::string& field, double v, const char* unit) const {
    if (!std::isfinite(v) || v <= 0.0) {
      fail(field, std::string("must be finite and > 0 ") + unit + ", got " + number(v));
    }
  }
  core::Quat unit(const std::string& field, const core::Quat& q) const {
    const double n = q.norm();
    if (!std::isfinite(n) || n < 1e-9) fail(field, "quaternion must be finite and non-zero");
    return core::Quat(q.coeffs() / n);
  }

 private:
  std::string base_;
};

}  // namespace

ScriptedPath::ScriptedPath(std::vector<PathSegment> segments, const TrajectorySample& start,
                           std::string key_prefix)
    : key_prefix_(std::move(key_prefix)) {
  if (segments.empty()) {
    throw InputError("", 0, 0, key_prefix_, "a scripted path needs at least one segment");
  }
  if (!start.pose.position.allFinite() || !std::isfinite(start.jaw)) {
    throw InputError("", 0, 0, key_prefix_ + ".start", "start pose and jaw must be finite");
  }
  if (start.pose.position.stableNorm() > kMaxTargetDistance)
    throw InputError("", 0, 0, key_prefix_ + ".start", "start " + too_far(start.pose.position.stableNorm()));
  TrajectorySample previous = start;
  const double start_norm = start.pose.orientation.norm();
  if (!std::isfinite(start_norm) || start_norm < 1e-9) {
    throw InputError("", 0, 0, key_prefix_ + ".start",
                     "start orientation must be finite and non-zero");
  }
  previous.pose.orientation.coeffs() /= start_norm;
  double t0 = 0.0;
  segments_.reserve(segments.size());
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const PathSegment& in = segments[i];
    const Checker check(key_prefix_, i);
    Resolved s;
    s.t0 = t0;
    s.q0 = in.orientation ? check.unit("orientation", *in.orientation) : previous.pose.orientation;
    s.q1 = s.q0;
    check.finite("angular_velocity", in.angular_velocity);
    s.spin = in.angular_velocity;
    if (in.jaw) check.finite("jaw", *in.jaw);
    s.jaw = in.jaw.value_or(previous.jaw);
    s.jaw0 = previous.jaw;

    if (const auto* line = std::get_if<LineSegment>(&in.shape)) {
      s.kind = Kind::line;
      check.positive("duration", line->duration, "s");
      s.duration = line->duration;
      s.a = line->from.value_or(previous.pose.position);
      check.position("from", s.a);
      check.position("to", line->to);
      s.b = line->to;
    } else if (const auto* circle = std::get_if<CircleSegment>(&in.shape)) {
      s.kind = Kind::circle;
      check.positive("duration", circle->duration, "s");
      s.duration = circle->duration;
      check.positive("radius", circle->radius, "m");
      check.positive("period", circle->period, "s");
      check.finite("start_phase", circle->start_phase);
      check.finite("axis", circle->axis);
      const double axis_norm = circle->axis.norm();
      if (!(axis_norm > 1e-12)) check.fail("axis", "must be a non-zero vector");
      const core::Vec3 n = circle->axis / axis_norm;
      const core::Vec3 ref = std::abs(n.x()) < 0.9 ? core::Vec3::UnitX() : core::Vec3::UnitY();
      s.e1 = (ref - ref.dot(n) * n).normalized();
      s.e2 = n.cross(s.e1);
      s.radius = circle->radius;
      s.rate = 2.0 * std::numbers::pi / circle->period;
      s.phase0 = circle->start_phase;
      const core::Vec3 radial = std::cos(s.phase0) * s.e1 + std::sin(s.phase0) * s.e2;
      if (circle->centre) {
        check.position("centre", *circle->centre);
        s.centre = *circle->centre;
      } else {
        s.centre = previous.pose.position - s.radius * radial;
      }
      if (s.centre.stableNorm() + s.radius > kMaxTargetDistance)
        check.fail("radius", "takes the circle up to " + number(s.centre.stableNorm() + s.radius) +
                                 " m from the world origin; a target beyond " +
                                 number(kMaxTargetDistance) + " m is not instrument motion");
    } else if (const auto* hold = std::get_if<HoldSegment>(&in.shape)) {
      s.kind = Kind::hold;
      check.positive("duration", hold->duration, "s");
      s.duration = hold->duration;
      s.a = hold->position.value_or(previous.pose.position);
      check.position("position", s.a);
    } else {
      const auto& step = std::get<StepSegment>(in.shape);
      s.kind = Kind::step;
      check.positive("duration", step.duration, "s");
      s.duration = step.duration;
      s.a = step.from.value_or(previous.pose.position);
      check.position("from", s.a);
      check.position("to", step.to);
      s.b = step.to;
      if (!std::isfinite(step.step_time) || step.step_time < 0.0 ||
          step.step_time > step.duration) {
        check.fail("step_time", "must be in [0, duration] = [0, " + number(step.duration) +
                                    "] s, got " + number(step.step_time));
      }
      s.step_time = step.step_time;
      if (step.to_orientation) s.q1 = check.unit("to_orientation", *step.to_orientation);
    }
    if (!std::isfinite(in.jaw_time) || in.jaw_time < 0.0 || in.jaw_time > s.duration)
      check.fail("jaw_time", "must be in [0, duration] = [0, " + number(s.duration) + "] s, got " +
                                 number(in.jaw_time));
    s.jaw_time = in.jaw_time;
    segments_.push_back(s);
    previous = evaluate_segment(s, s.duration);
    t0 += s.duration;
  }
}

double ScriptedPath::duration() const noexcept {
  const Resolved& last = segments_.back();
  return last.t0 + last.duration;
}

double ScriptedPath::segment_start(std::size_t i) const noexcept { return segments_[i].t0; }

TrajectorySample ScriptedPath::evaluate_segment(const Resolved& s, double tau) noexcept {
  TrajectorySample out;
  out.jaw = tau < s.jaw_time ? s.jaw0 + (s.jaw - s.jaw0) * (tau / s.jaw_time) : s.jaw;
  core::Quat base = s.q0;
  switch (s.kind) {
    case Kind::line:
      out.pose.position = s.a + (tau / s.duration) * (s.b - s.a);
      break;
    case Kind::circle: {
      const double phi = s.phase0 + s.rate * tau;
      out.pose.position = s.centre + s.radius * (std::cos(phi) * s.e1 + std::sin(phi) * s.e2);
      break;
    }
    case Kind::hold:
      out.pose.position = s.a;
      break;
    case Kind::step:
      if (tau + kTimeEpsilon >= s.step_time) {
        out.pose.position = s.b;
        base = s.q1;
      } else {
        out.pose.position = s.a;
      }
      break;
  }
  out.pose.orientation = core::quat_exp(s.spin * tau) * base;
  out.pose.orientation.normalize();
  return out;
}

TrajectorySample ScriptedPath::evaluate(double t) const noexcept {
  const double total = duration();
  const double tc = t > 0.0 ? std::min(t, total) : 0.0;  // NaN → 0
  // Last segment whose start is <= tc (within kTimeEpsilon).
  std::size_t lo = 0;
  std::size_t hi = segments_.size();
  while (hi - lo > 1) {
    const std::size_t mid = (lo + hi) / 2;
    if (segments_[mid].t0 <= tc + kTimeEpsilon) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const Resolved& s = segments_[lo];
  const double tau = std::clamp(tc - s.t0, 0.0, s.duration);
  TrajectorySample out = evaluate_segment(s, tau);
  out.time = tc;
  return out;
}

Trajectory ScriptedPath::sample(double dt) const {
  if (!std::isfinite(dt) || dt <= 0.0) {
    throw InputError("", 0, 0, key_prefix_ + ".dt", "must be finite and > 0 s, got " + number(dt));
  }
  for (std::size_t i = 0; i < segments_.size(); ++i) {
    const Resolved& s = segments_[i];
    const Checker check(key_prefix_, i);
    if (s.spin.norm() * dt >= std::numbers::pi) {
      check.fail("angular_velocity", "turns " + number(s.spin.norm() * dt) +
                                         " rad per sample (dt = " + number(dt) +
                                         " s); sampling needs less than π");
    }
    if (s.kind == Kind::circle && 2.0 * std::numbers::pi / s.rate <= 2.0 * dt) {
      check.fail("period", "must be longer than two samples (2 dt = " + number(2.0 * dt) + " s)");
    }
  }
  return sample_motion(std::make_shared<const ScriptedPath>(*this), dt, key_prefix_ + ".dt");
}

ScriptedPath::FarthestPoint ScriptedPath::farthest_point(const Placement& placement) const noexcept {
  FarthestPoint far;
  auto consider = [&](const core::Vec3& p, double t) {
    const double d = apply(placement, p).norm();
    if (d > far.distance || !std::isfinite(d)) far = {d, t};
  };
  for (const Resolved& s : segments_) {
    if (s.kind == Kind::circle) {
      const double swept = std::min(s.rate * s.duration, 2.0 * std::numbers::pi);
      const int n = static_cast<int>(std::ceil(swept / (std::numbers::pi / 180.0)));
      for (int k = 0; k <= n; ++k) {
        const double tau = std::min(s.duration, (swept * k / std::max(n, 1)) / s.rate);
        consider(evaluate_segment(s, tau).pose.position, s.t0 + tau);
      }
    } else {
      consider(s.a, s.t0);
      if (s.kind != Kind::hold) consider(s.b, s.t0 + s.duration);
    }
  }
  return far;
}

std::size_t ScriptedPath::memory_bytes() const noexcept {
  return sizeof(*this) + segments_.capacity() * sizeof(Resolved) + key_prefix_.capacity();
}

}  // namespace numen::sim
