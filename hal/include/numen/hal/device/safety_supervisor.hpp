#pragma once
/// @file safety_supervisor.hpp
/// SafetySupervisor: the watchdogs and plausibility checks of one device, the fault log, and
/// the DeviceLifecycle they drive (whose torque_allowed() is the lifecycle part of the torque
/// gate in hal::ImpedanceDevice::write(), the one place that gates and clamps axis torques). Once per control period it is given
/// what the period's reads found (encoder freshness and sample checks, heartbeat consumers,
/// EMCY count, CiA 402 drive states, loop overrun, bus state) and decides whether the safe
/// state latches. The rules (see docs/safety.md):
///
///  - Latching causes (FaultCause): each moves kInactive / kActive to kSafeStop in the period
///    it is detected, is recorded with what, which axis / node / drive, a value, the time and
///    the period, and is recorded again only after it has cleared (rising edges; counts are
///    events). Encoder timeout: an axis without an accepted frame for encoder_timeout_periods
///    periods (exactly N, not N − 1). Encoder jump, out of range, non-finite: the sample check
///    rejected the axis's frame for that reason (sample_check.hpp). Heartbeat lost / node reset:
///    the consumer's loss / unexpected boot-up counters grew. EMCY: the EMCY log's fault count
///    grew. Drive fault / drive stuck: the Cia402Master reports them. Overruns: overrun_limit
///    consecutive overrun periods. Bus off, I/O error, non-finite torque, bad input.
///  - Reject-only conditions: a stale or malformed encoder frame (kStale, kMalformed) below the
///    N-period timeout only rejects the sample (the InstrumentDevice holds the last accepted
///    value); an isolated overrun only counts. Counted in counters().
///  - Safe state sequence: period k detects → torque_allowed() is false from the same period
///    (commanded_torque_zero(); ImpedanceDevice::write() sends zeros) and drive_target() is
///    kDisabled (the caller requests it from its Cia402Master, whose next update sends disable
///    voltage) → kFault once every drive reports disabled, or after safe_stop_timeout_periods
///    (recorded as kSafeStopTimeout). Only rearm() leaves kFault, to kInactive, and only when
///    no cause is present (blocking() says which one is); activate() is needed again.
///
/// Construction may allocate and throw (setup); every other member is
/// noexcept, allocation free, lock free and bounded.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/canopen/cia402.hpp"
#include "numen/hal/device/device_lifecycle.hpp"
#include "numen/hal/canopen/emcy.hpp"
#include "numen/hal/canopen/heartbeat.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/device/sample_check.hpp"

#include "numen/hal/device/device_status.hpp"

namespace numen::hal {


/// Most drives one SafetySupervisor watches.
inline constexpr std::size_t kMaxSupervisedDrives = 16;
/// Capacity of the fault log (records; the oldest is overwritten).
inline constexpr std::size_t kFaultLogCapacity = 64;

/// Creation settings of a SafetySupervisor: the supervision settings and the device's axes.
struct SafetySettings : SupervisionSettings {
  /// Number of axes n of the device, 1..kMaxAxes (SafetyInputs carry n axis entries).
  std::size_t num_axes = 0;
};

/// What one period's reads found (SafetySupervisor::update() input). Spans refer to the
/// caller's data and are read during update() only.
struct SafetyInputs {
  /// Per axis (n entries): periods since the axis last had an accepted encoder frame
  /// (DeviceSample::periods_since_accepted; 0 = accepted this period).
  std::span<const std::uint32_t> periods_since_accepted;
  /// Per axis (n entries): the sample check's FaultMask this period (DeviceSample::
  /// axis_faults). kNoData marks an axis that has never had an accepted value.
  std::span<const FaultMask> axis_faults;
  /// The heartbeat consumers of the device's nodes (HeartbeatMonitor::consumers()).
  std::span<const HeartbeatConsumer> heartbeats;
  /// EMCY messages reporting a fault so far (EmcyLogCounters::faults; a count, compared with
  /// the last value acted on).
  std::uint64_t emcy_faults = 0;
  /// The newest EMCY fault, for the record (newest_emcy_fault()); may be null.
  const EmcyRecord* emcy_last_fault = nullptr;
  /// This period's Cia402Master::update() output of each drive (at most kMaxSupervisedDrives).
  std::span<const Cia402MasterOutput> drives;
  /// The previous control period overran its deadline.
  bool overrun = false;
  /// The bus controller's state (Bus::state()).
  BusState bus_state = BusState::kOk;
  /// A Bus read or write returned IoStatus::kError since the last update (recorded once per
  /// run of periods with an error).
  bool io_error = false;
};

/// Event counters of a SafetySupervisor since construction.
struct SafetyCounters {
  std::uint64_t updates = 0;              ///< update() calls.
  std::uint64_t records = 0;              ///< Fault records written.
  std::uint64_t records_overwritten = 0;  ///< Records pushed out of the full log.
  std::uint64_t latches = 0;              ///< Safe stops entered.
  std::uint64_t overruns = 0;             ///< Overrun periods (consecutive or not).
  std::uint64_t rejected_samples = 0;     ///< Axis-periods rejected as stale or malformed
                                          ///< without a latching cause (below the timeout).
  std::uint64_t non_finite_torques = 0;   ///< trip_non_finite_torque() calls.
};

/// The watchdogs and plausibility checks of one device, driving its DeviceLifecycle (see the
/// file comment for the rules). One period:
///
///   frames → InstrumentDevice::sample(), HeartbeatMonitor::poll(), Cia402Master::update()
///   → supervisor.update(now, inputs)
///   → for each drive: master.request(supervisor.drive_target())
///   → compute torques; ImpedanceDevice::write(tau): zeros unless torque_allowed() (and the drive's
///     master allows torque), each clamped to ±max_torque; a NaN trips
///     trip_non_finite_torque()
///   → sent in this period.
///
/// Not thread safe: one control loop owns it.
class SafetySupervisor {
 public:
  /// Validates `settings`: throws std::invalid_argument naming the field and value if a
  /// period count is 0 or num_axes is outside 1..kMaxAxes.
  explicit SafetySupervisor(const SafetySettings& settings);

  /// Lifecycle transitions (DeviceLifecycle). activate() and rearm() refuse with
  /// kCausePresent while the last update() found a cause present (blocking() says which).
  /// Events (heartbeat, EMCY counts) seen by update() while unconfigured are absorbed, not
  /// acted on. rearm() clears first_fault(); the fault log is kept.
  /// kUnconfigured → kInactive.
  LifecycleResult configure() noexcept { return lifecycle_.configure(); }
  /// kInactive → kActive (see configure()).
  LifecycleResult activate() noexcept { return lifecycle_.activate(); }
  /// kActive → kInactive (see configure()).
  LifecycleResult deactivate() noexcept { return lifecycle_.deactivate(); }
  /// kInactive → kUnconfigured (see configure()).
  LifecycleResult cleanup() noexcept { return lifecycle_.cleanup(); }
  /// kFault → kInactive if no cause is present (see configure()).
  LifecycleResult rearm() noexcept;

  /// One control period at `now_ns` (bus clock, ns): detects the latching causes in the fixed
  /// order of FaultCause (bad input, bus off, I/O error, heartbeats in consumer order, EMCY,
  /// drives in order, overruns, then per axis non-finite, out of range, jump, timeout),
  /// records each, determines whether a cause is still present and whether every drive is
  /// disabled, and updates the lifecycle. In kUnconfigured only the event baselines move.
  LifecycleUpdate update(std::int64_t now_ns, const SafetyInputs& inputs) noexcept;

  /// A NaN or infinite torque reached the torque gate on `axis` (ImpedanceDevice::write(), which sends
  /// zeros): records kNonFiniteTorque (id = axis) and latches the safe state at once.
  void trip_non_finite_torque(std::size_t axis) noexcept;

  /// Latches the safe state at once for a cause found outside this supervisor's inputs
  /// (kNonFiniteTorque from the gate, kPeerFault from the control loop): records `cause` with
  /// `id` and `value` (the table above) as the latching record; the lifecycle leaves kActive
  /// (or kInactive) for kSafeStop. Counts a latch if it entered the safe state.
  void trip(FaultCause cause, std::uint8_t id, double value) noexcept;

  /// True only in kActive: torques may be sent (still gate each drive with its
  /// Cia402MasterOutput::torque_allowed). False: the caller must command zero this period.
  bool torque_allowed() const noexcept { return lifecycle_.torque_allowed(); }
  /// !torque_allowed(): zero torque must be commanded in this period.
  bool commanded_torque_zero() const noexcept { return !lifecycle_.torque_allowed(); }
  /// The CiA 402 target the caller must request from every Cia402Master after update():
  /// kEnabled only in kActive, else kDisabled.
  Cia402Target drive_target() const noexcept { return lifecycle_.drive_target(); }
  /// The lifecycle state.
  LifecycleState state() const noexcept { return lifecycle_.state(); }
  /// The lifecycle.
  const DeviceLifecycle& lifecycle() const noexcept { return lifecycle_; }

  /// The record that latched the current (or last, until rearm()) safe state; nullptr if none.
  const FaultRecord* first_fault() const noexcept { return has_first_ ? &first_ : nullptr; }
  /// The first cause present at the last update() (what activate() / rearm() wait for); cause
  /// kNone if none. Event-only causes (EMCY, I/O error, non-finite torque, node reset once the
  /// node is heard again) are never present: their consequences show in the other inputs.
  const FaultRecord& blocking() const noexcept { return blocking_; }
  /// Records held, <= kFaultLogCapacity.
  std::size_t fault_log_size() const noexcept { return log_size_; }
  /// Record `i`, oldest held (0) to newest (size − 1); nullptr if i >= size.
  const FaultRecord* fault_log_at(std::size_t i) const noexcept;
  /// The newest record, or nullptr.
  const FaultRecord* newest_fault() const noexcept {
    return log_size_ == 0 ? nullptr : fault_log_at(log_size_ - 1);
  }
  /// Consecutive overrun periods up to the last update().
  std::uint32_t consecutive_overruns() const noexcept { return consecutive_overruns_; }
  /// Index of the last update() (0 = first; 0 before any).
  std::uint64_t period() const noexcept { return period_; }
  /// Number of axes n.
  std::size_t num_axes() const noexcept { return n_; }
  /// Counters.
  const SafetyCounters& counters() const noexcept { return counters_; }
  /// The settings.
  const SafetySettings& settings() const noexcept { return settings_; }

 private:
  // Appends a record stamped with the current period; latches first_ if it latches.
  void record(FaultCause cause, std::uint8_t id, double value, bool latching) noexcept;
  // The first cause present at `inputs`, or kNone.
  FaultRecord find_present(const SafetyInputs& inputs, bool drives_disabled) const noexcept;

  SafetySettings settings_;
  DeviceLifecycle lifecycle_;
  std::size_t n_ = 0;

  // Edge memory (a cause is recorded again only after it cleared).
  std::array<FaultMask, kMaxAxes> prev_mask_{};
  std::array<bool, kMaxAxes> timeout_active_{};
  std::array<bool, kMaxSupervisedDrives> drive_fault_prev_{};
  std::array<bool, kMaxSupervisedDrives> drive_stuck_prev_{};
  std::array<std::uint64_t, kMaxNodeId + 1> hb_losses_seen_{};
  std::array<std::uint64_t, kMaxNodeId + 1> hb_boot_ups_seen_{};
  std::uint64_t emcy_seen_ = 0;
  bool bus_off_prev_ = false;
  bool io_error_prev_ = false;
  bool bad_input_prev_ = false;
  std::uint32_t consecutive_overruns_ = 0;

  std::uint64_t period_ = 0;
  std::int64_t now_ns_ = 0;
  bool latch_this_period_ = false;  // a latching record was written in this update

  std::array<FaultRecord, kFaultLogCapacity> log_{};
  std::size_t log_head_ = 0;  // where the next record goes
  std::size_t log_size_ = 0;
  FaultRecord first_;
  bool has_first_ = false;
  FaultRecord blocking_;
  SafetyCounters counters_;
};

/// The newest record of `log` that reports a fault (emcy_reports_fault), or nullptr. Walks at
/// most K records; noexcept, allocation free. For SafetyInputs::emcy_last_fault.
template <std::size_t K>
const EmcyRecord* newest_emcy_fault(const EmcyLog<K>& log) noexcept {
  for (std::size_t i = log.size(); i > 0; --i) {
    const EmcyRecord* r = log.at(i - 1);
    if (r != nullptr && emcy_reports_fault(r->message)) return r;
  }
  return nullptr;
}

}  // namespace numen::hal
