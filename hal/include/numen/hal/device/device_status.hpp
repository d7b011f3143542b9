#pragma once
/// @file device_status.hpp
/// What a device's supervision says, as the code above hal reads it through the device face
/// (hal::Device; platform::ControlLoop, sim's run and summaries): the lifecycle states, the
/// start-up phases, the fault causes and their records, the supervision settings a device is
/// built with (LifecycleSettings, SupervisionSettings, and the drives' Cia402MasterSettings of
/// canopen/cia402_settings.hpp, included here), and
/// one device's report (DeviceReport:
/// its protocol's figures — start-up, lifecycle, faults, EMCY, heartbeats, SDO reads — without
/// naming the protocol's classes). The managed CANopen stack (canopen_master.hpp,
/// device_lifecycle.hpp, safety_supervisor.hpp) produces these values; nothing above hal needs
/// its headers to read them.

#include <cstdint>
#include <string>
#include <vector>

#include "numen/hal/canopen/cia402_settings.hpp"

namespace numen::hal {

/// States of a DeviceLifecycle.
enum class LifecycleState : std::uint8_t {
  kUnconfigured,  ///< Not configured: nothing is read or supervised, zero torque.
  kInactive,      ///< Configured: inputs are read and supervised, zero torque, drives disabled.
  kActive,        ///< Torque commands allowed (the only such state), drives enabled.
  kSafeStop,      ///< A fault was detected: zero torque, drives being disabled (CiA 402).
  kFault,         ///< Latched safe state: zero torque, drives disabled (or timed out); only
                  ///< rearm() leaves it.
};

/// Short English name of a LifecycleState (static string), e.g. "safe stop".
const char* to_string(LifecycleState state) noexcept;

/// Outcome of a lifecycle transition request.
enum class LifecycleResult : std::uint8_t {
  kOk,                  ///< The transition was made.
  kNotUnconfigured,     ///< configure() outside kUnconfigured.
  kNotInactive,         ///< activate() or cleanup() outside kInactive.
  kNotActive,           ///< deactivate() outside kActive.
  kFaultLatched,        ///< configure/activate/deactivate/cleanup while kSafeStop or kFault:
                        ///< only rearm() leaves the safe state.
  kSafeStopInProgress,  ///< rearm() while kSafeStop: the drives have not yet been disabled.
  kNotFaulted,          ///< rearm() outside kSafeStop / kFault: there is nothing to re-arm.
  kCausePresent,        ///< activate() or rearm() while a fault condition is present (the
                        ///< supervisor's last verdict; SafetySupervisor::blocking() says which).
};

/// Short English reason for a LifecycleResult (static string), e.g. "a fault cause is still
/// present".
const char* to_string(LifecycleResult result) noexcept;

/// Phases of the NMT start-up.
enum class StartupPhase : std::uint8_t {
  kResetCommunication,  ///< Reset communication (all nodes) is sent at the next begin_period().
  kWaitBootUp,          ///< Waiting for every node's boot-up message.
  kStartNodes,          ///< Start remote node (all nodes) is sent at the next begin_period().
  kWaitOperational,     ///< Waiting for every node's heartbeat to report operational.
  kOperational,         ///< Every node was heard operational: the start-up is complete.
  kFailed,              ///< startup_timeout_ms passed first, or a node's configuration failed
                        ///< (StartupReport says which node).
  kConfigure,           ///< Every node booted; the nodes with a DCF are being configured over
                        ///< SDO (pre-operational), then kStartNodes. (Last in the enum only to
                        ///< keep the other values, which state frames carry, unchanged.)
};

/// Short English name of a StartupPhase (static string), e.g. "wait boot-up".
const char* to_string(StartupPhase phase) noexcept;

/// Why the safe state latched (or would latch).
enum class FaultCause : std::uint8_t {
  kNone,             ///< No fault.
  kBadInput,         ///< SafetyInputs spans do not match the configuration (fewer axis
                     ///< entries than axes, more drives than kMaxSupervisedDrives).
  kBusOff,           ///< The CAN controller is bus off (ISO 11898-1 §12).
  kIoError,          ///< A Bus read or write returned IoStatus::kError this period.
  kHeartbeatLost,    ///< A heartbeat consumer lost its node (CiA 301 §7.2.8.3.2.2).
  kNodeReset,        ///< A node sent a boot-up message after it had been heard (it reset).
  kEmcy,             ///< An EMCY message reporting a fault (CiA 301 §7.2.7).
  kDriveFault,       ///< A CiA 402 drive in fault reaction active / fault (Cia402Master).
  kDriveStuck,       ///< A CiA 402 drive did not make the awaited transition in time.
  kDriveEnergized,   ///< Readiness only: a drive is not in a disabled state while it should be.
  kOverruns,         ///< overrun_limit consecutive control periods overran.
  kEncoderTimeout,   ///< No accepted encoder frame on an axis for encoder_timeout_periods.
  kEncoderJump,      ///< An encoder value moved faster than the axis's max speed allows.
  kOutOfRange,       ///< An encoder value outside the axis's [min, max].
  kNonFinite,        ///< An encoder value that is NaN or infinite.
  kNonFiniteTorque,  ///< A NaN or infinite axis torque reached the gate (ImpedanceDevice::write(),
                     ///< trip_non_finite_torque()).
  kSafeStopTimeout,  ///< The drives did not report disabled within safe_stop_timeout_periods.
  kForceOutOfRange,  ///< Admittance: a force/torque reading outside the sensor's range
                     ///< (AdmittanceDevice; SampleFault::kOutOfRange).
  kForceTimeout,     ///< Admittance: no valid force reading for force_timeout_periods.
  kPeerFault,        ///< Another device of the same control loop is in its safe state
                     ///< (platform::ControlLoop with several devices; docs/safety.md
                     ///< "Several devices"): id = that device's index in the loop.
};

/// The last FaultCause (the values run from kNone = 0 to it): a new cause goes before this
/// line and becomes it. Readers that list every cause (the view's frame layout) stop here.
inline constexpr FaultCause kLastFaultCause = FaultCause::kPeerFault;

/// Short English name of a FaultCause (static string), e.g. "encoder timeout".
const char* to_string(FaultCause cause) noexcept;

/// One recorded fault. `id` and `value` depend on the cause:
///
/// | cause | id | value |
/// | --- | --- | --- |
/// | kEncoderTimeout | axis | periods without an accepted frame |
/// | kEncoderJump, kOutOfRange, kNonFinite | axis | the axis's FaultMask this period |
/// | kHeartbeatLost, kNodeReset | node id | s from the node's last message to its fault |
/// | kEmcy | node id | emergency error code (0 if no EMCY record was given) |
/// | kDriveFault, kDriveStuck, kDriveEnergized | drive index | PowerState as a number |
/// | kOverruns | 0 | consecutive overrun periods |
/// | kBusOff | 0 | BusState as a number |
/// | kIoError, kNonFiniteTorque | 0 / axis | 0 |
/// | kSafeStopTimeout | first drive not disabled | periods waited |
/// | kForceOutOfRange | 0 | the reading's FaultMask |
/// | kForceTimeout | 0 | periods without a valid reading |
/// | kPeerFault | the peer's index in the control loop | 0 |
/// | kBadInput | 0 | 0 |
struct FaultRecord {
  FaultCause cause = FaultCause::kNone;  ///< What.
  std::uint8_t id = 0;                   ///< Axis index, node id or drive index (table above).
  double value = 0.0;                    ///< Cause-specific value (table above).
  std::int64_t time_ns = 0;              ///< `now_ns` of the period it was detected in, ns.
  std::uint64_t period = 0;              ///< That period's index (0 = first update()).
  bool latched = false;                  ///< This record moved the device into kSafeStop.
};

/// Creation settings of a DeviceLifecycle.
struct LifecycleSettings {
  /// Periods, >= 1, that kSafeStop waits for every drive to report a disabled state before it
  /// gives up and latches kFault anyway (recorded as a timeout). 100 = 0.1 s at 1 kHz.
  std::uint32_t safe_stop_timeout_periods = 100;
};

/// The watchdog settings of an impedance device's supervision, defined once: a
/// SafetySupervisor's (SafetySettings) and an impedance device's (ImpedanceSettings) are this
/// struct and add their own, so a setting is not copied field by field on its way down. The
/// lifecycle's (LifecycleSettings::safe_stop_timeout_periods, >= 1: periods kSafeStop waits for
/// the drives to report disabled before it latches kFault anyway) is its base.
struct SupervisionSettings : LifecycleSettings {
  /// Periods, >= 1, without an accepted encoder frame after which an axis's encoder has timed
  /// out (the N-th period without one latches). Fewer only reject the sample.
  std::uint32_t encoder_timeout_periods = 3;
  /// Consecutive overrun periods, >= 1, that latch (an overrun followed by a period on time
  /// restarts the count).
  std::uint32_t overrun_limit = 3;
};

/// The NMT start-up's figures (the base of CanopenMaster's StartupReport; a DeviceReport's).
struct StartupStatus {
  StartupPhase phase = StartupPhase::kResetCommunication;  ///< Current phase.
  std::uint64_t done_period = 0;  ///< update() index at which kOperational / kFailed was reached.
  std::uint8_t missing_node = 0;  ///< kFailed: the first node not booted / not operational /
                                  ///< not configured.
  bool configuration_failed = false;  ///< kFailed by a node's configuration (configuration_error()).
  std::uint32_t attempts = 0;     ///< Start-ups begun (1 after the first).
};

/// One device's protocol and supervision figures (Device::report()), for the run's summary and
/// trace. The minimal protocol reports `managed` false and the defaults. Counters count since
/// construction.
struct DeviceReport {
  /// The managed CANopen stack (NMT start-up, heartbeats, EMCY, CiA 402 drives, supervision).
  bool managed = false;
  /// The NMT start-up: its phase now, the period it completed (or failed) in, the first node
  /// missing when it failed, whether a node's configuration failed it, the start-ups begun.
  StartupStatus startup;
  /// The lifecycle now (kUnconfigured without a lifecycle).
  LifecycleState lifecycle = LifecycleState::kUnconfigured;
  std::uint64_t latches = 0;        ///< Safe stops entered.
  std::uint64_t fault_records = 0;  ///< Fault records written (latching or not).
  std::uint64_t emcys = 0;          ///< EMCY messages received.
  std::uint64_t emcy_faults = 0;    ///< Of them, reporting a fault (error code not 0x0000).
  bool has_emcy = false;            ///< An EMCY was received: the newest's node and code follow.
  std::uint8_t newest_emcy_node = 0;   ///< Node id of the newest EMCY.
  std::uint16_t newest_emcy_code = 0;  ///< Its emergency error code (CiA 301 §7.2.7).
  std::uint64_t configured_nodes = 0;  ///< Node configurations completed (SDO, from a DCF).
  bool sdo_polled = false;             ///< In-loop SDO reads are configured: the next two count.
  std::uint64_t sdo_reads = 0;         ///< In-loop SDO reads completed.
  std::uint64_t sdo_read_errors = 0;   ///< In-loop SDO reads aborted or timed out.
  std::uint64_t heartbeat_losses = 0;  ///< Heartbeat losses, summed over the nodes.
  std::uint64_t malformed_drive_frames = 0;  ///< Frames on a drive TPDO COB-ID its mapping refused.
};

/// A device's protocol notes in words, for the run's summary (Device::notes(); allocates, never
/// in a period). Empty for the minimal protocol.
struct DeviceNotes {
  /// The failed node configuration's error (empty if none).
  std::string configuration_error;
  /// Each held EMCY record: "node N at T s: 0xCODE description (register 0xRR)", a drive node's
  /// code described by the CiA 402 table, another's by CiA 301's.
  std::vector<std::string> emcy_messages;
  /// Each drive: "axis name: CiA 402 power state".
  std::vector<std::string> drive_states;
};

}  // namespace numen::hal
