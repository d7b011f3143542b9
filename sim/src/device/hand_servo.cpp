/// @file hand_servo.cpp
/// A scripted hand's position-based visual servo (hand_servo.hpp).

#include "numen/sim/device/hand_servo.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "numen/core/data.hpp"
#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

core::Vec3 span_target(const HandServoSpan& s, double t) noexcept {
  const double u = s.t1_s > s.t0_s ? std::clamp((t - s.t0_s) / (s.t1_s - s.t0_s), 0.0, 1.0) : 1.0;
  return (1.0 - u) * s.target_start + u * s.target_end;
}

}  // namespace

void validate(const HandServoSpec& spec, const std::string& who) {
  const HandServoSettings& g = spec.settings;
  if (!(std::isfinite(g.latency_s) && g.latency_s >= 0.0 && g.latency_s <= kMaxServoLatency))
    throw std::invalid_argument(who + ": servo latency must be in [0, " + format_input_number(kMaxServoLatency) +
                                "] s (got " + format_input_number(g.latency_s) + ")");
  if (!(std::isfinite(g.time_constant_s) && g.time_constant_s > 0.0))
    throw std::invalid_argument(who + ": servo time_constant must be finite and > 0 (got " +
                                format_input_number(g.time_constant_s) + ")");
  if (!(std::isfinite(g.max_offset_m) && g.max_offset_m > 0.0))
    throw std::invalid_argument(who + ": servo max_offset must be finite and > 0 (got " +
                                format_input_number(g.max_offset_m) + ")");
  double end = -INFINITY;
  for (std::size_t i = 0; i < spec.spans.size(); ++i) {
    const HandServoSpan& s = spec.spans[i];
    if (s.body < 0)
      throw std::invalid_argument(who + ": servo span " + std::to_string(i) +
                                  "'s body not resolved");
    if (!s.point.allFinite())
      throw std::invalid_argument(who + ": servo span " + std::to_string(i) +
                                  "'s point must be finite");
    if (!(std::isfinite(s.t0_s) && std::isfinite(s.t1_s) && s.t1_s > s.t0_s && s.t0_s >= end))
      throw std::invalid_argument(who + ": servo span " + std::to_string(i) +
                                  " must start at or after the previous one's end and last > 0 s");
    if (!s.target_start.allFinite() || !s.target_end.allFinite())
      throw std::invalid_argument(who + ": servo span " + std::to_string(i) +
                                  " has a non-finite target");
    end = s.t1_s;
  }
}

HandServo::HandServo(HandServoSpec spec, double dt_s, const std::string& who)
    : spec_(std::move(spec)), device_(who), dt_s_(dt_s) {
  validate(spec_, who);
  if (!(std::isfinite(dt_s) && dt_s > 0.0))
    throw std::invalid_argument(who + ": servo period must be finite and > 0");
  const auto n = static_cast<std::size_t>(std::llround(spec_.settings.latency_s / dt_s)) + 1;
  error_line_.assign(n, core::Vec3::Zero());
  planned_line_.assign(n, 0);
  offset_line_.assign(n, core::Vec3::Zero());
}

bool HandServo::target_at(double t_s, core::Vec3& target) const noexcept {
  for (const HandServoSpan& s : spec_.spans)
    if (t_s >= s.t0_s && t_s < s.t1_s) {
      target = span_target(s, t_s);
      return true;
    }
  return false;
}

void HandServo::observe(double t_s, const core::Data& data) noexcept {
  while (span_ < spec_.spans.size() && t_s >= spec_.spans[span_].t1_s) ++span_;
  const bool planned = span_ < spec_.spans.size() && t_s >= spec_.spans[span_].t0_s;
  core::Vec3 e = core::Vec3::Zero();
  if (planned && static_cast<std::size_t>(spec_.spans[span_].body) < data.bodies.size()) {
    const HandServoSpan& s = spec_.spans[span_];
    const core::BodyState& b = data.bodies[static_cast<std::size_t>(s.body)];
    e = span_target(s, t_s) - (b.position + b.orientation * s.point);
    if (!e.allFinite()) e.setZero();  // a diverged body: the run stops on it, the hand holds
    error_max_m_ = std::max(error_max_m_, e.norm());
  }
  const std::size_t n = error_line_.size();
  error_line_[head_ % n] = e;
  planned_line_[head_ % n] = planned ? 1 : 0;
  offset_line_[head_ % n] = offset_;
  ++head_;
  if (head_ < n) return;                     // nothing seen L ago yet
  const std::size_t seen = (head_ - n) % n;  // the entry written n − 1 periods ago
  if (!planned_line_[seen]) return;
  const core::Vec3 error = spec_.settings.predict
                               ? core::Vec3(error_line_[seen] - (offset_ - offset_line_[seen]))  // less what it did since
                               : error_line_[seen];
  offset_ += (dt_s_ / spec_.settings.time_constant_s) * error;
  const double o = offset_.norm();
  if (o > spec_.settings.max_offset_m) {
    offset_ *= spec_.settings.max_offset_m / o;
    ++saturated_;
    if (first_saturation_s_ < 0.0) first_saturation_s_ = t_s;
  }
  offset_max_m_ = std::max(offset_max_m_, offset_.norm());
}

}  // namespace numen::sim
