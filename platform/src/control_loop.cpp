/// @file control_loop.cpp

#include "numen/platform/control_loop.hpp"

#include "numen/core/step.hpp"
#include "numen/hal/canopen.hpp"
#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

ControlLoop::ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
                         hal::InstrumentDevice& device) noexcept
    : model_(&model), data_(&data), bus_(&bus), device_(&device) {}

void ControlLoop::begin_period(std::int64_t now_ns) noexcept {
  // CiA 301 SYNC counter runs 1..240 when used.
  sync_counter_ = static_cast<std::uint8_t>(sync_counter_ >= 240 ? 1 : sync_counter_ + 1);
  if (bus_->write(hal::make_sync(now_ns, sync_counter_)) != hal::IoStatus::kOk)
    ++counters_.sync_write_failures;
}

const PeriodReport& ControlLoop::end_period(std::int64_t now_ns) noexcept {
  report_ = PeriodReport{};
  ++counters_.periods;
  report_.frames_read = device_->poll(*bus_);
  const hal::DeviceSample sample = device_->sample(now_ns);
  report_.sample_valid = sample.valid;
  report_.target_ready = sample.ready;
  if (sample.ready) {
    data_->target = sample.target;
    data_->target_twist = sample.twist;
  }

  const std::int64_t t0 = monotonic_now_ns();
  core::step(*model_, *data_);
  report_.step_ns = monotonic_now_ns() - t0;
  step_time_.record(report_.step_ns);

  // Torque only from a sample checked this period: a stale or rejected sample
  // keeps the last good target for the god-object, but the drives get zero
  // torque until fresh plausible data arrive (no "hold the last command").
  if (sample.valid && data_->attached_body >= 0) {
    report_.command_status = device_->command(data_->feedback_wrench, *bus_, now_ns);
  } else {
    ++counters_.periods_zero_torque;
    report_.command_status = device_->command_zero(*bus_, now_ns);
  }
  if (report_.command_status != hal::IoStatus::kOk) ++counters_.command_failures;
  return report_;
}

}  // namespace numen::platform
