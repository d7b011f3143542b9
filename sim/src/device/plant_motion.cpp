/// @file plant_motion.cpp
/// An emulated impedance device that moves under numen's torques, held by the hand
/// (plant_motion.hpp).

#include "numen/sim/device/plant_motion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/hand_servo.hpp"
#include "numen/sim/device/trajectory_motion.hpp"

namespace numen::sim {
namespace {

/// A speed no hand gives an axis (m/s or rad/s): beyond it the plant has run away.
double runaway_speed(const hal::AxisConfig& a) noexcept {
  return std::isfinite(a.max_speed) ? 100.0 * a.max_speed : 1e3;
}

}  // namespace

void LimitCycleDetector::add(const core::Vec3& e, double t_s, double dt_s) noexcept {
  if (!primed_) {
    primed_ = true;
    last_e_ = e;
    block_start_s_ = t_s;
    return;
  }
  const double tau = 1.0 / (2.0 * std::numbers::pi * kHighPassHz);
  const double alpha = tau / (tau + dt_s);
  y_ = alpha * (y_ + e - last_e_);
  last_e_ = e;
  for (int c = 0; c < 3; ++c) {
    const auto k = static_cast<std::size_t>(c);
    const int side = y_[c] > kBandM ? 1 : (y_[c] < -kBandM ? -1 : 0);
    if (side != 0 && side != side_[k]) {
      if (side_[k] != 0) ++crossings_[k];
      side_[k] = side;
    }
  }
  block_peak_m_ = std::max(block_peak_m_, y_.cwiseAbs().maxCoeff());
  if (t_s - block_start_s_ < kBlockS) return;
  const int crossings = *std::max_element(crossings_.begin(), crossings_.end());
  if (crossings >= kMinCrossings) {
    ++run_;
    if (run_ >= kBlocks) {
      if (!detected_) time_s_ = t_s;
      detected_ = true;
      if (block_peak_m_ > amplitude_m_) {
        amplitude_m_ = block_peak_m_;
        frequency_hz_ = crossings / (2.0 * (t_s - block_start_s_));
      }
    }
  } else {
    run_ = 0;
  }
  crossings_.fill(0);
  block_peak_m_ = 0.0;
  block_start_s_ = t_s;
}

PlantMotion::PlantMotion(const hal::DeviceConfig& config, const DevicePlantSettings& plant,
                         const HandSettings& hand, const Trajectory& trajectory,
                         std::int64_t start_ns)
    : config_(config),
      settings_(plant),
      hand_(hand),
      trajectory_(&trajectory),
      start_ns_(start_ns),
      kinematics_(hal::make_kinematics(config)) {
  validate(hand, config.name);
  const int n = kinematics_->num_axes();
  if (static_cast<int>(plant.axes.size()) != n)
    throw std::invalid_argument(config.name + ": the plant gives " +
                                std::to_string(plant.axes.size()) + " axes, the device has " +
                                std::to_string(n));
  if (plant.substeps < 1 || plant.substeps > kMaxPlantSubsteps)
    throw std::invalid_argument(config.name + ": plant substeps must be in [1, " +
                                std::to_string(kMaxPlantSubsteps) + "]");
  if (!(std::isfinite(plant.torque_phase_s) && plant.torque_phase_s >= 0.0))
    throw std::invalid_argument(config.name + ": torque phase must be finite and >= 0");
  plants_.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    AxisPlantSettings a = plant.axes[static_cast<std::size_t>(i)];
    const auto k = static_cast<std::size_t>(i);
    follows_[k] = a.inertia == 0.0;
    if (follows_[k]) a.inertia = 1.0;  // not stepped; a valid placeholder
    try {
      plants_.emplace_back(a);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(config.name + ": axis " + config.axes[k].name + ": " + e.what());
    }
  }
  state_.q = hal::AxisVector::Zero(n);
  state_.qdot = hal::AxisVector::Zero(n);
}

hal::AxisVector PlantMotion::intent_at(double t) const noexcept {
  TrajectorySample s = trajectory_->at(t);
  if (servo_) s.pose.position += servo_->offset();
  return instrument_axes(config_, *kinematics_, s);
}

void PlantMotion::gather() noexcept {
  for (int i = 0; i < state_.q.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (follows_[k]) {
      state_.q[i] = intent_[i];
    } else {
      state_.q[i] = plants_[k].q();
      state_.qdot[i] = plants_[k].qdot();
    }
  }
}

void PlantMotion::advance(double t0, double t1, int parts) noexcept {
  if (parts < 1 || !(t1 > t0)) return;
  const int n = static_cast<int>(state_.q.size());
  const double h = (t1 - t0) / parts;
  const core::Vec6 m_hand = (core::Vec6() << hand_.mass, hand_.mass, hand_.mass,
                             hand_.rotational_inertia, hand_.rotational_inertia,
                             hand_.rotational_inertia)
                                .finished();
  const core::Vec6 c_hand = (core::Vec6() << hand_.damping, hand_.damping, hand_.damping,
                             hand_.rotational_damping, hand_.rotational_damping,
                             hand_.rotational_damping)
                                .finished();
  hal::AxisVector qi0 = intent_at(t0);
  for (int s = 0; s < parts; ++s) {
    const double ta = t0 + s * h;
    const hal::AxisVector qi1 = intent_at(ta + h);
    hal::AxisVector qdot_i(n);
    for (int i = 0; i < n; ++i) {
      const bool wraps = config_.axes[static_cast<std::size_t>(i)].wraps;
      qdot_i[i] = hal::axis_difference(qi1[i], qi0[i], wraps) / h;
    }
    // The intent and the handle at the sub-step's start; the hand's wrench held over it.
    const core::Pose intent = kinematics_->forward(qi0);
    const core::Twist intent_twist = hal::twist_from_rates(kinematics_->jacobian(qi0), qdot_i);
    for (int i = 0; i < n; ++i)
      if (follows_[static_cast<std::size_t>(i)]) {
        state_.q[i] = qi0[i];
        state_.qdot[i] = qdot_i[i];
      }
    const core::Pose handle = kinematics_->forward(state_.q);
    const hal::Jacobian j = kinematics_->jacobian(state_.q);
    const core::Wrench w =
        hand_wrench(hand_, intent, intent_twist, handle, hal::twist_from_rates(j, state_.qdot));
    const hal::AxisVector f = hal::torques_from_wrench(j, w);
    figures_.handle_force_n = w.force.norm();
    figures_.handle_force_max_n = std::max(figures_.handle_force_max_n, figures_.handle_force_n);
    for (int i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(i);
      if (follows_[k]) continue;
      const double m_extra = j.col(i).cwiseAbs2().dot(m_hand);
      const double c_extra = j.col(i).cwiseAbs2().dot(c_hand);
      AxisPlant& p = plants_[k];
      const double q_before = p.q();
      // The hand's damping on the axis's own rate goes in implicitly (c_extra); the wrench
      // above counted it explicitly, so it is added back to what is held.
      p.step(h, f[i] + c_extra * p.qdot(), m_extra, c_extra);
      figures_.port_energy_j += f[i] * (p.q() - q_before);
      const double speed = std::abs(p.qdot());
      const double limit = runaway_speed(config_.axes[k]);
      if (!figures_.diverged && (!std::isfinite(p.q()) || !(speed <= limit))) {
        figures_.diverged = true;
        figures_.diverged_axis = i;
        figures_.diverged_time_s = ta + h;
        // An axis whose value is not finite (its speed then too, or NaN) ran away at +inf.
        figures_.diverged_speed =
            std::isfinite(p.q()) ? speed : std::numeric_limits<double>::infinity();
        figures_.diverged_speed_limit = limit;
      }
    }
    qi0 = qi1;
    if (figures_.diverged) return;
  }
  for (int i = 0; i < n; ++i)
    if (!follows_[static_cast<std::size_t>(i)]) state_.qdot[i] = plants_[static_cast<std::size_t>(i)].qdot();
}

const hal::DeviceMotionState& PlantMotion::at_sync(std::int64_t t_ns,
                                                   const hal::DriveCommands& commands) noexcept {
  if (start_at_sync_) {
    start_ns_ = t_ns;
    start_at_sync_ = false;
  }
  const double t1 = static_cast<double>(t_ns - start_ns_) * 1e-9;
  const int n = static_cast<int>(state_.q.size());
  const double gap = static_cast<double>(t_ns - last_sync_ns_) * 1e-9;
  intent_ = intent_at(t1);
  if (!had_sync_ || (gap > kMaxSyncGapS && !figures_.diverged)) {
    // The device starts where the hand means it to be, at rest; after a silence of the bus
    // longer than kMaxSyncGapS (a controller restarted) it starts again there.
    had_sync_ = true;
    for (int i = 0; i < n; ++i) plants_[static_cast<std::size_t>(i)].reset(intent_[i], 0.0);
    state_.q = intent_;
    state_.qdot.setZero();
  } else if (!figures_.diverged && t_ns > last_sync_ns_) {
    const double t0 = static_cast<double>(last_sync_ns_ - start_ns_) * 1e-9;
    const double period = t1 - t0;
    // `substeps` per control period of the scene; a longer interval (SYNCs late or lost on a
    // real bus) gets as many more.
    const double nominal = config_.control_period_s > 0.0 ? config_.control_period_s : period;
    const int total = settings_.substeps *
                      static_cast<int>(std::clamp(std::ceil(period / nominal - 1e-9), 1.0,
                                                  kMaxSyncGapS / nominal + 1.0));
    const double phase = std::min(settings_.torque_phase_s, period);
    int before = static_cast<int>(std::lround(total * phase / period));
    if (phase > 0.0) before = std::max(before, 1);
    before = std::min(before, total - 1);
    const int after = std::max(total - before, 1);
    advance(t0, t0 + phase, before);
    for (int i = 0; i < n; ++i)
      plants_[static_cast<std::size_t>(i)].command(i < commands.torque.size() ? commands.torque[i]
                                                                              : 0.0);
    if (!figures_.diverged) advance(t0 + phase, t1, after);
    if (!figures_.diverged) gather();
  }
  last_sync_ns_ = t_ns;
  // What the hand feels and where it is against the handle, at the SYNC.
  const core::Pose intent = kinematics_->forward(intent_);
  const core::Pose handle = kinematics_->forward(state_.q);
  const core::Vec3 e = handle.position - intent.position;
  figures_.hand_separation_max_mm = std::max(figures_.hand_separation_max_mm, e.norm() * 1e3);
  if (figures_.port_energy_j < figures_.port_energy_min_j) {
    figures_.port_energy_min_j = figures_.port_energy_j;
    figures_.port_energy_min_time_s = t1;
  }
  figures_.limit_cycle.add(e, t1, config_.control_period_s);
  return state_;
}

}  // namespace numen::sim
