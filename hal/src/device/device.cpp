/// @file device.cpp
/// hal::Device: the period's order (SYNC, read, write) and the one gate and clamp of the axis
/// torques; make_device().

#include "numen/hal/device/device.hpp"

#include <algorithm>
#include <cmath>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/managed_device.hpp"
#include "numen/hal/device/minimal_device.hpp"

namespace numen::hal {

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

Device::Device(InstrumentDevice& instrument, Bus& bus) : instrument_(&instrument), bus_(&bus) {
  sent_.torque = AxisVector::Zero(instrument.num_axes());
  const DeviceConfig& c = instrument.config();
  // validate() bounds both; a hand-built config outside them gets no ramp rather than r = 0.
  if (std::isfinite(c.soft_start_s) && c.soft_start_s > 0.0 && c.control_period_s > 0.0)
    ramp_step_ = c.control_period_s / c.soft_start_s;
}

IoStatus Device::begin_period(std::int64_t now_ns) noexcept {
  // CiA 301 SYNC counter runs 1..240 when used.
  sync_counter_ = static_cast<std::uint8_t>(sync_counter_ >= 240 ? 1 : sync_counter_ + 1);
  const IoStatus s = bus_->write(make_sync(now_ns, sync_counter_));
  note(s);
  note(begin_protocol(now_ns));
  return s;
}

const DeviceRead& Device::read(std::int64_t now_ns) noexcept {
  read_ = DeviceRead{};
  CanFrame frame;
  for (int i = 0; i < 1024; ++i) {
    const IoStatus s = bus_->read(frame);
    if (s == IoStatus::kError) {
      read_.read_error = true;
      io_error_ = true;
    }
    if (s != IoStatus::kOk) break;
    ++read_.frames_read;
    if (!take_frame(frame)) instrument_->on_frame(frame);
  }
  (void)instrument_->sample(now_ns);
  return read_;
}

void Device::shutdown() noexcept {
  shutting_down_ = true;
  on_shutdown();
}

IoStatus Device::write(std::span<const double> torques, std::int64_t now_ns) noexcept {
  const DeviceConfig& config = instrument_->config();
  const int n = instrument_->num_axes();
  ++torque_counters_.writes;
  sent_.per_mille = {};
  sent_.clamped = 0;
  sent_.gated = true;
  // The gate: this period's sample, no shutdown, and per axis the protocol's permission.
  const bool open = sample().valid && !shutting_down_;
  bool any_allowed = false;
  int non_finite_axis = -1;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double tau = k < torques.size() ? torques[k] : 0.0;
    const bool allowed = open && config.axes[k].has_drive() && torque_allowed(i);
    sent_.torque[i] = allowed ? tau : 0.0;
    any_allowed = any_allowed || allowed;
    if (allowed && !std::isfinite(tau) && non_finite_axis < 0) non_finite_axis = i;
  }
  if (non_finite_axis >= 0) {
    sent_.torque.setZero();
    ++torque_counters_.non_finite;
    on_non_finite_torque(non_finite_axis);
    any_allowed = false;
  }
  // The soft start: r = min(1, k · dt / T) in the k-th write since torque was enabled.
  if (ramp_step_ > 0.0) {
    if (ramp_writes_ < 0 && any_allowed) {
      ramp_writes_ = 0;
      ++torque_counters_.soft_starts;
    }
    if (ramp_writes_ >= 0 && static_cast<double>(ramp_writes_) * ramp_step_ < 1.0) ++ramp_writes_;
    sent_.ramp = ramp_writes_ < 0 ? 0.0
                                   : std::min(1.0, static_cast<double>(ramp_writes_) * ramp_step_);
    if (any_allowed && sent_.ramp < 1.0) ++torque_counters_.ramped_writes;
  }
  // The clamp: |τ_i| <= torque_limit(axis i) (max_torque, within the RPDO's range), then r.
  for (int i = 0; i < n && any_allowed; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const AxisConfig& a = config.axes[k];
    const double lim = torque_limit(a);
    double& t = sent_.torque[i];
    if (t > lim || t < -lim) {
      t = std::clamp(t, -lim, lim);
      ++sent_.clamped;
      ++torque_counters_.axis_saturations[k];
    }
    t *= sent_.ramp;
    sent_.per_mille[k] = torque_per_mille(a, t);
  }
  sent_.gated = !any_allowed;
  torque_counters_.saturations += static_cast<std::uint64_t>(sent_.clamped);
  if (sent_.gated) ++torque_counters_.gated_writes;
  const IoStatus s = send(sent_, now_ns);
  note(s);
  return s;
}

std::unique_ptr<Device> make_device(InstrumentDevice& instrument, Bus& bus,
                                    std::int64_t period_ns, const DeviceSettings& settings) {
  if (instrument.config().canopen.managed) {
    return std::make_unique<ManagedDevice>(instrument, bus, period_ns, settings);
  }
  return std::make_unique<MinimalDevice>(instrument, bus);
}

}  // namespace numen::hal
