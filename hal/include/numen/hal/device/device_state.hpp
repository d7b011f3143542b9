#pragma once
/// @file device_state.hpp
/// The device face's two records (hal::Device, device.hpp): DeviceState, what Device::read()
/// found this period — everything a control period needs from a device of either kind — and
/// DeviceCommand / DeviceOutput, what Device::write() is given and what it sent. The values
/// are checked once, where they are decoded (InstrumentDevice, ForceSensor): range, freshness
/// and speed; nothing above hal checks them again.

#include <array>
#include <cstdint>
#include <span>

#include "numen/core/types.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/device/sample_check.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

/// What Device::read() found this period. An impedance device (encoders in) fills the axis and
/// link fields; an admittance device (a force sensor in) fills `wrench` and `wrench_point` and
/// leaves the axes and links empty (num_axes = num_links = 0).
struct DeviceState {
  // ---- the bus ----
  int frames_read = 0;      ///< Frames taken from the bus this period.
  bool read_error = false;  ///< A Bus::read() returned IoStatus::kError (the reads stopped).
  int input_frames = 0;     ///< Frames the kind's input took (encoder or force TPDOs).
  // ---- the checked input ----
  /// Every axis (impedance) or the force reading (admittance) fresh and plausible this period.
  bool valid = false;
  /// The input has a value to drive with: every axis has had an accepted value (impedance; the
  /// values may be held from an earlier period when `valid` is false); always true for an
  /// admittance device (its last accepted reading, zero before the first).
  bool ready = false;
  /// Union of the failed checks this period (SampleFault bits).
  FaultMask faults = SampleFault::kNoData;
  /// `now_ns` given to read() (bus clock, ns).
  std::int64_t time_ns = 0;
  // ---- impedance: axes (n = num_axes entries) ----
  int num_axes = 0;  ///< n; 0 for an admittance device.
  /// Failed checks per axis this period (SampleFault bits; entries >= n are 0).
  std::array<FaultMask, kMaxAxes> axis_faults{};
  /// Per axis: periods since the axis last accepted a value (0: this period), the freshness the
  /// encoder watchdog reads (DeviceSample::periods_since_accepted).
  std::array<std::uint32_t, kMaxAxes> periods_since_accepted{};
  AxisVector q;     ///< Axis values, m or rad (the last accepted, held through a rejection).
  AxisVector qdot;  ///< Axis rates, m/s or rad/s (DeviceSample::qdot: the one estimate).
  /// Axis displacements over the period, m or rad (DeviceSample::dq: the passivity port's flow
  /// times T, 0 after a sample that was not valid).
  AxisVector dq;
  // ---- impedance: links (num_links entries) ----
  int num_links = 0;  ///< Links of the kinematics, 1..kMaxLinks; 0 for an admittance device.
  /// Pose of each link, world (Kinematics::link_pose(l, q); link 0: the controlled frame).
  std::array<core::Pose, kMaxLinks> link_poses{};
  /// Twist of each link, world, linear part at the link's origin: J_l(q) q̇.
  std::array<core::Twist, kMaxLinks> link_twists{};
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

}  // namespace numen::hal
