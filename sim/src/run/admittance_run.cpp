/// @file admittance_run.cpp

#include "numen/sim/run/admittance_run.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "numen/core/collision.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/run/grasp_summary.hpp"
#include "numen/sim/run/task_summary.hpp"
#include "numen/sim/run/run.hpp"

#include "contact_depths.hpp"

namespace numen::sim {
namespace {

const AdmittanceScene& admittance_of(const Scene& scene) {
  if (!scene.admittance)
    throw std::invalid_argument(scene.name +
                                ": not an admittance scene (coupling = \"admittance\")");
  return *scene.admittance;
}

/// Axis values that put the device's controlled frame at the held body's initial pose.
hal::AxisVector initial_axes(const Scene& scene) {
  const auto kin = hal::make_kinematics(scene.device);
  const int held = scene.model.initial_held_body;
  const core::Pose pose = held >= 0
                              ? scene.model.bodies[static_cast<std::size_t>(held)].initial_pose
                              : kin->forward(hal::AxisVector::Zero(kin->num_axes()));
  return kin->inverse(pose, hal::AxisVector::Zero(kin->num_axes()));
}

hal::AdmittanceSettings device_settings(std::uint32_t overrun_limit) noexcept {
  hal::AdmittanceSettings s;
  s.overrun_limit = overrun_limit;
  return s;
}

platform::ControlLoopSettings loop_settings(std::uint32_t overrun_limit) noexcept {
  platform::ControlLoopSettings s;
  s.supervise_overruns = overrun_limit > 0;
  return s;
}

}  // namespace

AdmittanceRunner::AdmittanceRunner(const Scene& scene, std::size_t trace_capacity,
                                   std::uint32_t overrun_limit)
    : RunHarness(scene, trace_capacity),
      hand_motion_(scene.device, scene.hand, admittance_of(scene).drive_lag_s),
      emulator_(scene.device, admittance_of(scene).config),
      kinematics_(hal::make_kinematics(scene.device)),
      start_axes_(initial_axes(scene)),
      ghost_(core::make_data(scene.model)) {
  // The admittance device, assembled in the rig the loop runs, on the bus's controller side.
  assemble(loop_settings(overrun_limit), scene.device, admittance_of(scene).config,
           bus_.controller(), start_axes_, device_settings(overrun_limit));
  emulator_.set_axis_values(start_axes_);  // the device's set-points (the rig's device starts there)
  hand_motion_.set_axis_values(start_axes_);
  emulator_.set_motion(&hand_motion_);
  acc_.admittance.enabled = true;
  acc_.device_loop = "admittance";
  acc_.admittance.k_hand = scene.hand.stiffness;
  acc_.managed = false;
  acc_.startup = "admittance: SYNC, force TPDOs, csp RPDOs (no NMT start-up)";
  view_axis_values_.assign(scene.device.axes.size(), 0.0);
}

AdmittanceRunner::~AdmittanceRunner() { disassemble(); }

void AdmittanceRunner::finish() {
  multirate_.stop();
  if (view_) view_->finish();
}

void AdmittanceRunner::period(std::int64_t deadline_mono_ns, std::int64_t woke_mono_ns) noexcept {
  const core::Model& model = scene_->model;
  const std::int64_t t = k_ * period_ns_;
  const double ts = static_cast<double>(t) * 1e-9;
  // The hand: where the trajectory puts the controlled frame (through the device's constraint).
  const hal::Kinematics& kin = *kinematics_;
  hand_ = kin.forward(instrument_axes(scene_->device, kin, scene_->trajectory.at(ts)));
  hand_motion_.set_hand(hand_, scene_->trajectory.twist_at(ts));

  bus_.set_time_ns(t);
  loop_->begin_period(t, deadline_mono_ns, woke_mono_ns);
  bus_.set_time_ns(t + scene_->bus.latency_ns);
  emulator_.poll(bus_.device());
  bus_.set_time_ns(t + phase_ns_);
  const platform::PeriodReport& r = loop_->end_period(t + phase_ns_);
  ++k_;  // (a multirate run: the loop's Stepper::finish() left both loops' single-rate view)

  // ---- measurements ----
  RunSummary& s = acc_;
  AdmittanceSummary& a = s.admittance;
  const int held = data_.held_body;
  hand_pen_ = tool_pen_ = 0.0;
  int tool_contacts = 0;
  const core::Vec3 x_dev = emulator_.pose().position;
  if (held >= 0) {
    const auto h = static_cast<std::size_t>(held);
    tool_pen_ = detail::deepest_contact_of(data_, held, &tool_contacts);
    ghost_.bodies = data_.bodies;  // same size: no allocation
    ghost_.bodies[h].position = hand_.position;
    ghost_.bodies[h].orientation = hand_.orientation;
    core::detect_contacts(model, ghost_);
    hand_pen_ = detail::deepest_contact_of(ghost_, held);
    const double e = (x_dev - data_.bodies[h].position).norm();
    error_sq_ += e * e;
    a.device_error_max_mm = std::max(a.device_error_max_mm, e * 1e3);
  }
  if (!r.sample_valid) {
    ++s.invalid_periods;
    ++a.sensor_rejected_periods;
  }
  const double sep = (hand_.position - x_dev).norm();
  a.hand_separation_max_mm = std::max(a.hand_separation_max_mm, sep * 1e3);
  a.final_hand_separation_mm = sep * 1e3;
  a.final_measured_force_n = r.feedback.force.norm();
  a.measured_force_max_n = std::max(a.measured_force_max_n, r.feedback.force.norm());
  a.measured_torque_max_nm = std::max(a.measured_torque_max_nm, r.feedback.torque.norm());
  s.tool_penetration_max_mm = std::max(s.tool_penetration_max_mm, tool_pen_ * 1e3);
  s.target_penetration_max_mm = std::max(s.target_penetration_max_mm, hand_pen_ * 1e3);
  s.hand_penetration_max_mm = s.target_penetration_max_mm;
  s.any_penetration_max_mm = std::max(s.any_penetration_max_mm, data_.max_penetration * 1e3);
  s.contacts_max = std::max(s.contacts_max, data_.num_contacts);
  s.solver_iterations_max = std::max(s.solver_iterations_max, data_.solver_iterations);
  solver_iterations_sum_ += data_.solver_iterations;
  if (data_.solver_residual > s.solver_residual_max) s.solver_residual_max = data_.solver_residual;
  if (data_.status & core::kSolverNotConverged) ++s.solver_not_converged_steps;
  if (r.entered_safe_stop) {
    if (s.faults == 0 && rig_->device().first_fault() != nullptr) {
      // the first latched safe state of the run (kept across re-arms)
      s.first_fault = hal::to_string(rig_->device().first_fault()->cause);
      s.first_fault_time_s = static_cast<double>(t + phase_ns_) * 1e-9;
      s.first_fault_period = k_ - 1;
    }
    ++s.faults;
  }
  // The frame and the trace record of an admittance period (docs/viewer.md, "Admittance
  // runs"; docs/scenes.md): the target is the hand, the wrench the measured one that drove the
  // god-object, no axis torque.
  data_.target = hand_;  // not read by the admittance coupling (core/src/coupling/coupling.cpp)
  view_report_ = r;
  if (trace_.records().capacity() > 0)
    trace_.push(make_trace_record(data_, held, tool_contacts, tool_pen_, hand_pen_, view_report_,
                                  loop_->device().output().torque));
  if (view_)
    view_->publish(data_, view_report_, view_axis_values_,
                   {static_cast<std::uint64_t>(k_ - 1), tool_pen_, hand_pen_, hand_pen_, 0.0, 0.0});
  divergence_.observe(model, data_, k_ - 1, ts);
}

RunSummary AdmittanceRunner::summary() const {
  RunSummary s = acc_;
  if (view_) view_->summarize(s);
  summarize_divergence(divergence_, scene_->model, s);
  summarize_periods(s);
  summarize_grasps(scene_->model, data_, s);
  summarize_task(*scene_, data_, s);
  s.lifecycle = hal::to_string(rig_->device().lifecycle());
  s.zero_torque_periods = 0;
  AdmittanceSummary& a = s.admittance;
  a.device_error_rms_mm = k_ > 0 ? std::sqrt(error_sq_ / static_cast<double>(k_)) * 1e3 : 0.0;
  // Through the device face: the force TPDOs its input took, its set-points' counters.
  const hal::Device& device = rig_->device();
  a.sensor_frames = static_cast<std::int64_t>(device.input_frames());
  if (const hal::AdmittanceDeviceCounters* c = device.conditioning().setpoints) {
    a.csp_rpdos = static_cast<std::int64_t>(c->rpdos_written);
    a.setpoints_clamped = static_cast<std::int64_t>(c->clamped_to_range);
    a.setpoints_rate_limited = static_cast<std::int64_t>(c->rate_limited);
    a.hold_periods = static_cast<std::int64_t>(c->hold_periods);
  }
  s.rejected_samples = a.sensor_rejected_periods;
  multirate_.summarize(s);
  return s;
}

}  // namespace numen::sim
