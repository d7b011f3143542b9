#pragma once
/// @file impedance_device.hpp
/// hal::ImpedanceDevice: the impedance kind of hal::Device (device.hpp): encoder TPDOs in, axis
/// torques out, through an InstrumentDevice (decoding, checks, kinematics). One control period
/// of a device is, in this order:
///
///   begin_period(now)  SYNC (CiA 301, COB-ID 0x080) and the protocol's own period-start frames
///   read(now)          every pending frame → decode → the checked sample (InstrumentDevice)
///   supervise(now, …)  watchdogs and lifecycle: whether torque may be sent this period
///   … the caller steps the dynamics and maps the feedback to axis torques τ = Σ J_lᵀ w_l …
///   write(τ, now)      gate and clamp τ (here, once), then the protocol's torque frames
///
/// write() is the one place where axis torques are gated and clamped, for every protocol:
///  - gate: every axis gets 0 unless this period's sample is valid, shutdown() was not called,
///    and the implementation allows torque on the axis (torque_allowed(): the axis has a drive;
///    managed stack: the lifecycle is kActive and that drive's CiA 402 master allows torque);
///  - non-finite: a NaN or infinite τ on an allowed axis zeroes every axis (the managed stack
///    latches the safe state, FaultCause::kNonFiniteTorque);
///  - passivity controller (DeviceConfig::passivity enabled; passivity_controller.hpp): on
///    the allowed axes of its mask, the observer books E_i −= T τ_i v_i (v_i = Δq_i / T, the
///    axis's displacement over the period decoded with the sample, DeviceSample::dq:
///    Hannaford & Ryu's flow, not the filtered DeviceSample::qdot) and, while E_i < 0, the
///    damper −α v_i is added to τ_i. It runs
///    after the gate (a gated axis gets no damping) and before the clamp and the soft start,
///    so the clamp still bounds what is sent; what they take away is booked back into E
///    (PassivityController::sent());
///  - clamp: |τ_i| <= AxisConfig::max_torque (N·m or N), counted per axis;
///  - soft start: every clamped τ_i times r(t) = min(1, k · dt / T) in the k-th write since
///    torque was enabled (T = DeviceConfig::soft_start_s, dt = control_period_s; T = 0: r = 1).
///    Torque is enabled at the first write whose gate opens after construction or, managed
///    stack, after the lifecycle entered kActive (the start-up, activate(), the activation that
///    follows a rearm()). A linear ramp, as a CiA 402 drive's torque slope (object 0x6087) and
///    OpenHaptics' HD_FORCE_RAMPING: each period adds at most max_torque · dt / T to |τ_i|
///    (docs/safety.md, "Soft start").
/// The protocol implementations only encode what write() decided (sent_torques()); nothing
/// downstream clamps or gates again, so what sent_torques() reports is what the drives receive
/// (up to the per mille rounding of the RPDO, AxisConfig::rated_torque / 1000).
///
/// Implementations: MinimalDevice (the minimal protocol: SYNC, position TPDOs, torque RPDOs)
/// and ManagedDevice (the managed CANopen stack: NMT start-up, heartbeats, EMCY, CiA 402
/// drives, SafetySupervisor and DeviceLifecycle); make_device() picks one from
/// DeviceConfig::canopen.managed. Construction allocates and may throw; every other member is
/// noexcept, allocation free, lock free and never blocks.

#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include "numen/hal/device/device.hpp"
#include "numen/hal/device/device_status.hpp"
#include "numen/hal/device/instrument_device.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/device/passivity_controller.hpp"

namespace numen::hal {

class NmtMaster;  // nmt_master.hpp: the NMT master the managed devices on one bus share

/// Creation settings of an impedance device's supervision (the minimal protocol uses none):
/// the supervision settings (SupervisionSettings: encoder timeout, overrun limit, safe-stop
/// timeout, defined once there) and the device's own.
struct ImpedanceSettings : SupervisionSettings {
  /// Activate the lifecycle on its own once the start-up is complete and no fault cause is
  /// present; false: the caller calls activate().
  bool auto_activate = true;
  /// Settings of each drive's Cia402Master.
  Cia402MasterSettings drive_settings;
};

/// The torques of the last write(), exactly as the torque frames carry them.
struct SentTorques {
  /// Per axis, N·m (revolute) or N (prismatic), after the gate and the clamp: 0 on a gated
  /// axis and on an axis without a drive (n entries). The RPDO carries round(1000 τ / rated)
  /// per mille of it (per_mille).
  AxisVector torque;
  /// Per axis, the RPDO's target torque, per mille of AxisConfig::rated_torque, sign applied
  /// (entries >= n and axes without a drive are 0).
  std::array<std::int16_t, kMaxAxes> per_mille{};
  /// Every axis was zeroed by the gate (no valid sample, shut down, not allowed, non-finite).
  bool gated = true;
  /// Axes clamped to ±max_torque in this write.
  int clamped = 0;
  /// The soft-start factor r in [0, 1] this write applied to every clamped τ_i (1: no ramp
  /// running or soft start off; 0: torque not enabled yet, so the write was gated).
  double ramp = 1.0;
  /// Some per mille value is not zero.
  bool any() const noexcept {
    for (std::int16_t v : per_mille)
      if (v != 0) return true;
    return false;
  }
};

/// One instrument on one bus, the impedance kind (see the file comment). Not thread safe: one
/// real-time thread owns it.
class ImpedanceDevice : public Device {
 public:
  /// Sends axis torques `torques` (N·m or N, n entries; missing entries are 0) at `now_ns`:
  /// gates and clamps them (the file comment; the only place that does), stores the result
  /// (sent_torques()) and writes the protocol's torque frames (minimal: one torque RPDO per
  /// driven axis; managed: controlword + target torque RPDO per drive). Returns kOk if every
  /// write succeeded, else kError if one failed, else kWouldBlock.
  IoStatus write(std::span<const double> torques, std::int64_t now_ns) noexcept;
  /// Device::write(): write(command.torques, now_ns); the output of sent_torques().
  const DeviceOutput& write(const DeviceCommand& command, std::int64_t now_ns) noexcept override;
  /// Device::ramp_feedback_again(): the soft start begins again at the next open write
  /// (restart_soft_start()).
  void ramp_feedback_again() noexcept override { restart_soft_start(); }

  /// The controller-side instrument driver (sample, kinematics, mapping τ = Σ J_lᵀ w_l).
  const InstrumentDevice& instrument() const noexcept { return *instrument_; }
  /// Same, mutable (InstrumentDevice::torques_for() updates its counters).
  InstrumentDevice& instrument() noexcept { return *instrument_; }
  /// The sample of the last read() (InstrumentDevice::last_sample()).
  const DeviceSample& sample() const noexcept { return instrument_->last_sample(); }
  /// The torques of the last write(), as sent.
  const SentTorques& sent_torques() const noexcept { return sent_; }
  /// Counters of write().
  const TorqueCounters& torque_counters() const noexcept { return torque_counters_; }
  /// The passivity controller write() runs (num_axes() == 0 when DeviceConfig::passivity is
  /// off): its energies E_i, dampers and counters.
  const PassivityController& passivity() const noexcept { return passivity_; }
  /// Device::conditioning(): torque_counters() and passivity().
  OutputConditioning conditioning() const noexcept override {
    return {&torque_counters_, &passivity_};
  }

 protected:
  /// Keeps references: `instrument` and `bus` must outlive the device.
  ImpedanceDevice(InstrumentDevice& instrument, Bus& bus);

  /// Whether `axis` (< n, with a drive) may get torque this period (the gate's per-protocol
  /// part; write() adds the sample and shutdown conditions).
  virtual bool torque_allowed(int axis) const noexcept = 0;
  /// write() found a non-finite torque on allowed axis `axis` (managed: latch the safe state).
  virtual void on_non_finite_torque(int axis) noexcept { (void)axis; }
  /// Writes the torque frames of sent_torques() at `now_ns`.
  virtual IoStatus send(const SentTorques& torques, std::int64_t now_ns) noexcept = 0;
  /// Torque is (re-)enabled: the soft start begins again at the next write whose gate is open
  /// (r = dt / T there). Managed stack: the lifecycle entered kActive. No effect with the soft
  /// start off.
  void restart_soft_start() noexcept {
    if (ramp_step_ > 0.0) ramp_writes_ = -1;
  }

  InstrumentDevice* instrument_;

 private:
  bool on_input_frame(const CanFrame& frame) noexcept override { return instrument_->on_frame(frame); }
  // The conditioning's sub-stages, in write()'s order, each applied once (the file comment):
  // the gate and the non-finite trip (returns the axes that passed, bit i; 0: every axis
  // gated), the passivity controller, the soft start's r, the clamp and × r.
  std::uint32_t gate(std::span<const double> torques) noexcept;
  void control_passivity(std::uint32_t open) noexcept;
  void advance_soft_start(bool open) noexcept;
  void clamp_and_ramp(bool open) noexcept;
  // The sample (InstrumentDevice::sample(): decoded and checked there, once) as the state.
  void end_read(std::int64_t now_ns, DeviceState& state) noexcept override;

  SentTorques sent_;
  TorqueCounters torque_counters_;
  PassivityController passivity_;
  // The passivity controller's port flow this period: DeviceSample::dq / T per axis.
  AxisVector passivity_rate_;
  // Soft start: dt / T (0: off) and the writes since the ramp began (-1: armed, waiting for an
  // open gate; counting stops once r reached 1).
  double ramp_step_ = 0.0;
  std::int64_t ramp_writes_ = -1;
};

/// The device `instrument.config()` asks for: ManagedDevice if canopen.managed, else
/// MinimalDevice, with `period_ns` the control period (> 0). `network`: the NMT master the
/// managed devices on `bus` share (ManagedDevice; the minimal protocol has no NMT and ignores
/// it); nullptr: the device alone on its bus. Throws std::invalid_argument for bad settings
/// (construction only).
std::unique_ptr<ImpedanceDevice> make_device(InstrumentDevice& instrument, Bus& bus,
                                             std::int64_t period_ns,
                                             const ImpedanceSettings& settings = {},
                                             NmtMaster* network = nullptr);

}  // namespace numen::hal
