#pragma once
/// @file admittance_device.hpp
/// Controller side of an admittance device (paper Fig. 2 note): the device measures the
/// wrench the user applies to its handle (ForceSensor, force_sensor.hpp) and is position
/// controlled; numen commands it the god-object's pose through inverse kinematics, one CiA 402
/// drive per axis in cyclic synchronous position mode (csp, modes of operation 8): controlword
/// 0x6040 + target position 0x607A INTEGER32 counts in one 6-byte RPDO per axis
/// (csp_drive_rpdo_mapping(), docs/protocol.md).
/// Construction validates and may allocate/throw; every other call is noexcept and
/// allocation free.

#include <cstdint>
#include <memory>
#include <vector>

#include "numen/core/types.hpp"
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
};

/// An admittance device as the controller drives it.
class AdmittanceDevice {
 public:
  /// Validates `device` (validate(DeviceConfig)) and `admittance`, builds the kinematics
  /// (make_kinematics) and the sensor decoder; the set-points start at `q0` (the device's
  /// current axis values, m / rad, num_axes entries; empty: 0). Throws std::invalid_argument.
  AdmittanceDevice(DeviceConfig device, AdmittanceConfig admittance,
                   const AxisVector& q0 = AxisVector());

  /// Takes the sensor's TPDOs (true if the frame was one of them); false otherwise.
  bool on_frame(const CanFrame& frame) noexcept { return sensor_.on_frame(frame); }
  /// The sensor's checked reading at bus time `now_ns` (once per period).
  ForceSample sample(std::int64_t now_ns) noexcept { return sensor_.sample(now_ns); }

  /// `sensor_wrench` (sensor frame; N, N·m about the sensor origin) in the world frame, with
  /// the torque taken about the world point `about` (m). The sensor's pose is the forward
  /// kinematics of the current set-points · sensor_in_tool: the device is assumed to be where
  /// it was commanded (csp drives track within their following error; this protocol reads no
  /// position back).
  core::Wrench world_wrench(const core::Wrench& sensor_wrench,
                            const core::Vec3& about) const noexcept;

  /// New set-points for the controlled frame at `pose` (world): inverse kinematics seeded with
  /// the current set-points, each axis clamped to [min, max] and its change limited to
  /// max_speed · control period (a csp set-point must not jump). A non-finite IK result keeps
  /// the set-points (counted). Returns the set-points.
  const AxisVector& set_pose(const core::Pose& pose) noexcept;
  /// Replaces the set-points (no clamping): setup and tests.
  void reset_setpoints(const AxisVector& q) noexcept;

  /// Writes one csp RPDO per axis: `controlword` and the set-point in counts
  /// (value_to_counts), stamped `now_ns`. Returns kOk if every write was accepted, else the
  /// first failure.
  IoStatus write_setpoints(std::uint16_t controlword, Bus& bus, std::int64_t now_ns) noexcept;

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
  const ForceSensor& sensor() const noexcept { return sensor_; }
  const AdmittanceDeviceCounters& counters() const noexcept { return counters_; }

 private:
  DeviceConfig device_;
  AdmittanceConfig admittance_;
  std::unique_ptr<Kinematics> kinematics_;
  ForceSensor sensor_;
  PdoMapping rpdo_map_;
  AxisVector q_;
  std::array<std::int32_t, kMaxAxes> counts_{};
  AdmittanceDeviceCounters counters_;
};

}  // namespace numen::hal
