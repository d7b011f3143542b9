#pragma once
/// @file managed_device.hpp
/// ManagedDevice: hal::ImpedanceDevice for the managed CANopen stack (DeviceConfig::canopen.managed;
/// docs/canopen.md, docs/safety.md). It owns the CanopenMaster (NMT start-up,
/// heartbeats both ways, EMCY log, one Cia402Master per drive) and the SafetySupervisor with
/// its DeviceLifecycle, configured at construction (kUnconfigured → kInactive). One period:
///   begin_period: SYNC, the NMT command due and the controller heartbeat (through the bus's
///                 NmtMaster: one device's commands reach its own nodes only);
///   read:         drive TPDOs, heartbeats, EMCY → CanopenMaster; encoder TPDOs →
///                 InstrumentDevice; the sample;
///   supervise:    CanopenMaster::update(); SafetySupervisor::update() (encoder timeout /
///                 jump / range, heartbeat lost, node reset, EMCY, drive fault / stuck,
///                 overruns, bus off, I/O errors: a fault latches the safe state in this very
///                 period); a pending re-arm; the automatic activation; the drives' CiA 402
///                 target from the lifecycle; entering kActive restarts the soft start;
///   write:        ImpedanceDevice::write() gates (torque_allowed(): lifecycle kActive and the axis's
///                 drive master allows torque) and clamps; then each drive's RPDO
///                 (controlword + that target torque).

#include <array>
#include <cstdint>
#include <memory>

#include "numen/hal/device/canopen_master.hpp"
#include "numen/hal/device/impedance_device.hpp"
#include "numen/hal/device/safety_supervisor.hpp"

namespace numen::hal {

/// The managed CANopen stack behind hal::ImpedanceDevice. Not thread safe.
class ManagedDevice final : public ImpedanceDevice {
 public:
  /// Keeps references: `instrument` and `bus` must outlive the device. Builds the
  /// CanopenMaster (`period_ns` > 0, the control period; its NMT commands through `network`,
  /// the NMT master the managed devices on `bus` share, or a private one when nullptr) and the
  /// SafetySupervisor (one axis per instrument axis) and configures the lifecycle. Throws
  /// std::invalid_argument for a configuration that is not managed, bad settings, or nodes or
  /// a controller node that `network`'s other devices make impossible (NmtMaster::add_device()).
  ManagedDevice(InstrumentDevice& instrument, Bus& bus, std::int64_t period_ns,
                const ImpedanceSettings& settings = {}, NmtMaster* network = nullptr);

  DeviceSupervision supervise(std::int64_t now_ns, bool overrun) noexcept override;

  /// kInactive → kActive now (SafetySupervisor::activate()); on kOk the soft start begins
  /// again (DeviceConfig::soft_start_s).
  LifecycleResult activate() noexcept override;
  RearmResult rearm() noexcept override;
  LifecycleState lifecycle() const noexcept override { return supervisor_->state(); }
  bool rearm_pending() const noexcept override { return rearm_pending_; }
  bool drives_disabled() const noexcept override;

  DeviceReport report() const noexcept override;
  DeviceNotes notes() const override;

  /// The CANopen master (hal and tests; the code above hal reads report()).
  const CanopenMaster* canopen() const noexcept { return master_.get(); }
  /// Same, mutable (e.g. to queue an NMT command).
  CanopenMaster* canopen() noexcept { return master_.get(); }
  /// The safety supervisor and lifecycle (hal and tests; above hal: report(), first_fault()).
  const SafetySupervisor* supervisor() const noexcept { return supervisor_.get(); }
  const FaultRecord* first_fault() const noexcept override { return supervisor_->first_fault(); }
  /// SafetySupervisor::trip(cause, id, 0).
  void latch_safe_state(FaultCause cause, std::uint8_t id) noexcept override {
    supervisor_->trip(cause, id, 0.0);
  }

 private:
  bool take_frame(const CanFrame& frame) noexcept override { return master_->on_frame(frame); }
  IoStatus begin_protocol(std::int64_t now_ns) noexcept override {
    return master_->begin_period(now_ns, *bus_);
  }
  bool torque_allowed(int axis) const noexcept override;
  void on_non_finite_torque(int axis) noexcept override;
  void on_shutdown() noexcept override;
  IoStatus send(const SentTorques& torques, std::int64_t now_ns) noexcept override;

  std::unique_ptr<CanopenMaster> master_;
  std::unique_ptr<SafetySupervisor> supervisor_;
  ImpedanceSettings settings_;
  // Per axis: index of its drive in the master (-1: no drive).
  std::array<int, kMaxAxes> drive_of_axis_{};
  bool rearm_pending_ = false;
  /// A re-arm reran the start-up: the drives' fault reset is requested once it is operational
  /// (a reset sent while a node is pre-operational is ignored by its drive, and the master
  /// gives it up after its transition timeout).
  bool fault_reset_after_startup_ = false;
};

}  // namespace numen::hal
