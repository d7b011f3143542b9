#pragma once
/// @file device_state.hpp
/// The device face's records (hal::Device, device.hpp): DeviceState, what Device::read()
/// found this period — everything a control period needs from a device of either kind, the
/// instrument's DeviceSample held whole — DeviceCommand / DeviceOutput, what Device::write() is
/// given and what it sent, and TorqueCounters / OutputConditioning, what the writes'
/// conditioning did so far. The values are checked once, where they are decoded
/// (InstrumentDevice, ForceSensor): range, freshness and speed; nothing above hal checks them
/// again.

#include <array>
#include <cstdint>
#include <span>

#include "numen/core/types.hpp"
#include "numen/hal/device/device_sample.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/device/sample_check.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

class PassivityController;  // passivity_controller.hpp: an impedance device's output controller
struct AdmittanceDeviceCounters;  // admittance_device.hpp: an admittance device's set-points

/// What Device::read() found this period: the instrument's checked sample (the DeviceSample
/// it holds, device_sample.hpp: an impedance device's read() assigns InstrumentDevice::sample()'s
/// result to it whole) and what the sample does not say — the bus, the axis count, the links'
/// Jacobians, an admittance device's wrench. An impedance device (encoders in) fills the sample's
/// axis and link fields; an admittance device (a force sensor in) fills `valid`, `ready` and
/// `faults` of it (its force reading's), `wrench` and `wrench_point`, and leaves the axes and
/// links empty (num_axes = num_links = 0). Of the sample's fields: `valid`: every axis
/// (impedance) or the force reading (admittance) fresh and plausible this period; `ready`: the
/// input has a value to drive with — every axis has had an accepted value (impedance; the values
/// may be held from an earlier period when `valid` is false), always true for an admittance
/// device (its last accepted reading, zero before the first); `faults`: the union of the failed
/// checks this period (SampleFault bits; kNoData before the first read); `time_ns`: `now_ns`
/// given to read() (bus clock, ns); `periods_since_accepted`: the freshness the encoder watchdog
/// reads.
struct DeviceState : DeviceSample {
  /// Before the first read: no data, no link.
  DeviceState() noexcept {
    faults = SampleFault::kNoData;
    num_links = 0;
  }
  // ---- the bus ----
  int frames_read = 0;      ///< Frames taken from the bus this period.
  bool read_error = false;  ///< A Bus::read() returned IoStatus::kError (the reads stopped).
  int input_frames = 0;     ///< Frames the kind's input took (encoder or force TPDOs).
  // ---- impedance: axes and links (the sample's q, qdot, dq, link_poses, link_twists) ----
  int num_axes = 0;  ///< n; 0 for an admittance device.
  /// Geometric Jacobian of each link at q (6 × n, world, linear part at the link's origin):
  /// what maps a link wrench w_l to axis torques, τ = Σ_l J_lᵀ w_l (paper Eq. 8 by virtual work).
  std::array<Jacobian, kMaxLinks> link_jacobians{};
  // ---- admittance: the measured wrench ----
  /// The handle's measured wrench, world: N, and N·m about `wrench_point` (the last accepted
  /// reading, held through a rejection; zero before the first). Zero for an impedance device.
  core::Wrench wrench;
  /// The point the torque of `wrench` is about: the sensor's origin, world, m (from the
  /// commanded set-points: AdmittanceDevice::world_wrench()).
  core::Vec3 wrench_point = core::Vec3::Zero();
};

/// What Device::write() sends this period.
struct DeviceCommand {
  /// Impedance: the axis torques τ (N·m or N, n entries; missing entries are 0), gated,
  /// conditioned and clamped by the device (ImpedanceDevice::write()).
  std::span<const double> torques;
  /// Admittance: the held body's pose, world — the device's new set-points through inverse
  /// kinematics (numen's admittance device is position controlled from the god-object's pose;
  /// paper Fig. 2 note); null: the set-points are held.
  const core::Pose* pose = nullptr;
};

/// What the last Device::write() sent.
struct DeviceOutput {
  IoStatus status = IoStatus::kOk;  ///< kOk if every frame was accepted, else the failure.
  /// Impedance: non-zero torque on at least one drive (SentTorques::any()); admittance: false.
  bool torque_commanded = false;
  /// Impedance: every axis was zeroed by the gate (SentTorques::gated); admittance: the
  /// set-points were held (not kActive).
  bool gated = true;
  /// Impedance: the soft-start factor r in [0, 1] applied (SentTorques::ramp); admittance: 1.
  double ramp = 1.0;
  /// Admittance: the CiA 402 controlword sent with the set-points; 0 for an impedance device.
  std::uint16_t controlword = 0;
  /// Impedance: the axis torques sent, after the gate, the passivity controller, the clamp and
  /// the soft start (SentTorques::torque, n entries, the device's storage: valid until the next
  /// write); empty for an admittance device.
  std::span<const double> torque;
};

/// Counters of an impedance device's writes since construction (ImpedanceDevice::write(): the
/// gate, the clamp, the soft start; OutputConditioning::torque).
struct TorqueCounters {
  std::uint64_t writes = 0;        ///< write() calls.
  std::uint64_t gated_writes = 0;  ///< write() calls that zeroed every axis (SentTorques::gated).
  std::uint64_t saturations = 0;   ///< Axis torques clamped to ±max_torque.
  std::uint64_t non_finite = 0;    ///< write() calls given a NaN / inf torque on an allowed axis.
  /// Per axis: clamps to ±max_torque (entries >= n are 0).
  std::array<std::uint64_t, kMaxAxes> axis_saturations{};
  /// Soft-start ramps begun (torque enabled with DeviceConfig::soft_start_s > 0).
  std::uint64_t soft_starts = 0;
  /// Writes that scaled an open gate's torques by r < 1 (SentTorques::ramp).
  std::uint64_t ramped_writes = 0;
};

/// What the writes' conditioning did since construction, as the device face gives it
/// (Device::conditioning()): the figures a run's summary reads without naming the kind of
/// device. Each pointer is the device's storage (valid while it lives) or null.
struct OutputConditioning {
  /// The writes' counters (an impedance device: ImpedanceDevice::torque_counters()); null for a
  /// device that sends no torque (admittance).
  const TorqueCounters* torque = nullptr;
  /// The passivity controller on the output (an impedance device: ImpedanceDevice::passivity(),
  /// num_axes() == 0 when DeviceConfig::passivity is off); null for a device without one
  /// (admittance).
  const PassivityController* passivity = nullptr;
  /// The set-points' counters (an admittance device: AdmittanceDevice::counters(), the csp
  /// RPDOs written, the set-points clamped to range or rate limited, the held periods); null
  /// for a device that sends torque (impedance).
  const AdmittanceDeviceCounters* setpoints = nullptr;
};

}  // namespace numen::hal
