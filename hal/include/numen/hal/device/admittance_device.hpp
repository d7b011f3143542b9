#pragma once
/// @file admittance_device.hpp
/// Controller side of an admittance device (paper Fig. 2 note): the device measures the
/// wrench the user applies to its handle (ForceSensor, force_sensor.hpp) and is position
/// controlled; numen commands it the god-object's pose through inverse kinematics, one CiA 402
/// drive per axis in cyclic synchronous position mode (csp, modes of operation 8): controlword
/// 0x6040 + target position 0x607A INTEGER32 counts in one 6-byte RPDO per axis
/// (csp_drive_rpdo_mapping(), docs/protocol.md).
/// Construction validates and may allocate/throw; every other call is noexcept, allocation
/// free, lock free and never blocks.

#include <cstdint>
#include <memory>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/device/device_lifecycle.hpp"
#include "numen/hal/device/device.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/force_sensor.hpp"
#include "numen/hal/device/kinematics.hpp"

namespace numen::hal {

/// What the scene says about an admittance device besides its DeviceConfig (axes, kinds,
/// geometry): the force sensor and the csp RPDO of each axis.
struct AdmittanceConfig {
  /// The 6-axis force/torque sensor on the handle.
  ForceSensorConfig sensor;
  /// Per DeviceConfig::axes entry: COB-ID of the axis drive's csp RPDO (11-bit).
  std::vector<std::uint32_t> rpdo_cob_ids;
};

/// The default AdmittanceConfig of `device`: sensor defaults (node 32: TPDOs 0x1A0 / 0x2A0) and
/// per axis the RPDO1 of the axis's encoder node, 0x200 + (encoder_cob_id − 0x180) (CiA 301
/// predefined connection set). No validation.
AdmittanceConfig make_admittance_config(const DeviceConfig& device);

/// Throws std::invalid_argument naming the device and the field when: one rpdo_cob_ids entry
/// per axis is missing; an RPDO COB-ID is outside 0x001–0x7FF, in 0x080–0x0FF or 0x700–0x77F,
/// used twice, or equal to an encoder COB-ID or a sensor COB-ID; the sensor is invalid
/// (validate(ForceSensorConfig)).
void validate(const DeviceConfig& device, const AdmittanceConfig& admittance);

/// Counters since construction.
struct AdmittanceDeviceCounters {
  std::uint64_t rpdos_written = 0;     ///< csp RPDOs accepted by the bus.
  std::uint64_t write_failures = 0;    ///< csp RPDOs the bus did not take.
  std::uint64_t clamped_to_range = 0;  ///< Set-points clamped to an axis's [min, max].
  std::uint64_t rate_limited = 0;      ///< Set-points limited to max_speed · control period.
  std::uint64_t ik_rejected = 0;       ///< Poses whose inverse kinematics was not finite (held).
  std::uint64_t invalid_periods = 0;   ///< Periods without a valid force reading.
  std::uint64_t hold_periods = 0;      ///< write_pose() calls outside kActive (set-points held).
  std::uint64_t ignored_frames = 0;    ///< Frames read that were not the sensor's.
};

/// Creation settings of an admittance device's supervision (docs/safety.md): the lifecycle's
/// (LifecycleSettings::safe_stop_timeout_periods, >= 1, its base) and the device's own.
struct AdmittanceSettings : LifecycleSettings {
  /// Consecutive periods without a valid force reading that latch the safe state, >= 1 (the
  /// last accepted reading drives the god-object meanwhile).
  std::uint32_t force_timeout_periods = 3;
  /// Activate on its own in the first period with a valid reading (else call activate()).
  bool auto_activate = true;
  /// Consecutive overrun periods (supervise()'s `overrun`) that latch the safe state, as the
  /// impedance stack's ImpedanceSettings::overrun_limit; 0: overruns are never latched (offline
  /// runs, where there is no deadline to miss).
  std::uint32_t overrun_limit = 0;
};

/// An admittance device as the controller drives it: the admittance kind of hal::Device
/// (device.hpp). One period:
///   begin_period: SYNC;
///   read:         the force sensor's TPDOs → the checked reading (force_sample());
///   supervise:    a DeviceLifecycle: a reading out of range, none valid for
///                 force_timeout_periods, or overrun_limit consecutive overruns latch the safe
///                 state (FaultCause kForceOutOfRange, kForceTimeout, kOverruns; first_fault());
///                 the automatic activation at the first valid reading; a pending re-arm;
///   write_pose:   in kActive the controlled frame's new pose → inverse kinematics → csp RPDOs
///                 (controlword enable operation + target position), else the set-points held
///                 with controlword shutdown (0x0006, CiA 402: operation disabled).
class AdmittanceDevice final : public Device {
 public:
  /// Validates `device` (validate(DeviceConfig)), `admittance` and `settings`, builds the
  /// kinematics (make_kinematics) and the sensor decoder, configures the lifecycle
  /// (kUnconfigured → kInactive); the set-points start at `q0` (the device's current axis
  /// values, m / rad, num_axes entries; empty: 0). Keeps a reference: `bus` must outlive the
  /// device. Throws std::invalid_argument.
  AdmittanceDevice(DeviceConfig device, AdmittanceConfig admittance, Bus& bus,
                   const AxisVector& q0 = AxisVector(), const AdmittanceSettings& settings = {});

  DeviceSupervision supervise(std::int64_t now_ns, bool overrun) noexcept override;
  /// kInactive → kActive now (refused while the reading is invalid: kCausePresent).
  LifecycleResult activate() noexcept override { return lifecycle_.activate(); }
  /// Accepted when the safe state is latched: the lifecycle re-arms (kFault → kInactive) in
  /// the first period whose reading is valid again, and auto_activate then follows.
  RearmResult rearm() noexcept override;
  bool rearm_pending() const noexcept override { return rearm_pending_; }
  LifecycleState lifecycle() const noexcept override { return lifecycle_.state(); }
  /// Controlword shutdown was sent since the last kActive period.
  bool drives_disabled() const noexcept override { return disable_sent_; }
  const FaultRecord* first_fault() const noexcept override {
    return has_first_fault_ ? &first_fault_ : nullptr;
  }

  /// The sensor's checked reading of the last read().
  const ForceSample& force_sample() const noexcept { return sample_; }
  /// The lifecycle.
  const DeviceLifecycle& device_lifecycle() const noexcept { return lifecycle_; }
  /// `sensor_wrench` (sensor frame; N, N·m about the sensor origin) in the world frame, with
  /// the torque taken about the world point `about` (m). The sensor's pose is the forward
  /// kinematics of the current set-points · sensor_in_tool: the device is assumed to be where
  /// it was commanded (csp drives track within their following error; this protocol reads no
  /// position back).
  core::Wrench world_wrench(const core::Wrench& sensor_wrench,
                            const core::Vec3& about) const noexcept;
  /// Sends the period's set-points at `now_ns`: in kActive (and not shutting down), with
  /// `pose` given, new set-points for the controlled frame at `*pose` (world; set_pose()) and
  /// controlword enable operation; otherwise the set-points held and controlword shutdown. The
  /// one gate of the admittance output. Returns kOk if every RPDO was accepted, else the first
  /// failure.
  IoStatus write_pose(const core::Pose* pose, std::int64_t now_ns) noexcept;
  /// Device::write(): write_pose(command.pose, now_ns); gated while the set-points are held.
  const DeviceOutput& write(const DeviceCommand& command, std::int64_t now_ns) noexcept override;
  /// The controlword of the last write_pose() (0 before the first).
  std::uint16_t controlword() const noexcept { return controlword_; }
  /// New set-points for the controlled frame at `pose` (world): inverse kinematics seeded with
  /// the current set-points, each axis clamped to [min, max] and its change limited to
  /// max_speed · control period (a csp set-point must not jump). A non-finite IK result keeps
  /// the set-points (counted). Returns the set-points. (write_pose() calls it in kActive.)
  const AxisVector& set_pose(const core::Pose& pose) noexcept;
  /// Replaces the set-points (no clamping): setup and tests.
  void reset_setpoints(const AxisVector& q) noexcept;
  /// Writes one csp RPDO per axis: `controlword` and the set-point in counts
  /// (value_to_counts), stamped `now_ns`. Returns kOk if every write was accepted, else the
  /// first failure. (write_pose() calls it with the lifecycle's controlword.)
  IoStatus write_setpoints(std::uint16_t controlword, std::int64_t now_ns) noexcept;
  /// Current set-points (m / rad).
  const AxisVector& setpoints() const noexcept { return q_; }
  /// Forward kinematics of the set-points: the commanded pose of the controlled frame.
  core::Pose commanded_pose() const noexcept { return kinematics_->forward(q_); }
  /// Set-points in counts, as last written.
  const std::array<std::int32_t, kMaxAxes>& counts() const noexcept { return counts_; }
  int num_axes() const noexcept { return kinematics_->num_axes(); }
  const Kinematics& kinematics() const noexcept { return *kinematics_; }
  const DeviceConfig& config() const noexcept { return device_; }
  const AdmittanceConfig& admittance() const noexcept { return admittance_; }
  const AdmittanceSettings& settings() const noexcept { return settings_; }
  const ForceSensor& sensor() const noexcept { return sensor_; }
  const AdmittanceDeviceCounters& counters() const noexcept { return counters_; }
  /// Device::conditioning(): the set-points' counters (counters()).
  OutputConditioning conditioning() const noexcept override { return {nullptr, nullptr, &counters_}; }

 private:
  bool on_input_frame(const CanFrame& frame) noexcept override {
    if (sensor_.on_frame(frame)) return true;
    ++counters_.ignored_frames;
    return false;
  }
  // The checked reading (ForceSensor::sample()) as the state: the wrench in the world about the
  // sensor's origin (world_wrench()).
  void end_read(std::int64_t now_ns, DeviceState& state) noexcept override;
  // `sensor_wrench` in the world, about the sensor origin; `origin` gets that origin (world).
  core::Wrench sensor_to_world(const core::Wrench& sensor_wrench, core::Vec3& origin) const noexcept;
  void on_shutdown() noexcept override;

  DeviceConfig device_;
  AdmittanceConfig admittance_;
  AdmittanceSettings settings_;
  std::unique_ptr<Kinematics> kinematics_;
  ForceSensor sensor_;
  PdoMapping rpdo_map_;
  DeviceLifecycle lifecycle_;
  ForceSample sample_;
  AxisVector q_;
  std::array<std::int32_t, kMaxAxes> counts_{};
  AdmittanceDeviceCounters counters_;
  FaultRecord first_fault_;
  std::uint64_t periods_ = 0;         // supervise() calls
  std::uint32_t overrun_streak_ = 0;  // consecutive periods told they overran
  std::uint16_t controlword_ = 0;
  bool has_first_fault_ = false;
  bool rearm_pending_ = false;
  bool disable_sent_ = false;  // controlword shutdown sent since the last kActive period
};

}  // namespace numen::hal
