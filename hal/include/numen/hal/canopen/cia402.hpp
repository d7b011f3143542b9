#pragma once
/// @file cia402.hpp
/// The CiA 402 power drive system finite state automaton (PDS FSA) as seen from both ends of
/// the bus: statusword (object 0x6041) decoding, controlword (object 0x6040) commands,
/// Cia402Master (numen's controller side: brings a drive up, gates the torque, handles quick
/// stop, faults and a stuck drive) and Cia402Drive (an emulated drive in cyclic synchronous
/// torque mode for the simulated instrument and the tests).
///
/// Source: CiA 402-2 / IEC 61800-7-201, "PDS FSA": statusword state coding (xxxx xxxx x0xx 0000
/// not ready to switch on, …), controlword command coding (shutdown 0 X 1 1 0 → transitions
/// 2, 6, 8, …) and the state transitions 0–16; quick stop option code 0x605A; modes of
/// operation 0x6060 (10 = cyclic synchronous torque, cst). See docs/protocol.md.
///
/// Pure protocol logic: no I/O, no clock. Every per-period call (decode_*, Cia402Master::update,
/// Cia402Drive::step / statusword) is noexcept, allocation free, lock free and bounded.

#include <cstdint>

#include "numen/hal/canopen/cia402_settings.hpp"

namespace numen::hal {

// ---------------------------------------------------------------------------------------------
// Statusword 0x6041
// ---------------------------------------------------------------------------------------------

/// Bits of the statusword (object 0x6041, UNSIGNED16; CiA 402-2 "Statusword").
struct StatuswordBit {
  static constexpr std::uint16_t kReadyToSwitchOn = 1u << 0;   ///< rtso, part of the state.
  static constexpr std::uint16_t kSwitchedOn = 1u << 1;        ///< so, part of the state.
  static constexpr std::uint16_t kOperationEnabled = 1u << 2;  ///< oe, part of the state.
  static constexpr std::uint16_t kFault = 1u << 3;             ///< f, part of the state.
  /// ve: high voltage is applied to the power stage. Not part of the state coding.
  static constexpr std::uint16_t kVoltageEnabled = 1u << 4;
  /// qs: 1 = quick stop NOT active (active low). Part of the state coding of ready to switch
  /// on, switched on, operation enabled (1) and quick stop active (0).
  static constexpr std::uint16_t kQuickStop = 1u << 5;
  static constexpr std::uint16_t kSwitchOnDisabled = 1u << 6;  ///< sod, part of the state.
  /// w: a warning condition (the drive keeps its state).
  static constexpr std::uint16_t kWarning = 1u << 7;
  /// rm: remote — the controlword is processed (0: local control, the controlword is ignored).
  static constexpr std::uint16_t kRemote = 1u << 9;
  /// tr: target reached (mode dependent; in numen's emulator: see Cia402Drive::statusword()).
  static constexpr std::uint16_t kTargetReached = 1u << 10;
  /// ila: internal limit active (e.g. the target torque was clipped at max torque 0x6072).
  static constexpr std::uint16_t kInternalLimitActive = 1u << 11;
  /// Cyclic synchronous modes (csp/csv/cst), bit 12: the drive follows the command value
  /// (for cst: the target torque 0x6071 is used as the torque demand).
  static constexpr std::uint16_t kDriveFollowsCommand = 1u << 12;
};

/// Mask of the statusword bits that code the states whose quick stop bit is don't-care
/// (not ready to switch on, switch on disabled, fault reaction active, fault): bits 0–3 and 6.
inline constexpr std::uint16_t kStateMaskWithoutQuickStop = 0x004F;
/// Mask of the statusword bits that code the states with a defined quick stop bit (ready to
/// switch on, switched on, operation enabled, quick stop active): bits 0–3, 5 and 6.
inline constexpr std::uint16_t kStateMaskWithQuickStop = 0x006F;

/// States of the PDS FSA (CiA 402-2), plus kUnknown for a statusword matching no state coding.
enum class PowerState : std::uint8_t {
  kNotReadyToSwitchOn,   ///< xxxx xxxx x0xx 0000 — initialising after power-up.
  kSwitchOnDisabled,     ///< xxxx xxxx x1xx 0000 — power stage off, initialised.
  kReadyToSwitchOn,      ///< xxxx xxxx x01x 0001 — waiting for switch on.
  kSwitchedOn,           ///< xxxx xxxx x01x 0011 — power stage may be energised, no torque.
  kOperationEnabled,     ///< xxxx xxxx x01x 0111 — the drive applies the target torque.
  kQuickStopActive,      ///< xxxx xxxx x00x 0111 — quick stop function being executed.
  kFaultReactionActive,  ///< xxxx xxxx x0xx 1111 — fault detected, fault reaction running.
  kFault,                ///< xxxx xxxx x0xx 1000 — fault, power stage off.
  kUnknown,              ///< None of the above (a corrupted or non-conforming statusword).
};

/// Short English name of a PowerState (static string).
const char* to_string(PowerState state) noexcept;

/// The PDS state coded in `statusword` by the standard table (masks 0x004F / 0x006F); bit 4
/// (voltage enabled), 7 and 8–15 are don't-care. A pattern in no row is kUnknown.
constexpr PowerState decode_power_state(std::uint16_t statusword) noexcept {
  switch (statusword & kStateMaskWithoutQuickStop) {
    case 0x0000:
      return PowerState::kNotReadyToSwitchOn;
    case 0x0040:
      return PowerState::kSwitchOnDisabled;
    case 0x000F:
      return PowerState::kFaultReactionActive;
    case 0x0008:
      return PowerState::kFault;
    default:
      break;
  }
  switch (statusword & kStateMaskWithQuickStop) {
    case 0x0021:
      return PowerState::kReadyToSwitchOn;
    case 0x0023:
      return PowerState::kSwitchedOn;
    case 0x0027:
      return PowerState::kOperationEnabled;
    case 0x0007:
      return PowerState::kQuickStopActive;
    default:
      return PowerState::kUnknown;
  }
}

/// The state bits (0–3, 5, 6) a drive reports for `state`, with the don't-care quick stop bit
/// of not ready / switch on disabled / fault reaction active / fault set to 0. kUnknown yields
/// 0x0041, a pattern no state coding matches.
constexpr std::uint16_t power_state_bits(PowerState state) noexcept {
  switch (state) {
    case PowerState::kNotReadyToSwitchOn:
      return 0x0000;
    case PowerState::kSwitchOnDisabled:
      return 0x0040;
    case PowerState::kReadyToSwitchOn:
      return 0x0021;
    case PowerState::kSwitchedOn:
      return 0x0023;
    case PowerState::kOperationEnabled:
      return 0x0027;
    case PowerState::kQuickStopActive:
      return 0x0007;
    case PowerState::kFaultReactionActive:
      return 0x000F;
    case PowerState::kFault:
      return 0x0008;
    case PowerState::kUnknown:
      break;
  }
  return 0x0041;
}

/// A statusword split into the state and the other bits numen uses.
struct Statusword {
  PowerState state = PowerState::kUnknown;  ///< decode_power_state().
  bool voltage_enabled = false;             ///< Bit 4.
  bool warning = false;                     ///< Bit 7.
  bool remote = false;                      ///< Bit 9.
  bool target_reached = false;              ///< Bit 10.
  bool internal_limit_active = false;       ///< Bit 11.
  bool drive_follows_command = false;       ///< Bit 12 (cyclic synchronous modes).
};

/// Splits a statusword (object 0x6041) into its fields.
constexpr Statusword decode_statusword(std::uint16_t statusword) noexcept {
  Statusword s;
  s.state = decode_power_state(statusword);
  s.voltage_enabled = (statusword & StatuswordBit::kVoltageEnabled) != 0;
  s.warning = (statusword & StatuswordBit::kWarning) != 0;
  s.remote = (statusword & StatuswordBit::kRemote) != 0;
  s.target_reached = (statusword & StatuswordBit::kTargetReached) != 0;
  s.internal_limit_active = (statusword & StatuswordBit::kInternalLimitActive) != 0;
  s.drive_follows_command = (statusword & StatuswordBit::kDriveFollowsCommand) != 0;
  return s;
}

// ---------------------------------------------------------------------------------------------
// Controlword 0x6040
// ---------------------------------------------------------------------------------------------

/// Bits of the controlword (object 0x6040, UNSIGNED16; CiA 402-2 "Controlword").
struct ControlwordBit {
  static constexpr std::uint16_t kSwitchOn = 1u << 0;         ///< so
  static constexpr std::uint16_t kEnableVoltage = 1u << 1;    ///< ev
  static constexpr std::uint16_t kQuickStop = 1u << 2;        ///< qs, active low (0 = quick stop)
  static constexpr std::uint16_t kEnableOperation = 1u << 3;  ///< eo
  static constexpr std::uint16_t kFaultReset = 1u << 7;       ///< fr, acts on its rising edge
  static constexpr std::uint16_t kHalt = 1u << 8;             ///< h (mode specific stop)
};

/// The controlwords numen sends (the don't-care bits of the command coding set to 0).
struct Controlword {
  /// Shutdown, 0 X 1 1 0 (bits 7, 3–0): transitions 2, 6, 8 → ready to switch on.
  static constexpr std::uint16_t kShutdown = 0x0006;
  /// Switch on, 0 0 1 1 1: transition 3 → switched on.
  static constexpr std::uint16_t kSwitchOn = 0x0007;
  /// Switch on + enable operation, 0 1 1 1 1: transitions 3 + 4 → operation enabled.
  static constexpr std::uint16_t kSwitchOnEnableOperation = 0x000F;
  /// Disable voltage, 0 X X 0 X: transitions 7, 9, 10, 12 → switch on disabled.
  static constexpr std::uint16_t kDisableVoltage = 0x0000;
  /// Quick stop, 0 X 0 1 X: transitions 7, 10 → switch on disabled, 11 → quick stop active.
  static constexpr std::uint16_t kQuickStop = 0x0002;
  /// Disable operation, 0 0 1 1 1: transition 5 → switched on (same bits as switch on).
  static constexpr std::uint16_t kDisableOperation = 0x0007;
  /// Enable operation, 0 1 1 1 1: transitions 4, 16 → operation enabled.
  static constexpr std::uint16_t kEnableOperation = 0x000F;
  /// Fault reset, bit 7 0 → 1 (others X): transition 15 fault → switch on disabled.
  static constexpr std::uint16_t kFaultReset = 0x0080;
};

/// The command a controlword carries, from bits 7 and 3–0 alone (CiA 402-2 command coding;
/// bits 4–6 and 8–15 are ignored). The coding is complete: every controlword is exactly one
/// command. Which transition it causes depends on the state (Cia402Drive::step).
enum class ControlCommand : std::uint8_t {
  kDisableVoltage,   ///< 0xxx xx0x: transitions 7, 9, 10, 12.
  kQuickStop,        ///< 0xxx x01x: transitions 7, 10, 11.
  kShutdown,         ///< 0xxx x110: transitions 2, 6, 8.
  kSwitchOn,         ///< 0xxx 0111: switch on (3) or disable operation (5).
  kEnableOperation,  ///< 0xxx 1111: switch on + enable operation (3+4) or enable operation
                     ///< (4, 16).
  kFaultReset,       ///< 1xxx xxxx: fault reset (15) on the rising edge of bit 7. No other
                     ///< command is coded while bit 7 is 1 (every other row has bit 7 = 0).
};

/// Short English name of a ControlCommand (static string).
const char* to_string(ControlCommand command) noexcept;

/// The command coded in `controlword` (see ControlCommand).
constexpr ControlCommand decode_controlword(std::uint16_t controlword) noexcept {
  if ((controlword & ControlwordBit::kFaultReset) != 0) return ControlCommand::kFaultReset;
  if ((controlword & ControlwordBit::kEnableVoltage) == 0) return ControlCommand::kDisableVoltage;
  if ((controlword & ControlwordBit::kQuickStop) == 0) return ControlCommand::kQuickStop;
  if ((controlword & ControlwordBit::kSwitchOn) == 0) return ControlCommand::kShutdown;
  if ((controlword & ControlwordBit::kEnableOperation) == 0) return ControlCommand::kSwitchOn;
  return ControlCommand::kEnableOperation;
}

/// Modes of operation (object 0x6060, INTEGER8) value of cyclic synchronous torque mode.
inline constexpr std::int8_t kModeCyclicSynchronousTorque = 10;

// ---------------------------------------------------------------------------------------------
// Master (controller side)
// ---------------------------------------------------------------------------------------------

/// The state the controller wants a drive in.
enum class Cia402Target : std::uint8_t {
  kDisabled,   ///< Safe state: disable voltage (0x0000) → switch on disabled, no torque.
  kEnabled,    ///< Operation enabled: shutdown → switch on → enable operation, then torque.
  kQuickStop,  ///< Quick stop (0x0002): operation enabled → quick stop active; other energised
               ///< states → switch on disabled. No torque.
};

/// Short English name of a Cia402Target (static string).
const char* to_string(Cia402Target target) noexcept;

/// What the master decided for one period.
struct Cia402MasterOutput {
  /// Controlword (0x6040) to send this period.
  std::uint16_t controlword = Controlword::kDisableVoltage;
  /// True only when the target is kEnabled, the statusword reports operation enabled and no
  /// fault is latched. Otherwise the target torque sent must be 0 (hal::ImpedanceDevice::write() gates
  /// on it).
  bool torque_allowed = false;
  /// The state decoded from the statusword given to update().
  PowerState state = PowerState::kUnknown;
  /// The drive is in the target's state (kEnabled: operation enabled; kDisabled: switch on
  /// disabled or not ready to switch on; kQuickStop: quick stop active or switch on disabled).
  bool at_target = false;
  /// A fault (fault reaction active or fault) was seen and not yet re-armed with
  /// Cia402Master::request_fault_reset(). While set the master sends no power-up command.
  bool fault = false;
  /// The drive stayed in one state for transition_timeout_periods while the master waited
  /// for a transition. Cleared when the state changes or a new request is made.
  bool stuck = false;
};

/// Event counters of a Cia402Master since construction.
struct Cia402MasterCounters {
  std::uint64_t faults = 0;               ///< Faults latched (fault reaction active / fault seen).
  std::uint64_t fault_resets = 0;         ///< Fault reset edges sent (0x0080 after 0x0000).
  std::uint64_t stuck = 0;                ///< Stuck reports (once per episode).
  std::uint64_t invalid_statuswords = 0;  ///< Statuswords matching no state (kUnknown).
  std::uint64_t dropouts = 0;  ///< Drive left operation enabled while the target was kEnabled.
};

/// numen's side of the PDS FSA for one drive. Fed, once per control period, the latest
/// statusword received (its TPDO), it returns the controlword to send (in the RPDO) and whether
/// torque is allowed. Sequence for kEnabled, one command per observed state:
///
///   not ready to switch on → 0x0000 (wait for the drive's automatic transition 1)
///   switch on disabled     → 0x0006 shutdown          (transition 2)
///   ready to switch on     → 0x0007 switch on         (transition 3)
///   switched on            → 0x000F enable operation  (transition 4)
///   operation enabled      → 0x000F, torque allowed
///   quick stop active      → 0x0000 disable voltage   (transition 12; works for every quick stop
///                             option code, 16 only for codes 5–8), then up again
///   fault reaction / fault → fault latched, 0x0000, never re-armed automatically
///
/// A latched fault is cleared only by request_fault_reset(): the master then sends 0x0000 and
/// 0x0080 in two periods once the drive is in fault (a rising edge of bit 7, transition 15),
/// holds 0x0080 until the drive leaves fault, and resumes the sequence. A statusword matching
/// no state (kUnknown) is counted; the previous controlword is repeated and torque forbidden.
/// Not thread safe.
class Cia402Master {
 public:
  /// Default settings, target kDisabled.
  Cia402Master() noexcept = default;
  /// Throws std::invalid_argument naming the field if transition_timeout_periods < 3.
  explicit Cia402Master(const Cia402MasterSettings& settings);

  /// Sets the target state. A change restarts the stuck timer and clears the stuck report.
  void request(Cia402Target target) noexcept;
  /// Re-arms after a fault: clears the latch and, if the drive is in fault reaction active or
  /// fault, sends a fault reset edge (see the class comment). No effect without a latched fault.
  void request_fault_reset() noexcept;

  /// One control period: decodes `statusword` (0x6041) and returns the controlword and the
  /// torque permission for this period.
  Cia402MasterOutput update(std::uint16_t statusword) noexcept;

  /// The current target.
  Cia402Target target() const noexcept { return target_; }
  /// The output of the last update() (the default output before the first).
  const Cia402MasterOutput& last() const noexcept { return out_; }
  /// Counters.
  const Cia402MasterCounters& counters() const noexcept { return counters_; }
  /// The settings.
  const Cia402MasterSettings& settings() const noexcept { return settings_; }

 private:
  enum class ResetPhase : std::uint8_t { kNone, kLow, kHigh };

  std::uint16_t command_for(PowerState state) const noexcept;
  bool at_target(PowerState state) const noexcept;

  Cia402MasterSettings settings_;
  Cia402Target target_ = Cia402Target::kDisabled;
  Cia402MasterOutput out_;
  Cia402MasterCounters counters_;
  PowerState last_state_ = PowerState::kUnknown;        // as decoded, kUnknown included
  PowerState last_known_state_ = PowerState::kUnknown;  // last decodable state
  std::uint32_t waited_periods_ = 0;  // updates waited in one state since the timer restarted
  bool restart_timer_ = false;        // request() changed the target
  bool fault_latched_ = false;
  bool reset_requested_ = false;
  ResetPhase reset_phase_ = ResetPhase::kNone;
};

// ---------------------------------------------------------------------------------------------
// Drive emulator (device side)
// ---------------------------------------------------------------------------------------------

/// Creation settings of a Cia402Drive. Durations are in steps (control periods).
struct Cia402DriveSettings {
  /// Steps spent in not ready to switch on after power-up before the automatic transition 1.
  std::uint32_t init_periods = 1;
  /// Steps spent in fault reaction active before the automatic transition 14 to fault.
  std::uint32_t fault_reaction_periods = 1;
  /// Quick stop option code (object 0x605A, INTEGER16), 0–8. 0: disable drive function — the
  /// drive passes to switch on disabled at the next step. 1–4: stop (simplified: zero torque
  /// for quick_stop_periods), then transition 12 to switch on disabled. 5–8: stop, then stay
  /// in quick stop active (transition 16 on enable operation allowed). Ramps, current and
  /// voltage limits (the differences between 1, 2, 3, 4) are not modelled.
  std::int16_t quick_stop_option_code = 2;
  /// Duration of the quick stop, steps (codes 1–8).
  std::uint32_t quick_stop_periods = 1;
  /// Max torque (object 0x6072), per mille of rated torque, 1–32767: the applied torque is
  /// clipped to ±this and the statusword reports internal limit active.
  std::int16_t max_torque_per_mille = 1000;
  /// Modes of operation (0x6060). Only cyclic synchronous torque (10) applies the target
  /// torque; in any other mode the emulated drive applies 0.
  std::int8_t modes_of_operation = kModeCyclicSynchronousTorque;
  /// Statusword bit 4: the DC link (mains) voltage is present.
  bool voltage_present = true;
  /// Statusword bit 9. false: local control — the drive ignores every controlword.
  bool remote = true;
};

/// Event counters of a Cia402Drive since construction.
struct Cia402DriveCounters {
  std::uint64_t steps = 0;           ///< step() calls.
  std::uint64_t transitions = 0;     ///< State changes (automatic ones included).
  std::uint64_t faults = 0;          ///< Transitions 13 (inject_fault while not in fault).
  std::uint64_t fault_resets = 0;    ///< Transitions 15.
  std::uint64_t torque_limited = 0;  ///< Steps whose target torque was clipped.
};

/// An emulated CiA 402 drive in cyclic synchronous torque mode: the PDS FSA with transitions
/// 0–16 of CiA 402-2, driven one step per control period with the controlword and target torque
/// received in that period (the RPDO applied at SYNC). Power-up performs transition 0 (the drive
/// starts in not ready to switch on). Each step, in this order:
///   1. automatic transitions that are due: 1 (after init_periods), 14 (after
///      fault_reaction_periods), 12 at the end of a quick stop with option code 0–4;
///   2. the controlword's command (decode_controlword), by the transition table; the fault
///      reset acts only on a rising edge of bit 7 relative to the previous step's controlword;
///      switch on + enable operation in ready to switch on performs 3 and 4 in one step;
///   3. the output torque: the target torque clipped to ±max torque in operation enabled with
///      mode 10 and halt (bit 8) clear; 0 in every other case.
/// inject_fault() performs transition 13 at once. Not thread safe.
class Cia402Drive {
 public:
  /// Default settings.
  Cia402Drive() noexcept = default;
  /// Throws std::invalid_argument naming the field: quick_stop_option_code outside 0–8,
  /// max_torque_per_mille outside 1–32767.
  explicit Cia402Drive(const Cia402DriveSettings& settings);

  /// One period with the received controlword (0x6040) and target torque (0x6071, per mille
  /// of rated torque 0x6076).
  void step(std::uint16_t controlword, std::int16_t target_torque_per_mille) noexcept;

  /// A fault occurs (transition 13 from any state except fault reaction active and fault):
  /// fault reaction active at once, error code (0x603F) = `error_code`, torque 0. persistent:
  /// the cause stays until clear_fault_condition(); a fault reset is refused meanwhile. A fault
  /// while already in fault reaction / fault keeps the first error code.
  void inject_fault(std::uint16_t error_code, bool persistent = false) noexcept;
  /// Removes the cause of a persistent fault (a fault reset can then clear it).
  void clear_fault_condition() noexcept { fault_condition_ = false; }
  /// Sets statusword bit 7 (warning); the state is not affected.
  void set_warning(bool warning) noexcept { warning_ = warning; }
  /// Writes modes of operation (0x6060), as an SDO would.
  void set_modes_of_operation(std::int8_t mode) noexcept { settings_.modes_of_operation = mode; }
  /// Writes max torque (0x6072), per mille, as an SDO would; false (unchanged) outside 1–32767.
  /// Takes effect at the next step.
  bool set_max_torque_per_mille(std::int32_t per_mille) noexcept {
    if (per_mille < 1 || per_mille > 32767) return false;
    settings_.max_torque_per_mille = static_cast<std::int16_t>(per_mille);
    return true;
  }

  /// The statusword (0x6041): the state bits (power_state_bits; quick stop bit 0 where it is
  /// don't-care), bit 4 voltage_present, bit 7 warning, bit 9 remote, and in operation enabled:
  /// bit 10 target reached (applied torque == target torque, or halt set), bit 11 internal
  /// limit active (target clipped), bit 12 drive follows the command (mode 10, halt clear).
  std::uint16_t statusword() const noexcept;
  /// The current state.
  PowerState state() const noexcept { return state_; }
  /// Torque applied in the last step, per mille of rated torque (0 outside operation enabled).
  std::int16_t applied_torque_per_mille() const noexcept { return applied_torque_; }
  /// Error code (0x603F) of the current fault; 0 when not in fault / after a fault reset.
  std::uint16_t error_code() const noexcept { return error_code_; }
  /// Modes of operation display (0x6061): the mode in effect.
  std::int8_t modes_of_operation_display() const noexcept { return settings_.modes_of_operation; }
  /// Counters.
  const Cia402DriveCounters& counters() const noexcept { return counters_; }
  /// The settings.
  const Cia402DriveSettings& settings() const noexcept { return settings_; }

 private:
  void enter(PowerState next) noexcept;
  void apply_command(std::uint16_t controlword) noexcept;

  Cia402DriveSettings settings_;
  Cia402DriveCounters counters_;
  PowerState state_ = PowerState::kNotReadyToSwitchOn;
  std::uint32_t periods_in_state_ = 0;  // completed steps since entering state_
  bool entered_this_step_ = false;
  std::uint16_t last_controlword_ = 0;
  std::int16_t applied_torque_ = 0;
  std::uint16_t error_code_ = 0;
  bool fault_condition_ = false;
  bool warning_ = false;
  bool limited_ = false;
  bool target_reached_ = false;
  bool following_ = false;
};

}  // namespace numen::hal
