/// @file admittance_loop.cpp

#include "numen/platform/admittance_loop.hpp"

#include <stdexcept>

#include "numen/core/rigid_body.hpp"
#include "numen/core/step.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

namespace {

hal::LifecycleSettings lifecycle_settings(const AdmittanceLoopSettings& s) {
  if (s.force_timeout_periods == 0)
    throw std::invalid_argument("admittance loop: force_timeout_periods must be >= 1");
  hal::LifecycleSettings l;
  l.safe_stop_timeout_periods = s.safe_stop_timeout_periods;
  return l;
}

}  // namespace

const char* to_string(AdmittanceFaultCause cause) noexcept {
  switch (cause) {
    case AdmittanceFaultCause::kNone: return "none";
    case AdmittanceFaultCause::kForceOutOfRange: return "force out of range";
    case AdmittanceFaultCause::kForceTimeout: return "force reading timeout";
    case AdmittanceFaultCause::kOverruns: return "overruns";
  }
  return "unknown";
}

AdmittanceLoop::AdmittanceLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                               hal::AdmittanceDevice& device,
                               const AdmittanceLoopSettings& settings)
    : model_(&model),
      data_(&data),
      bus_(&bus),
      device_(&device),
      settings_(settings),
      lifecycle_(lifecycle_settings(settings)) {
  if (model.coupling_mode != core::CouplingMode::kAdmittance)
    throw std::invalid_argument("admittance loop: the model's coupling mode must be admittance");
  lifecycle_.configure();
}

void AdmittanceLoop::begin_period(std::int64_t now_ns) noexcept {
  sync_counter_ = static_cast<std::uint8_t>(sync_counter_ >= 240 ? 1 : sync_counter_ + 1);
  if (bus_->write(hal::make_sync(now_ns, sync_counter_)) != hal::IoStatus::kOk)
    ++counters_.sync_write_failures;
}

void AdmittanceLoop::brake_held_body() noexcept {
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

const AdmittanceReport& AdmittanceLoop::end_period(std::int64_t now_ns, bool overran) noexcept {
  report_ = AdmittanceReport{};
  ++counters_.periods;
  report_.overran = overran;
  if (overran) ++counters_.overruns;
  overrun_streak_ = overran ? overrun_streak_ + 1 : 0;
  hal::CanFrame frame;
  for (int i = 0; i < 1024; ++i) {
    const hal::IoStatus s = bus_->read(frame);
    if (s == hal::IoStatus::kError) ++counters_.read_errors;
    if (s != hal::IoStatus::kOk) break;
    ++report_.frames_read;
    if (!device_->on_frame(frame)) ++counters_.ignored_frames;
  }
  const hal::ForceSample sample = device_->sample(now_ns);
  report_.sample_valid = sample.valid;
  report_.faults = sample.faults;
  if (!sample.valid) ++counters_.invalid_periods;

  const bool out_of_range = (sample.faults & hal::SampleFault::kOutOfRange) != 0;
  const bool timed_out = sample.periods_since_valid >= settings_.force_timeout_periods;
  const bool overruns =
      settings_.overrun_limit > 0 && overrun_streak_ >= settings_.overrun_limit;
  hal::LifecycleInputs in;
  in.fault = out_of_range || timed_out || overruns;
  in.cause_present = !sample.valid || overruns;
  in.drives_disabled = disable_sent_;
  const hal::LifecycleUpdate u = lifecycle_.update(now_ns, in);
  report_.entered_safe_stop = u.entered_safe_stop;
  if (u.entered_safe_stop)
    report_.cause = out_of_range ? AdmittanceFaultCause::kForceOutOfRange
                    : timed_out  ? AdmittanceFaultCause::kForceTimeout
                                 : AdmittanceFaultCause::kOverruns;
  if (settings_.auto_activate && lifecycle_.state() == hal::LifecycleState::kInactive &&
      sample.valid) {
    report_.activated = lifecycle_.activate() == hal::LifecycleResult::kOk;
  }
  const bool active = lifecycle_.state() == hal::LifecycleState::kActive;

  core::Data& d = *data_;
  const int a = d.attached_body;
  const bool held = a >= 0 && a < model_->num_bodies();
  if (active && held) {
    // The last accepted reading (held up to the timeout), in the world, about the COM.
    d.device_wrench =
        device_->world_wrench(sample.wrench, d.bodies[static_cast<std::size_t>(a)].position);
    report_.measured = d.device_wrench;
    report_.driven = true;
  } else {
    brake_held_body();
    ++counters_.hold_periods;
  }

  const std::int64_t t0 = monotonic_now_ns();
  if (step_function_ != nullptr)
    step_function_(step_context_);
  else
    core::step(*model_, d);
  report_.step_ns = monotonic_now_ns() - t0;

  if (active) {
    if (held) {
      const core::BodyState& s = d.bodies[static_cast<std::size_t>(a)];
      device_->set_pose(core::Pose{s.position, s.orientation});
    }
    report_.controlword = hal::Controlword::kEnableOperation;
    disable_sent_ = false;
  } else {
    report_.controlword = hal::Controlword::kShutdown;
  }
  report_.command_status = device_->write_setpoints(report_.controlword, *bus_, now_ns);
  if (!active && report_.command_status == hal::IoStatus::kOk) disable_sent_ = true;
  if (report_.command_status != hal::IoStatus::kOk) ++counters_.command_failures;
  report_.lifecycle = lifecycle_.state();
  return report_;
}

}  // namespace numen::platform
