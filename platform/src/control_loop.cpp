/// @file control_loop.cpp

#include "numen/platform/control_loop.hpp"

#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/core/feedback.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/canopen.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

namespace {

std::int64_t period_of(const hal::InstrumentDevice& device) {
  const double p = device.config().control_period_s;
  return static_cast<std::int64_t>(std::llround(p * 1e9));
}

hal::SafetySettings safety_settings(const hal::InstrumentDevice& device,
                                    const ControlLoopSettings& s) {
  hal::SafetySettings out;
  out.encoder_timeout_periods = s.encoder_timeout_periods;
  out.overrun_limit = s.overrun_limit;
  out.safe_stop_timeout_periods = s.safe_stop_timeout_periods;
  for (const hal::AxisConfig& a : device.config().axes) {
    out.torque_limits.push_back(a.has_drive() ? a.max_torque : 0.0);
  }
  return out;
}

}  // namespace

const char* to_string(RearmResult result) noexcept {
  switch (result) {
    case RearmResult::kAccepted:
      return "accepted";
    case RearmResult::kNotLatched:
      return "nothing to re-arm";
    case RearmResult::kMinimalProtocol:
      return "minimal protocol: no lifecycle";
  }
  return "unknown";
}

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                         hal::InstrumentDevice& device, DeviceBinding binding,
                         const ControlLoopSettings& settings)
    : model_(&model),
      data_(&data),
      bus_(&bus),
      device_(&device),
      binding_(std::move(binding)),
      settings_(settings),
      stats_(std::make_unique<LoopStatistics>(period_of(device))) {
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
  explicit_bound_.assign(static_cast<std::size_t>(model.num_bodies()), 0);
  for (const LinkBinding& b : binding_.links) {
    if (b.body < 0) continue;
    if (explicit_bound_[static_cast<std::size_t>(b.body)])
      throw std::invalid_argument("device binding: body " + std::to_string(b.body) +
                                  " is bound to two links");
    explicit_bound_[static_cast<std::size_t>(b.body)] = 1;
  }
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
  if (device.config().canopen.managed) {
    master_ = std::make_unique<hal::CanopenMaster>(device.config(), period_of(device),
                                                   settings_.drive_settings);
    supervisor_ = std::make_unique<hal::SafetySupervisor>(safety_settings(device, settings_));
    supervisor_->configure();  // kUnconfigured → kInactive: read and supervised, zero torque
  }
}

void ControlLoop::apply_targets(const hal::DeviceSample& sample) noexcept {
  core::Data& d = *data_;
  for (std::size_t k = 0; k < binding_.links.size(); ++k) {
    const LinkBinding& b = binding_.links[k];
    int body = b.body < 0 ? d.attached_body : b.body;
    // The attached body follows its own link if it has one; the "attached"
    // binding (body -1) serves only a held body without one (tool switching).
    if (b.body < 0 && body >= 0 && explicit_bound_[static_cast<std::size_t>(body)]) body = -1;
    bound_body_[k] = body;
    const core::Pose& link = sample.link_targets[static_cast<std::size_t>(b.link)];
    const core::Twist& lt = sample.link_twists[static_cast<std::size_t>(b.link)];
    core::Pose pose;
    pose.position = link.position + link.orientation * b.body_in_link.position;
    pose.orientation = link.orientation * b.body_in_link.orientation;
    core::Twist twist;
    twist.angular = lt.angular;
    twist.linear = lt.linear + lt.angular.cross(pose.position - link.position);
    link_origin_[k] = link.position;
    body_target_[k] = pose.position;
    if (body < 0) continue;
    if (body == d.attached_body) {
      d.target = pose;
      d.target_twist = twist;
    } else {
      core::BodyTarget& t = d.body_targets[static_cast<std::size_t>(body)];
      t.pose = pose;
      t.twist = twist;
      t.enabled = true;
    }
  }
  for (const AxisPrescription& p : binding_.prescriptions) {
    core::JointPrescription& jp = d.joint_prescribed[static_cast<std::size_t>(p.joint)];
    jp.value = p.scale * sample.q(p.axis) + p.offset;
    jp.rate = p.scale * sample.qdot(p.axis);
  }
}

bool ControlLoop::gather_link_wrenches() noexcept {
  const core::Data& d = *data_;
  for (core::Wrench& w : link_wrench_) w = core::Wrench{};
  bool any = false;
  for (std::size_t k = 0; k < binding_.links.size(); ++k) {
    const int body = bound_body_[k];
    if (body < 0) continue;
    any = true;
    const core::Wrench w = core::carry_wrench(d.body_feedback[static_cast<std::size_t>(body)],
                                              body_target_[k], link_origin_[k]);  // Eq. 9
    core::Wrench& acc = link_wrench_[static_cast<std::size_t>(binding_.links[k].link)];
    acc.force += w.force;
    acc.torque += w.torque;
  }
  return any;
}

bool ControlLoop::send_feedback(std::int64_t now_ns) noexcept {
  if (!gather_link_wrenches()) return false;
  const auto n = static_cast<std::size_t>(device_->kinematics().num_links());
  report_.command_status =
      device_->command_links(std::span<const core::Wrench>(link_wrench_.data(), n), *bus_, now_ns);
  return true;
}

void ControlLoop::begin_period(std::int64_t now_ns, std::int64_t deadline_mono_ns,
                               std::int64_t woke_mono_ns) noexcept {
  const std::int64_t t = monotonic_now_ns();
  begin_.woke_ns = woke_mono_ns >= 0 ? woke_mono_ns : t;
  begin_.deadline_ns = deadline_mono_ns >= 0 ? deadline_mono_ns : begin_.woke_ns;
  if (begin_.deadline_ns > begin_.woke_ns) begin_.deadline_ns = begin_.woke_ns;
  // CiA 301 SYNC counter runs 1..240 when used.
  sync_counter_ = static_cast<std::uint8_t>(sync_counter_ >= 240 ? 1 : sync_counter_ + 1);
  const hal::IoStatus s = bus_->write(hal::make_sync(now_ns, sync_counter_));
  if (s != hal::IoStatus::kOk) ++counters_.sync_write_failures;
  if (s == hal::IoStatus::kError) io_error_ = true;
  if (master_ && master_->begin_period(now_ns, *bus_) == hal::IoStatus::kError) io_error_ = true;
  begin_.sync_sent_ns = monotonic_now_ns();
}

void ControlLoop::step_model() noexcept {
  report_.step_begin_ns = monotonic_now_ns();
  core::step(*model_, *data_);
  report_.step_end_ns = monotonic_now_ns();
  report_.step_ns = report_.step_end_ns - report_.step_begin_ns;
  step_time_.record(report_.step_ns);
}

void ControlLoop::end_period_minimal(std::int64_t now_ns, const hal::DeviceSample& sample) noexcept {
  step_model();
  report_.output_begin_ns = monotonic_now_ns();
  // Torque only from a sample checked this period: a stale or rejected sample
  // keeps the last good target for the god-object, but the drives get zero
  // torque until fresh plausible data arrive (no "hold the last command").
  if (!(sample.valid && !shutting_down_ && send_feedback(now_ns))) {
    ++counters_.periods_zero_torque;
    report_.command_status = device_->command_zero(*bus_, now_ns);
  }
  report_.output_end_ns = monotonic_now_ns();
  for (std::int16_t pm : device_->last_torque_per_mille()) report_.torque_commanded |= pm != 0;
}

void ControlLoop::end_period_managed(std::int64_t now_ns, const hal::DeviceSample& sample) noexcept {
  hal::CanopenMaster& m = *master_;
  hal::SafetySupervisor& sup = *supervisor_;
  m.update(now_ns);
  hal::SafetyInputs in;
  const auto n = static_cast<std::size_t>(device_->num_axes());
  in.periods_since_fresh = std::span<const std::uint32_t>(sample.periods_since_accepted.data(), n);
  in.axis_faults = std::span<const hal::FaultMask>(sample.axis_faults.data(), n);
  in.heartbeats = m.heartbeats();
  in.emcy_faults = m.emcy_log().counters().faults;
  in.emcy_last_fault = hal::newest_emcy_fault(m.emcy_log());
  in.drives = m.drive_outputs();
  in.overrun = settings_.supervise_overruns && last_overrun_;
  in.bus_state = bus_->state();
  in.io_error = io_error_;
  io_error_ = false;
  const hal::LifecycleUpdate u = sup.update(now_ns, in);
  report_.entered_safe_stop = u.entered_safe_stop;
  if (rearm_pending_ && sup.state() == hal::LifecycleState::kFault && m.operational() &&
      sup.rearm() == hal::LifecycleResult::kOk) {
    rearm_pending_ = false;
  }
  if (!shutting_down_ && settings_.auto_activate && sup.state() == hal::LifecycleState::kInactive &&
      m.operational() && sup.blocking().cause == hal::FaultCause::kNone) {
    report_.activated = sup.activate() == hal::LifecycleResult::kOk;
  }
  if (report_.activated && first_active_period_ < 0) {
    first_active_period_ = static_cast<std::int64_t>(counters_.periods) - 1;
  }
  m.request_drives(sup.drive_target());

  step_model();

  report_.output_begin_ns = monotonic_now_ns();
  bool have = sample.valid && gather_link_wrenches();
  if (have) {
    const auto links = static_cast<std::size_t>(device_->kinematics().num_links());
    have = device_->torques_for(std::span<const core::Wrench>(link_wrench_.data(), links), tau_);
  }
  if (!have) tau_.setZero();
  sup.saturate_torques(std::span<double>(tau_.data(), n));  // zeros unless active; NaN trips
  const std::span<const hal::Cia402MasterOutput> drives = m.drive_outputs();
  for (std::size_t i = 0; i < drives.size(); ++i) {
    if (!drives[i].torque_allowed) tau_[m.drive_axis(i)] = 0.0;
  }
  const std::array<std::int16_t, hal::kMaxAxes>& pm = device_->encode_torques(tau_);
  report_.command_status =
      m.write_drive_rpdos(now_ns, std::span<const std::int16_t>(pm.data(), n), *bus_);
  report_.output_end_ns = monotonic_now_ns();
  if (report_.command_status == hal::IoStatus::kError) io_error_ = true;
  for (std::size_t a = 0; a < n; ++a) report_.torque_commanded |= pm[a] != 0;
  if (!report_.torque_commanded) ++counters_.periods_zero_torque;
  if (report_.torque_commanded && first_torque_period_ < 0) {
    first_torque_period_ = static_cast<std::int64_t>(counters_.periods) - 1;
  }
  report_.lifecycle = sup.state();
  report_.startup = m.startup().phase;
}

const PeriodReport& ControlLoop::end_period(std::int64_t now_ns) noexcept {
  report_ = begin_;
  ++counters_.periods;
  report_.input_begin_ns = monotonic_now_ns();
  hal::CanFrame frame;
  for (int i = 0; i < 1024; ++i) {
    const hal::IoStatus s = bus_->read(frame);
    if (s == hal::IoStatus::kError) {
      ++counters_.read_errors;
      io_error_ = true;
    }
    if (s != hal::IoStatus::kOk) break;
    ++report_.frames_read;
    if (!(master_ && master_->on_frame(frame))) device_->on_frame(frame);
  }
  report_.input_end_ns = monotonic_now_ns();
  const hal::DeviceSample sample = device_->sample(now_ns);
  report_.sample_valid = sample.valid;
  report_.target_ready = sample.ready;
  if (sample.ready) apply_targets(sample);

  if (master_) {
    end_period_managed(now_ns, sample);
  } else {
    end_period_minimal(now_ns, sample);
  }
  if (report_.command_status != hal::IoStatus::kOk) ++counters_.command_failures;
  const PeriodVerdict v = stats_->record_period(report_.times());
  report_.overrun = v.overrun;
  last_overrun_ = v.overrun;
  return report_;
}

RearmResult ControlLoop::rearm() noexcept {
  if (!master_) return RearmResult::kMinimalProtocol;
  const bool failed = master_->startup().phase == hal::StartupPhase::kFailed;
  const bool latched = supervisor_->lifecycle().latched();
  if (!latched && !failed) return RearmResult::kNotLatched;
  master_->request_fault_reset();
  if (failed || !master_->all_nodes_operational()) master_->restart_startup();
  rearm_pending_ = latched;
  return RearmResult::kAccepted;
}

hal::LifecycleResult ControlLoop::activate() noexcept {
  if (!supervisor_) return hal::LifecycleResult::kNotInactive;
  const hal::LifecycleResult r = supervisor_->activate();
  if (r == hal::LifecycleResult::kOk && first_active_period_ < 0) {
    first_active_period_ = static_cast<std::int64_t>(counters_.periods) - 1;
  }
  return r;
}

void ControlLoop::shutdown() noexcept {
  shutting_down_ = true;
  rearm_pending_ = false;
  if (supervisor_ && supervisor_->state() == hal::LifecycleState::kActive)
    (void)supervisor_->deactivate();
}

bool ControlLoop::drives_disabled() const noexcept {
  if (!master_) return true;
  for (const hal::Cia402MasterOutput& d : master_->drive_outputs()) {
    switch (d.state) {
      case hal::PowerState::kSwitchOnDisabled:
      case hal::PowerState::kReadyToSwitchOn:
      case hal::PowerState::kNotReadyToSwitchOn:
      case hal::PowerState::kFault:
        break;
      default:
        return false;
    }
  }
  return true;
}

}  // namespace numen::platform
