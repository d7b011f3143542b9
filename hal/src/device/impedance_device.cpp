/// @file impedance_device.cpp
/// hal::ImpedanceDevice: the one gate and clamp of the axis torques; make_device().

#include "numen/hal/device/impedance_device.hpp"

#include <algorithm>
#include <cmath>

#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/managed_device.hpp"
#include "numen/hal/device/minimal_device.hpp"

namespace numen::hal {

ImpedanceDevice::ImpedanceDevice(InstrumentDevice& instrument, Bus& bus)
    : Device(bus), instrument_(&instrument) {
  sent_.torque = AxisVector::Zero(instrument.num_axes());
  passivity_rate_ = AxisVector::Zero(instrument.num_axes());
  const DeviceConfig& c = instrument.config();
  // validate() bounds both; a hand-built config outside them gets no ramp rather than r = 0.
  if (std::isfinite(c.soft_start_s) && c.soft_start_s > 0.0 && c.control_period_s > 0.0)
    ramp_step_ = c.control_period_s / c.soft_start_s;
  if (c.passivity.enabled)
    passivity_ = PassivityController(instrument.num_axes(), c.control_period_s, c.passivity);
}

IoStatus ImpedanceDevice::write(std::span<const double> torques, std::int64_t now_ns) noexcept {
  const int n = instrument_->num_axes();
  ++torque_counters_.writes;
  sent_.per_mille = {};
  sent_.clamped = 0;
  // The conditioning: its sub-stages in the order of the file comment, each once.
  const std::uint32_t open = gate(torques);  // bit i: axis i passed (0: every axis gated)
  control_passivity(open);
  advance_soft_start(open != 0);
  clamp_and_ramp(open != 0);
  if (passivity_.num_axes() > 0 && open != 0)  // the controller books what was sent
    passivity_.sent(std::span<const double>(sent_.torque.data(), static_cast<std::size_t>(n)));
  sent_.gated = open == 0;
  torque_counters_.saturations += static_cast<std::uint64_t>(sent_.clamped);
  if (sent_.gated) ++torque_counters_.gated_writes;
  const IoStatus s = send(sent_, now_ns);
  note(s);
  return s;
}

std::uint32_t ImpedanceDevice::gate(std::span<const double> torques) noexcept {
  const DeviceConfig& config = instrument_->config();
  const int n = instrument_->num_axes();
  // This period's sample, no shutdown, and per axis the protocol's permission.
  const bool open = sample().valid && !shutting_down();
  std::uint32_t allowed_mask = 0;  // bit i: axis i passed the gate
  int non_finite_axis = -1;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double tau = k < torques.size() ? torques[k] : 0.0;
    const bool allowed = open && config.axes[k].has_drive() && torque_allowed(i);
    sent_.torque[i] = allowed ? tau : 0.0;
    if (allowed) allowed_mask |= 1u << static_cast<unsigned>(i);
    if (allowed && !std::isfinite(tau) && non_finite_axis < 0) non_finite_axis = i;
  }
  if (non_finite_axis < 0) return allowed_mask;
  // The non-finite trip: every axis zeroed (the managed stack latches the safe state).
  sent_.torque.setZero();
  ++torque_counters_.non_finite;
  on_non_finite_torque(non_finite_axis);
  return 0;
}

void ImpedanceDevice::control_passivity(std::uint32_t open) noexcept {
  if (passivity_.num_axes() == 0) return;
  const int n = instrument_->num_axes();
  // Its port's flow: the period's displacement of the axis values the sample decoded
  // (DeviceSample::dq) over the period T (Hannaford & Ryu's), not the filtered q̇
  // (docs/passivity.md "Passivity controller": the filter's lag hides the energy a render
  // produces). 0 for the first valid sample after an invalid one.
  const AxisVector& dq = sample().dq;
  const double dt = instrument_->config().control_period_s;
  for (int i = 0; i < n; ++i) passivity_rate_[i] = dq[i] / dt;
  // The observer and damper on the gated torques, before the clamp.
  if (open != 0)
    (void)passivity_.apply(std::span<double>(sent_.torque.data(), static_cast<std::size_t>(n)),
                           std::span<const double>(passivity_rate_.data(), static_cast<std::size_t>(n)),
                           open);
}

void ImpedanceDevice::advance_soft_start(bool open) noexcept {
  if (ramp_step_ <= 0.0) return;
  // r = min(1, k · dt / T) in the k-th write since torque was enabled.
  if (ramp_writes_ < 0 && open) {
    ramp_writes_ = 0;
    ++torque_counters_.soft_starts;
  }
  if (ramp_writes_ >= 0 && static_cast<double>(ramp_writes_) * ramp_step_ < 1.0) ++ramp_writes_;
  sent_.ramp = ramp_writes_ < 0 ? 0.0 : std::min(1.0, static_cast<double>(ramp_writes_) * ramp_step_);
  if (open && sent_.ramp < 1.0) ++torque_counters_.ramped_writes;
}

void ImpedanceDevice::clamp_and_ramp(bool open) noexcept {
  const DeviceConfig& config = instrument_->config();
  const int n = instrument_->num_axes();
  // |τ_i| <= torque_limit(axis i) (max_torque, within the RPDO's range), then × r; per mille.
  for (int i = 0; i < n && open; ++i) {
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
}

void ImpedanceDevice::end_read(std::int64_t now_ns, DeviceState& state) noexcept {
  // The sample is the state's (DeviceState holds a DeviceSample): assigned whole, once.
  static_cast<DeviceSample&>(state) = instrument_->sample(now_ns);
  state.num_axes = instrument_->num_axes();
  for (int l = 0; l < state.num_links; ++l)
    state.link_jacobians[static_cast<std::size_t>(l)] = instrument_->link_jacobian(l);
}

const DeviceOutput& ImpedanceDevice::write(const DeviceCommand& command, std::int64_t now_ns) noexcept {
  output_.status = write(command.torques, now_ns);
  output_.torque_commanded = sent_.any();
  output_.gated = sent_.gated;
  output_.ramp = sent_.ramp;
  output_.controlword = 0;
  output_.torque = std::span<const double>(sent_.torque.data(), static_cast<std::size_t>(sent_.torque.size()));
  return output_;
}

std::unique_ptr<ImpedanceDevice> make_device(InstrumentDevice& instrument, Bus& bus,
                                             std::int64_t period_ns,
                                             const ImpedanceSettings& settings,
                                             NmtMaster* network) {
  if (instrument.config().canopen.managed) {
    return std::make_unique<ManagedDevice>(instrument, bus, period_ns, settings, network);
  }
  return std::make_unique<MinimalDevice>(instrument, bus);
}

}  // namespace numen::hal
