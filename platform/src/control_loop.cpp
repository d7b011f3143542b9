/// @file control_loop.cpp

#include "numen/platform/control_loop.hpp"

#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/core/feedback.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

namespace {

std::int64_t period_of(const hal::DeviceConfig& config) {
  return static_cast<std::int64_t>(std::llround(config.control_period_s * 1e9));
}

}  // namespace

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                         hal::InstrumentDevice& device, DeviceBinding binding,
                         const ControlLoopSettings& settings)
    : model_(&model),
      data_(&data),
      owned_(hal::make_device(device, bus, period_of(device.config()),
                              static_cast<const hal::DeviceSettings&>(settings))),
      device_(owned_.get()),
      bind_(&ControlLoop::bind_link_targets),
      command_(&ControlLoop::map_feedback),
      binding_(std::move(binding)),
      settings_(settings),
      stats_(std::make_unique<LoopStatistics>(period_of(device.config()))) {
  if (binding_.links.empty()) binding_.links = DeviceBinding::rigid().links;  // see DeviceBinding
  const int links = device.kinematics().num_links();
  for (const LinkBinding& b : binding_.links) {
    if (b.link < 0 || b.link >= links || b.link >= hal::kMaxLinks)
      throw std::invalid_argument("device binding: link " + std::to_string(b.link) +
                                  " out of range (the device has " + std::to_string(links) + ")");
    if (b.body < -1 || b.body >= model.num_bodies())
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) + " out of range");
  }
  for (const AxisPrescription& p : binding_.prescriptions) {
    if (p.joint < 0 || p.joint >= model.num_joints() ||
        !model.joints[static_cast<std::size_t>(p.joint)].prescribed)
      throw std::invalid_argument("device binding: joint " + std::to_string(p.joint) +
                                  " is not a prescribed joint");
    if (p.axis < 0 || p.axis >= device.num_axes())
      throw std::invalid_argument("device binding: axis " + std::to_string(p.axis) + " out of range");
  }
  explicit_bound_ = explicitly_bound_bodies(binding_, model.num_bodies());
  link_origin_.assign(binding_.links.size(), core::Vec3::Zero());
  body_target_.assign(binding_.links.size(), core::Vec3::Zero());
  bound_body_.assign(binding_.links.size(), -1);
  // Until the device has a target, the prescribed joints hold their starting coordinates (the
  // managed stack's start-up has no encoder values for its first periods).
  for (const AxisPrescription& p : binding_.prescriptions) {
    const core::JointModel& jm = model.joints[static_cast<std::size_t>(p.joint)];
    const core::BodyState* parent =
        jm.parent >= 0 ? &data.bodies[static_cast<std::size_t>(jm.parent)] : nullptr;
    data.joint_prescribed[static_cast<std::size_t>(p.joint)] = core::JointPrescription{
        core::joint_coordinate(jm, parent, data.bodies[static_cast<std::size_t>(jm.child)]), 0.0};
  }
  // ... and a body bound to a link holds its starting pose (a target at rest where it is).
  // Without one, such a body other than the held one has no target before the first sample: in
  // direct coupling it is then left to its joints alone, and a body jointed both to the world and
  // to the imposed held body (the default scene's trocar sleeve) is over-constrained — a singular
  // solve and a rolled-back, non-finite step in every period before the first sample.
  for (const LinkBinding& b : binding_.links) {
    if (b.body < 0 || b.body == data.attached_body) continue;
    const core::BodyState& start = data.bodies[static_cast<std::size_t>(b.body)];
    core::BodyTarget& t = data.body_targets[static_cast<std::size_t>(b.body)];
    t.pose.position = start.position;
    t.pose.orientation = start.orientation;
    t.twist = core::Twist{};
    t.enabled = true;
  }
  tau_ = hal::AxisVector::Zero(device.num_axes());
}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data,
                         hal::AdmittanceDevice& device, const ControlLoopSettings& settings)
    : model_(&model),
      data_(&data),
      device_(&device),
      bind_(&ControlLoop::bind_measured_wrench),
      command_(&ControlLoop::command_held_pose),
      settings_(settings),
      stats_(std::make_unique<LoopStatistics>(period_of(device.config()))) {
  if (model.coupling_mode != core::CouplingMode::kAdmittance)
    throw std::invalid_argument("admittance device '" + device.config().name +
                                "': the model's coupling mode must be admittance");
}

void ControlLoop::bind_link_targets(const hal::DeviceState& state) noexcept {
  // When the device is ready (a rejected sample keeps the last good target).
  if (!state.ready) return;
  core::Data& d = *data_;
  for (std::size_t k = 0; k < binding_.links.size(); ++k) {
    const LinkBinding& b = binding_.links[k];
    const auto l = static_cast<std::size_t>(b.link);
    link_origin_[k] = state.link_poses[l].position;
    bound_body_[k] = apply_link_target(b, state.link_poses[l], state.link_twists[l], d,
                                       explicit_bound_, &body_target_[k]);
  }
  for (const AxisPrescription& p : binding_.prescriptions)
    apply_prescription(p, state.q(p.axis), state.qdot(p.axis), d);
}

void ControlLoop::gather_link_wrenches() noexcept {
  const core::Data& d = *data_;
  for (core::Wrench& w : link_wrench_) w = core::Wrench{};
  for (std::size_t k = 0; k < binding_.links.size(); ++k) {
    const int body = bound_body_[k];
    if (body < 0) continue;
    const core::Wrench w = core::carry_wrench(d.body_feedback[static_cast<std::size_t>(body)],
                                              body_target_[k], link_origin_[k]);  // Eq. 9
    core::Wrench& acc = link_wrench_[static_cast<std::size_t>(binding_.links[k].link)];
    acc.force += w.force;
    acc.torque += w.torque;
  }
}

void ControlLoop::map_feedback(const hal::DeviceState& state, hal::DeviceCommand& command) noexcept {
  // Computes and never gates: a link without a driven body has w = 0, and whether τ is sent
  // is the device's write() decision alone (a non-finite τ trips its latch there).
  report_.feedback = core::Wrench{};
  const auto links = static_cast<std::size_t>(state.num_links);
  gather_link_wrenches();
  // τ = Σ_l J_lᵀ w_l with the Jacobians of this period's state (computed as it is, NaN
  // included: the device's write() trips on a non-finite τ).
  if (!hal::all_finite(std::span<const core::Wrench>(link_wrench_.data(), links)))
    ++counters_.non_finite_wrenches;
  hal::torques_from_link_wrenches(std::span<const hal::Jacobian>(state.link_jacobians.data(), links),
                                  std::span<const core::Wrench>(link_wrench_.data(), links), tau_);
  // The wrench the drives are asked to render, about link 0's origin (Eq. 9).
  const core::Vec3 origin0 = state.link_poses[0].position;
  for (std::size_t l = 0; l < links; ++l) {
    const core::Wrench w = core::carry_wrench(link_wrench_[l], state.link_poses[l].position, origin0);
    report_.feedback.force += w.force;
    report_.feedback.torque += w.torque;
  }
  command.torques = std::span<const double>(tau_.data(), static_cast<std::size_t>(tau_.size()));
}

void ControlLoop::begin_period(std::int64_t now_ns, std::int64_t deadline_mono_ns,
                               std::int64_t woke_mono_ns) noexcept {
  const std::int64_t t = monotonic_now_ns();
  begin_.woke_ns = woke_mono_ns >= 0 ? woke_mono_ns : t;
  begin_.deadline_ns = deadline_mono_ns >= 0 ? deadline_mono_ns : begin_.woke_ns;
  if (begin_.deadline_ns > begin_.woke_ns) begin_.deadline_ns = begin_.woke_ns;
  if (device_->begin_period(now_ns) != hal::IoStatus::kOk) ++counters_.sync_write_failures;
  begin_.sync_sent_ns = monotonic_now_ns();
}

void ControlLoop::step_model() noexcept {
  report_.step_begin_ns = monotonic_now_ns();
  stepper_->step(*model_, *data_);
  report_.step_end_ns = monotonic_now_ns();
  report_.step_ns = report_.step_end_ns - report_.step_begin_ns;
  step_time_.record(report_.step_ns);
}

const PeriodReport& ControlLoop::end_period(std::int64_t now_ns) noexcept {
  report_ = begin_;
  ++counters_.periods;
  const auto period = static_cast<std::int64_t>(counters_.periods) - 1;
  // 1. read
  report_.input_begin_ns = monotonic_now_ns();
  const hal::DeviceState& state = device_->read(now_ns);
  report_.input_end_ns = monotonic_now_ns();
  report_.frames_read = state.frames_read;
  if (state.read_error) ++counters_.read_errors;
  // 2. supervise
  const hal::DeviceSupervision sup =
      device_->supervise(now_ns, settings_.supervise_overruns && last_overrun_);
  report_.entered_safe_stop = sup.entered_safe_stop;
  report_.activated = sup.activated;
  report_.startup = sup.startup;
  if (report_.activated && first_active_period_ < 0) first_active_period_ = period;
  report_.sample_valid = state.valid;
  report_.target_ready = state.ready;
  report_.sample_faults = state.faults;
  // 3. targets (the kind's, chosen at construction)
  (this->*bind_)(state);
  // 4. step
  step_model();
  // 5. map (the kind's), 6. write
  report_.output_begin_ns = monotonic_now_ns();
  hal::DeviceCommand command;
  (this->*command_)(state, command);
  const hal::DeviceOutput& out = device_->write(command, now_ns);
  report_.output_end_ns = monotonic_now_ns();
  report_.command_status = out.status;
  report_.soft_start_ramp = out.ramp;
  report_.controlword = out.controlword;
  report_.torque_commanded = out.torque_commanded;
  if (out.gated) {
    report_.feedback = core::Wrench{};
  } else if (out.ramp < 1.0) {  // what the drives render: the soft start scaled every τ_i
    report_.feedback.force *= out.ramp;
    report_.feedback.torque *= out.ramp;
  }
  stepper_->finish(*model_, *data_);  // outside the timed step, after the commands
  report_.lifecycle = device_->lifecycle();  // after the write: a non-finite τ trips it
  if (const hal::FaultRecord* f = device_->first_fault()) report_.fault_cause = f->cause;
  if (!report_.torque_commanded) ++counters_.periods_zero_torque;
  if (report_.torque_commanded && first_torque_period_ < 0) first_torque_period_ = period;
  if (report_.command_status != hal::IoStatus::kOk) ++counters_.command_failures;
  const PeriodVerdict v = stats_->record_period(report_.times());
  report_.overrun = v.overrun;
  last_overrun_ = v.overrun;
  return report_;
}

void ControlLoop::brake_held_body() noexcept {
  // Explicit brake that halves the held body's twist every step (stable in both integrators:
  // h·b/m = 0.5): −0.5 m v / h, −0.5 I_w ω / h.
  core::Data& d = *data_;
  d.device_wrench = core::Wrench{};
  const int a = d.attached_body;
  if (a < 0 || a >= model_->num_bodies()) return;
  const core::BodyModel& bm = model_->bodies[static_cast<std::size_t>(a)];
  const core::BodyState& s = d.bodies[static_cast<std::size_t>(a)];
  const double k = 0.5 / model_->dt;
  d.device_wrench.force = -k * bm.mass * s.linear_velocity;
  d.device_wrench.torque =
      -k * (core::world_inertia(s.orientation, bm.inertia_body) * s.angular_velocity);
}

void ControlLoop::bind_measured_wrench(const hal::DeviceState& state) noexcept {
  // The input: the last accepted reading (held up to the timeout), in the world, carried to the
  // held body's COM (in kActive, a body held); else the brake.
  core::Data& d = *data_;
  const int a = d.attached_body;
  const bool held = a >= 0 && a < model_->num_bodies();
  const bool active = device_->lifecycle() == hal::LifecycleState::kActive && !device_->shutting_down();
  if (active && held) {
    d.device_wrench = core::carry_wrench(state.wrench, state.wrench_point,
                                         d.bodies[static_cast<std::size_t>(a)].position);
    report_.feedback = d.device_wrench;
    report_.driven = true;
  } else {
    brake_held_body();
    report_.feedback = core::Wrench{};
  }
}

void ControlLoop::command_held_pose(const hal::DeviceState& state, hal::DeviceCommand& command) noexcept {
  (void)state;
  // The held body's pose to the drives (the device holds the set-points outside kActive).
  const core::Data& d = *data_;
  const int a = d.attached_body;
  if (a < 0 || a >= model_->num_bodies()) return;
  const core::BodyState& s = d.bodies[static_cast<std::size_t>(a)];
  held_pose_ = core::Pose{s.position, s.orientation};
  command.pose = &held_pose_;
}

RearmResult ControlLoop::rearm() noexcept { return device_->rearm(); }

hal::LifecycleResult ControlLoop::activate() noexcept {
  const hal::LifecycleResult r = device_->activate();
  if (r == hal::LifecycleResult::kOk && first_active_period_ < 0) {
    first_active_period_ = static_cast<std::int64_t>(counters_.periods) - 1;
  }
  return r;
}

void ControlLoop::shutdown() noexcept { device_->shutdown(); }

bool ControlLoop::drives_disabled() const noexcept { return device_->drives_disabled(); }

}  // namespace numen::platform
