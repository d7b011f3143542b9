#include "numen/hal/input/relative_pose_integrator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace numen::hal {

namespace {

bool is_translation(PoseDof dof) noexcept {
  return dof == PoseDof::kX || dof == PoseDof::kY || dof == PoseDof::kZ;
}

std::string vec_field(const char* name, int i) {
  return std::string("RelativePoseIntegratorSettings.") + name + "[" + std::to_string(i) + "]";
}

}  // namespace

RelativePoseIntegrator::RelativePoseIntegrator(const RelativePoseIntegratorSettings& settings)
    : settings_(settings) {
  const char* const prefix = "RelativePoseIntegratorSettings.";
  if (settings.axes.size() > kMaxRelAxisMappings) {
    throw std::invalid_argument(std::string(prefix) +
                                "axes: " + std::to_string(settings.axes.size()) +
                                " mappings, at most " + std::to_string(kMaxRelAxisMappings));
  }
  for (std::size_t i = 0; i < settings.axes.size(); ++i) {
    const RelAxisMapping& m = settings.axes[i];
    const std::string field = std::string(prefix) + "axes[" + std::to_string(i) + "]";
    if (m.code > REL_MAX) {
      throw std::invalid_argument(field + ".code: " + std::to_string(m.code) +
                                  " is not an EV_REL code (0.." + std::to_string(REL_MAX) + ")");
    }
    if (static_cast<std::uint8_t>(m.dof) > static_cast<std::uint8_t>(PoseDof::kYaw)) {
      throw std::invalid_argument(field + ".dof: not a PoseDof");
    }
    if (!std::isfinite(m.scale)) {
      throw std::invalid_argument(field + ".scale: not finite");
    }
    axes_[i] = m;
    mapped_[m.code] = true;
  }
  num_axes_ = settings.axes.size();
  if (settings.clutch_key > KEY_MAX) {
    throw std::invalid_argument(std::string(prefix) + "clutch_key: " +
                                std::to_string(settings.clutch_key) + " is above KEY_MAX");
  }
  for (int i = 0; i < 3; ++i) {
    const double lo = settings.workspace_min[i];
    const double hi = settings.workspace_max[i];
    if (std::isnan(lo)) throw std::invalid_argument(vec_field("workspace_min", i) + ": NaN");
    if (std::isnan(hi)) throw std::invalid_argument(vec_field("workspace_max", i) + ": NaN");
    if (lo > hi) {
      throw std::invalid_argument(vec_field("workspace_min", i) + " = " + std::to_string(lo) +
                                  " is above workspace_max = " + std::to_string(hi));
    }
    const double p = settings.initial_pose.position[i];
    if (!std::isfinite(p) || p < lo || p > hi) {
      throw std::invalid_argument(vec_field("initial_pose.position", i) + " = " +
                                  std::to_string(p) + " is outside the workspace [" +
                                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
  }
  const double qn = settings.initial_pose.orientation.norm();
  if (!std::isfinite(qn) || qn < 1e-9) {
    throw std::invalid_argument(std::string(prefix) +
                                "initial_pose.orientation: zero or not finite");
  }
  settings_.initial_pose.orientation.normalize();
  target_ = settings_.initial_pose;
  period_start_ = target_;
  engaged_ = settings.clutch_mode == ClutchMode::kNone;
  pending_engaged_ = engaged_;
}

bool RelativePoseIntegrator::engaged() const noexcept { return engaged_; }

void RelativePoseIntegrator::clear_pending() noexcept {
  pending_.fill(0);
  pending_events_ = 0;
  pending_motion_ = false;
}

void RelativePoseIntegrator::feed(const InputEvent& event) noexcept {
  ++counters_.events;
  if (dropping_) {
    // Kernel rule: after SYN_DROPPED, ignore everything up to and including the next
    // SYN_REPORT (event-codes.rst, "EV_SYN").
    ++counters_.discarded_events;
    if (event.type == EV_SYN && event.code == SYN_REPORT) dropping_ = false;
    return;
  }
  switch (event.type) {
    case EV_SYN:
      if (event.code == SYN_REPORT) {
        apply_report(event.time_ns);
      } else if (event.code == SYN_DROPPED) {
        ++counters_.discarded_events;  // the SYN_DROPPED itself; drop_pending() the rest
        drop_pending();
        dropping_ = true;
      } else {
        ++counters_.other_events;  // SYN_CONFIG, SYN_MT_REPORT: nothing for a pointer
      }
      return;
    case EV_REL:
      if (event.code < REL_CNT && mapped_[event.code]) {
        pending_[event.code] += event.value;
        ++pending_events_;
        if (event.value != 0) pending_motion_ = true;
      } else {
        ++counters_.unmapped_events;
      }
      return;
    case EV_KEY:
      if (event.code != settings_.clutch_key || settings_.clutch_mode == ClutchMode::kNone) {
        ++counters_.other_events;
        return;
      }
      ++pending_events_;
      if (settings_.clutch_mode == ClutchMode::kHold) {
        key_down_ = event.value != 0;
        if (key_down_ != pending_engaged_) {
          pending_engaged_ = key_down_;
          clutch_changed_ = true;
        }
      } else {  // kToggle: presses (1) toggle; release (0) and autorepeat (2) do not
        if (event.value == 1) {
          pending_engaged_ = !pending_engaged_;
          clutch_changed_ = true;
        }
        key_down_ = event.value != 0;
      }
      return;
    default:
      ++counters_.other_events;
      return;
  }
}

void RelativePoseIntegrator::apply_report(std::int64_t time_ns) noexcept {
  ++counters_.reports;
  last_report_ns_ = time_ns;
  const bool move = engaged_ && !clutch_changed_;
  if (pending_motion_ && !move) ++counters_.ignored_reports;
  if (pending_motion_ && move) {
    core::Vec3 dp = core::Vec3::Zero();
    core::Vec3 dr = core::Vec3::Zero();  // rotation vector (roll, pitch, yaw), rad
    for (std::size_t i = 0; i < num_axes_; ++i) {
      const RelAxisMapping& m = axes_[i];
      const double d = static_cast<double>(pending_[m.code]) * m.scale;
      const int k = static_cast<int>(m.dof);
      if (is_translation(m.dof)) {
        dp[k] += d;
      } else {
        dr[k - 3] += d;
      }
    }
    const double angle = dr.norm();
    core::Quat dq = core::Quat::Identity();
    if (angle > 0.0) dq = core::Quat(Eigen::AngleAxisd(angle, dr / angle));
    if (settings_.frame == MotionFrame::kWorld) {
      target_.position += dp;
      target_.orientation = dq * target_.orientation;
    } else {
      target_.position += target_.orientation * dp;  // R at the start of the report
      target_.orientation = target_.orientation * dq;
    }
    target_.orientation.normalize();
    if (clamp_position()) ++counters_.clamped_reports;
    if (dp.squaredNorm() > 0.0 || angle > 0.0) ++counters_.moving_reports;
  }
  engaged_ = pending_engaged_;
  clutch_changed_ = false;
  clear_pending();
}

bool RelativePoseIntegrator::clamp_position() noexcept {
  bool clamped = false;
  for (int i = 0; i < 3; ++i) {
    const double p = target_.position[i];
    const double c = std::clamp(p, settings_.workspace_min[i], settings_.workspace_max[i]);
    if (c != p) {
      target_.position[i] = c;
      clamped = true;
    }
  }
  return clamped;
}

void RelativePoseIntegrator::drop_pending() noexcept {
  ++counters_.dropped;
  counters_.discarded_events += pending_events_;
  clear_pending();
  if (settings_.clutch_mode != ClutchMode::kNone) {
    engaged_ = false;
    pending_engaged_ = false;
    key_down_ = false;
  }
  clutch_changed_ = false;
}

void RelativePoseIntegrator::sync_clutch_key(bool pressed) noexcept {
  if (settings_.clutch_mode == ClutchMode::kHold && pressed != pending_engaged_) {
    pending_engaged_ = pressed;
    clutch_changed_ = true;
  }
  key_down_ = pressed;
  // Between reports (nothing pending) the new state applies at once.
  if (pending_events_ == 0 && !dropping_) {
    engaged_ = pending_engaged_;
    clutch_changed_ = false;
  }
}

void RelativePoseIntegrator::end_period(std::int64_t now_ns) noexcept {
  if (have_period_ && now_ns > last_period_ns_) {
    const double dt = static_cast<double>(now_ns - last_period_ns_) * 1e-9;
    twist_.linear = (target_.position - period_start_.position) / dt;
    // World angular velocity: Δq = q_now q_prev⁻¹, shortest way (q and −q alike).
    core::Quat dq = target_.orientation * period_start_.orientation.conjugate();
    if (dq.w() < 0.0) dq.coeffs() = -dq.coeffs();
    const Eigen::AngleAxisd aa(dq);
    twist_.angular = aa.axis() * (aa.angle() / dt);
  } else if (!have_period_) {
    twist_ = core::Twist{};
  }
  if (!have_period_ || now_ns > last_period_ns_) {
    last_period_ns_ = now_ns;
    period_start_ = target_;
    have_period_ = true;
  }
}

void RelativePoseIntegrator::reset(const core::Pose& pose) noexcept {
  target_ = pose;
  const double qn = target_.orientation.norm();
  if (!std::isfinite(qn) || qn < 1e-9) {
    target_.orientation = core::Quat::Identity();
  } else {
    target_.orientation.normalize();
  }
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(target_.position[i]))
      target_.position[i] = settings_.initial_pose.position[i];
  }
  clamp_position();
  clear_pending();
  clutch_changed_ = false;
  pending_engaged_ = engaged_;
  period_start_ = target_;
  twist_ = core::Twist{};
}

}  // namespace numen::hal
