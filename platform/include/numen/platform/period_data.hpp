#pragma once
/// @file period_data.hpp
/// platform::PeriodData: the record of one control period — every value a period computes,
/// each written by one stage — in the manner of MuJoCo's mjData (mjdata.h: each field's shape,
/// units and the stage that writes it). ControlLoop::end_period() runs its fixed stage list
/// over it (period_stages.hpp); the report (PeriodReport) and the trace read it, and nothing
/// recomputes a figure a stage computed. period_data_fields() is the writer table the tests
/// check every stage against (tests/platform/period_stages_test.cpp).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "numen/core/types.hpp"
#include "numen/hal/device/device.hpp"
#include "numen/hal/device/device_state.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/platform/loop_statistics.hpp"

namespace numen::platform {

/// The stages of a control period, in the order end_period() runs them (one bit each).
enum class PeriodStage : std::uint16_t {
  kNone = 0,
  kBegin = 1u << 0,      ///< begin_period(): the deadline and wake-up stamps, the SYNC.
  kRead = 1u << 1,       ///< hal::Device::read(): the period's DeviceState.
  kSupervise = 1u << 2,  ///< hal::Device::supervise(): watchdogs and lifecycle.
  kBind = 1u << 3,       ///< The device's state → core::Data's inputs (targets or wrench).
  kStep = 1u << 4,       ///< The Stepper (core::step): the held bodies' Eq. 8 feedback.
  kMap = 1u << 5,        ///< core::Data's feedback → the DeviceCommand (τ, or the pose).
  kSend = 1u << 6,       ///< hal::Device::write(): conditioned and sent, once.
  kFinish = 1u << 7,     ///< Stepper::finish() and the period's verdicts (lifecycle, counters,
                         ///< LoopStatistics).
};

/// Short name of a stage ("read", "map", ...; "none" for kNone).
const char* to_string(PeriodStage stage) noexcept;

/// Most link bindings one device may have (DeviceBinding::links; the constructor refuses more).
inline constexpr int kMaxLinkBindings = 16;

/// What one period did (begin_period() + end_period()): the part of PeriodData the callers
/// read (ControlLoop::end_period() returns it). The *_ns stamps are CLOCK_MONOTONIC
/// (monotonic_now_ns()), in the order of PeriodTimes (loop_statistics.hpp). Writer: the stage
/// named at each field (period_data_fields()).
struct PeriodReport {
  int frames_read = 0;              ///< Frames taken from the bus this period. Writer: read.
  bool sample_valid = false;        ///< Every axis fresh and plausible this period. Writer: read.
  bool target_ready = false;        ///< The device has a target (possibly held). Writer: read.
  std::int64_t step_ns = 0;         ///< Wall time of the step (ns). Writer: step.
  hal::IoStatus command_status = hal::IoStatus::kOk;  ///< The writes' result. Writer: send.
  /// Non-zero torque was commanded on at least one drive this period. Writer: send.
  bool torque_commanded = false;
  /// The device wrench of this period, world, N and N·m. Admittance: the measured wrench that
  /// drove the held body, about its COM (zero when not driven). Impedance: the feedback wrench
  /// the drives were sent: the bound bodies' Eq. 8 wrenches carried to their links (Eq. 9)
  /// and summed about link 0's origin (PeriodData::wrench) times the soft-start factor
  /// (soft_start_ramp), zero when the device gated every axis. Per-axis clamping acts on τ
  /// (hal::SentTorques::clamped counts it), not on this. Computed once. Writer: send.
  core::Wrench feedback;
  /// Admittance: the measured wrench drove the held body this period (kActive, a body held).
  /// Writer: bind.
  bool driven = false;
  /// Admittance: the controlword sent with the set-points (CiA 402: enable operation or
  /// shutdown); 0 for an impedance device. Writer: send.
  std::uint16_t controlword = 0;
  /// The input's SampleFault bits this period (impedance: the union over the axes; admittance:
  /// the force reading's). Writer: read.
  hal::FaultMask sample_faults = 0;
  /// The soft-start factor r in [0, 1] the device applied this period (hal::SentTorques::ramp;
  /// 1 once the ramp is over, with the soft start off, or for an admittance device). Writer: send.
  double soft_start_ramp = 1.0;
  // Timestamps (CLOCK_MONOTONIC ns).
  std::int64_t deadline_ns = 0;      ///< The period's deadline (begin_period's argument, or
                                     ///< its start when none was given). Writer: begin.
  std::int64_t woke_ns = 0;          ///< When the thread resumed (idem). Writer: begin.
  std::int64_t sync_sent_ns = 0;     ///< SYNC (+ NMT, heartbeat) written. Writer: begin.
  std::int64_t input_begin_ns = 0;   ///< Reading the frames started. Writer: read.
  std::int64_t input_end_ns = 0;     ///< The frames were read. Writer: read.
  std::int64_t step_begin_ns = 0;    ///< The step started. Writer: step.
  std::int64_t step_end_ns = 0;      ///< The step returned. Writer: step.
  std::int64_t output_begin_ns = 0;  ///< The map and the writes started. Writer: map.
  std::int64_t output_end_ns = 0;    ///< The writes returned. Writer: send.
  bool overrun = false;              ///< LoopStatistics found this period overran. Writer: finish.
  // Managed stack (defaults in the minimal protocol).
  /// After this period. Writer: finish (after the write: a non-finite τ trips it).
  hal::LifecycleState lifecycle = hal::LifecycleState::kUnconfigured;
  /// After this period. Writer: supervise.
  hal::StartupPhase startup = hal::StartupPhase::kResetCommunication;
  /// The safe state latched in this period's supervision (first_fault() says why). Writer:
  /// supervise.
  bool entered_safe_stop = false;
  /// After this period: the cause of the latched safe state (hal::Device::first_fault(),
  /// cleared by a re-arm); kNone while none is latched. Writer: finish.
  hal::FaultCause fault_cause = hal::FaultCause::kNone;
  /// The lifecycle entered kActive in this period. Writer: supervise.
  bool activated = false;

  /// The stamps as LoopStatistics takes them.
  PeriodTimes times() const noexcept {
    return PeriodTimes{deadline_ns,    woke_ns,     sync_sent_ns,    input_begin_ns, input_end_ns,
                       step_begin_ns,  step_end_ns, output_begin_ns, output_end_ns,  0};
  }
};

/// The record of one control period of one device (ControlLoop::end_period()): the values the
/// stages hand each other and the report. It persists from period to period: a stage that
/// does not write a field this period leaves it as it was (an impedance device that is not
/// ready keeps its last bindings). Per binding entries [0, DeviceBinding::links.size()) and
/// per link entries [0, DeviceState::num_links) are meaningful. Writer: the one stage that
/// writes the field (period_data_fields()).
struct PeriodData {
  /// The device's state this period (hal-owned; valid until the next read). Writer: read.
  const hal::DeviceState* state = nullptr;
  /// What the supervision decided (lifecycle, start-up phase, safe state entered, activated).
  /// Writer: supervise.
  hal::DeviceSupervision supervision;
  /// m, world: the origin of binding k's link this period (impedance). Writer: bind.
  std::array<core::Vec3, kMaxLinkBindings> link_origin{};
  /// m, world: the target point of binding k's body, the point its Eq. 8 wrench is about
  /// (impedance). Writer: bind.
  std::array<core::Vec3, kMaxLinkBindings> body_point{};
  /// The body binding k drives this period, −1 for none (impedance). Writer: bind.
  std::array<int, kMaxLinkBindings> bound_body{};
  /// World, N and N·m about link l's origin: the Σ of the Eq. 8 wrenches of the bodies bound
  /// to link l (Eq. 9; impedance; 0 for a link without one). Writer: map.
  std::array<core::Wrench, hal::kMaxLinks> link_wrench{};
  /// N·m or N, n entries: τ = Σ_l J_lᵀ w_l with the state's Jacobians (impedance; computed,
  /// never gated). Writer: map.
  hal::AxisVector tau;
  /// World, N and N·m: the device wrench before the device conditions it — impedance: the link
  /// wrenches carried to link 0's origin and summed (Eq. 9), writer map; admittance: the
  /// measured wrench at the held body's COM when driven, else 0, writer bind.
  core::Wrench wrench;
  /// Admittance: the held body's pose the device is sent (world). Writer: map.
  core::Pose held_pose;
  /// What the device is sent (τ or the pose, pointing into this record). Writer: map.
  hal::DeviceCommand command;
  /// What the device sent (hal-owned; valid until the next write). Writer: send.
  const hal::DeviceOutput* output = nullptr;
  /// What the period did (the report; each field names its writer).
  PeriodReport report;
};

/// One field of PeriodData and the stage that writes it.
struct PeriodField {
  const char* name;      ///< The member's name.
  std::size_t offset;    ///< Its offset in PeriodData, bytes.
  std::size_t size;      ///< Its size, bytes.
  /// The stage that writes it (`wrench`: kBind | kMap, bind for an admittance device and map
  /// for an impedance one).
  std::uint16_t writers;
};

/// Every field of PeriodData with its writer, in declaration order (the table the comments
/// above document; tests check each stage writes only its own).
std::span<const PeriodField> period_data_fields() noexcept;

}  // namespace numen::platform
