#pragma once
/// @file period_stages.hpp
/// The stages of a control period as free functions over one device's PeriodContext (what is
/// fixed when the loop is built: Model, Data, the device, its binding, the Stepper, the
/// settings; and the tallies kept across periods) and its PeriodData (period_data.hpp), in
/// the manner of core::step's stages (step_stages.hpp). ControlLoop::end_period() runs one of
/// two fixed lists, chosen at construction by the kind of device:
///
///   impedance:  read → supervise → bind_link_targets → step → map_link_wrenches → send → finish
///   admittance: read → supervise → bind_measured_wrench → step → map_held_pose → send → finish
///
/// so that no period branches on the kind of device. A loop with several devices runs each
/// stage over every device in turn (stage by stage: every device's read, then every device's
/// supervision, ...), each over its own context and record; the loop's shared work — the one
/// step, Stepper::finish() and LoopStatistics — is device 0's, and the other devices' step and
/// finish stages take its figures from its record. The send stage applies the fault policy
/// between devices (docs/safety.md "Several devices"). The torques' conditioning (gate,
/// passivity controller, clamp, soft start) is the send stage's, inside the device's write()
/// (hal::ImpedanceDevice::write(), once; docs/safety.md). Every stage is noexcept, allocation
/// free, lock free and never blocks; each writes only the PeriodData fields whose writer it is
/// (period_data_fields(); tests/platform/period_stages_test.cpp).

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/device/device.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/platform/device_binding.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/loop_statistics.hpp"
#include "numen/platform/period_data.hpp"
#include "numen/platform/stepper.hpp"

namespace numen::platform {

/// Counters since construction.
struct ControlLoopCounters {
  std::uint64_t periods = 0;              ///< end_period() calls.
  std::uint64_t sync_write_failures = 0;  ///< SYNC writes not accepted by the bus.
  std::uint64_t command_failures = 0;     ///< Periods whose writes did not all succeed.
  std::uint64_t periods_zero_torque = 0;  ///< Periods that sent zero torque on every drive (no
                                          ///< body held, no valid sample, gated, or a zero τ).
  std::uint64_t read_errors = 0;          ///< Bus reads that returned kError.
  /// Periods whose bound bodies' feedback had a NaN / inf wrench (mapped all the same: the
  /// device's write() trips on the non-finite τ, FaultCause::kNonFiniteTorque).
  std::uint64_t non_finite_wrenches = 0;
};

/// What a device's returns from stale samples did (ControlLoopSettings::rejoin_after_stale).
struct RejoinTally {
  std::uint64_t rejoins = 0;       ///< Valid samples that came after stale ones.
  std::int64_t last_period = -1;   ///< Period of the last of them (-1: none).
  double gap_max_m = 0.0;          ///< Largest distance from a held target to the resumed one, m.
  double gap_max_rad = 0.0;        ///< Largest angle between them, rad.
};

/// Most devices one ControlLoop runs (its constructor refuses more): the contexts and records
/// are fixed arrays of this size in the loop, nothing is allocated per device in a period.
inline constexpr int kMaxLoopDevices = 4;

/// What one device's period stages read besides PeriodData (fixed at construction) and the
/// tallies they keep across periods. Owned by the ControlLoop, one per device.
struct PeriodContext {
  const core::Model* model = nullptr;  ///< The model (never written).
  core::Data* data = nullptr;          ///< The Data the device drives.
  hal::Device* device = nullptr;       ///< The device, of either kind.
  Stepper* stepper = nullptr;          ///< The step (core::step unless ControlLoop::set_stepper()).
  /// Feed LoopStatistics' overrun verdict of the previous period to the supervision.
  bool supervise_overruns = false;
  DeviceBinding binding;                      ///< Which bodies the links drive (impedance).
  std::vector<std::uint8_t> explicit_bound;   ///< Per body: 1 if a binding names it.
  // Tallies across periods.
  ControlLoopCounters counters;            ///< Counters since construction.
  LatencyHistogram step_time;              ///< Wall time of the step per period (ns).
  LoopStatistics* stats = nullptr;         ///< The period's timing statistics.
  std::int64_t first_active_period = -1;   ///< Period the lifecycle first became active.
  std::int64_t first_torque_period = -1;   ///< Period non-zero torque was first commanded.
  /// The bound bodies are to be brought to the first ready sample's targets
  /// (ControlLoopSettings::place_at_first_sample); cleared by bind_link_targets() when done.
  bool place_pending = false;
  std::int64_t placed_period = -1;  ///< Period they were brought there; -1 if not.
  /// Glide the targets to the resumed samples after stale ones and ramp the feedback again
  /// (ControlLoopSettings::rejoin_after_stale).
  bool rejoin_after_stale = false;
  int rejoin_steps = 0;      ///< Periods of the glide (the device's soft start; 0: none).
  bool stale_seen = false;   ///< A stale sample came since the last valid one.
  int rejoin_k = -1;         ///< Periods into the glide under way (-1: none).
  std::array<core::Pose, kMaxLinkBindings> rejoin_from{};  ///< The held targets it leaves.
  std::array<double, hal::kMaxAxes> rejoin_from_q{};       ///< The held prescribed values.
  RejoinTally rejoin;        ///< What the returns did.
  /// This device's index in the loop, in [0, records.size()). Device 0 does the loop's shared
  /// work (the step, Stepper::finish(), LoopStatistics) for all.
  int index = 0;
  /// Every device's record of the loop, [number of devices] (this device's is records[index]):
  /// device 0's step and statistics figures, the peers' supervision for the fault policy.
  std::span<const PeriodData> records;
};

/// One stage: runs over `context` and `period` at bus time `now_ns`.
using PeriodStageFunction = void (*)(PeriodContext& context, PeriodData& period,
                                     std::int64_t now_ns) noexcept;

/// One entry of a period's stage list.
struct PeriodStageEntry {
  PeriodStage stage;          ///< Which stage (its bit).
  const char* name;           ///< The function's name.
  PeriodStageFunction run;    ///< The function.
};

/// Sees a period stage by stage (ControlLoop::end_period()'s `observer`: tests, tracing).
class PeriodObserver {
 public:
  virtual ~PeriodObserver() = default;
  /// After `stage` ran, with the record as it left it. Runs in the real-time period: must not
  /// allocate, throw, lock or block.
  virtual void after_stage(const PeriodStageEntry& stage, const PeriodData& period) noexcept = 0;

 protected:
  PeriodObserver() = default;
  PeriodObserver(const PeriodObserver&) = default;
  PeriodObserver& operator=(const PeriodObserver&) = default;
};

/// begin: the deadline and wake-up stamps (`deadline_mono_ns`, `woke_mono_ns`; < 0: now), the
/// device's period start (SYNC and the protocol's frames; hal::Device::begin_period()).
void begin_device_period(PeriodContext& context, PeriodData& period, std::int64_t now_ns,
                         std::int64_t deadline_mono_ns, std::int64_t woke_mono_ns) noexcept;
/// read: hal::Device::read() — the period's DeviceState and the report's input fields.
void read_device(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// supervise: hal::Device::supervise() with the previous period's overrun verdict.
void supervise_device(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// bind (impedance): while the state is ready (a rejected sample keeps the last good target),
/// each bound body's target — link pose · body_in_link, the link's twist carried to the body's
/// origin (Data::target of the held body, Data::body_targets of the others; paper Eq. 6) —
/// and the prescribed joints' values; after stale samples, glided from the held ones
/// (ControlLoopSettings::rejoin_after_stale).
void bind_link_targets(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// bind (admittance): in kActive with a body held, the state's measured wrench carried to the
/// held body's COM into Data::device_wrench; otherwise a brake that halves the held body's
/// twist each step.
void bind_measured_wrench(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// step: Stepper::step() over (Model, Data), timed — once a period, by device 0; device i > 0
/// takes device 0's step stamps into its record.
void step_dynamics(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// map (impedance): w_l = the bound bodies' Eq. 8 wrenches carried to their link's origin
/// (Eq. 9, once), τ = Σ_l J_lᵀ w_l with the state's Jacobians, and their sum about link 0's
/// origin; computes, never gates.
void map_link_wrenches(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// map (admittance): the held body's pose (none held: no pose, the set-points are held).
void map_held_pose(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// send: first the fault policy between the loop's devices (docs/safety.md "Several
/// devices"): while another device is in its safe state (kSafeStop or kFault after this
/// period's supervision), this device, if active, latches its own now
/// (hal::Device::latch_safe_state(), FaultCause::kPeerFault, id = the peer's index), and is
/// held out of an automatic activation (hal::Device::hold_activation()); then
/// hal::Device::write() — gated, conditioned and sent there, once; the report's feedback from
/// what it applied (gated: 0; else × the soft start's r).
void send_command(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;
/// finish: Stepper::finish() (outside the timed step), the lifecycle and fault cause after the
/// write, the counters, LoopStatistics' verdict. Device 0 finishes the step and records the
/// loop's period (from its deadline to the last device's writes; loop_period_times()); the
/// others take its overrun verdict.
void finish_period(PeriodContext& context, PeriodData& period, std::int64_t now_ns) noexcept;

/// The stamps of one loop period over the records of all its devices, [N]: the deadline,
/// wake-up, input and output starts of the first device; the SYNC, input and output ends of
/// the last; the step's (device 0's). For one device: its record's times().
PeriodTimes loop_period_times(std::span<const PeriodData> records) noexcept;

/// The impedance device's stage list (see the file comment).
std::span<const PeriodStageEntry> impedance_period_stages() noexcept;
/// The admittance device's stage list (see the file comment).
std::span<const PeriodStageEntry> admittance_period_stages() noexcept;

}  // namespace numen::platform
