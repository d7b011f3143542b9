/// @file cia402.cpp
/// CiA 402 PDS FSA: names, the controller-side master and the emulated drive (CiA 402-2).

#include "numen/hal/canopen/cia402.hpp"

#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

constexpr bool in_fault(PowerState s) noexcept {
  return s == PowerState::kFaultReactionActive || s == PowerState::kFault;
}

}  // namespace

const char* to_string(PowerState state) noexcept {
  switch (state) {
    case PowerState::kNotReadyToSwitchOn:
      return "not ready to switch on";
    case PowerState::kSwitchOnDisabled:
      return "switch on disabled";
    case PowerState::kReadyToSwitchOn:
      return "ready to switch on";
    case PowerState::kSwitchedOn:
      return "switched on";
    case PowerState::kOperationEnabled:
      return "operation enabled";
    case PowerState::kQuickStopActive:
      return "quick stop active";
    case PowerState::kFaultReactionActive:
      return "fault reaction active";
    case PowerState::kFault:
      return "fault";
    case PowerState::kUnknown:
      return "unknown";
  }
  return "unknown";
}

const char* to_string(ControlCommand command) noexcept {
  switch (command) {
    case ControlCommand::kDisableVoltage:
      return "disable voltage";
    case ControlCommand::kQuickStop:
      return "quick stop";
    case ControlCommand::kShutdown:
      return "shutdown";
    case ControlCommand::kSwitchOn:
      return "switch on / disable operation";
    case ControlCommand::kEnableOperation:
      return "enable operation";
    case ControlCommand::kFaultReset:
      return "fault reset";
  }
  return "unknown";
}

const char* to_string(Cia402Target target) noexcept {
  switch (target) {
    case Cia402Target::kDisabled:
      return "disabled";
    case Cia402Target::kEnabled:
      return "enabled";
    case Cia402Target::kQuickStop:
      return "quick stop";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Cia402Master
// ---------------------------------------------------------------------------------------------

Cia402Master::Cia402Master(const Cia402MasterSettings& settings) : settings_(settings) {
  if (settings.transition_timeout_periods < 3) {
    throw std::invalid_argument(
        "Cia402MasterSettings.transition_timeout_periods must be >= 3 (a fault reset takes two "
        "periods to send), got " +
        std::to_string(settings.transition_timeout_periods));
  }
}

void Cia402Master::request(Cia402Target target) noexcept {
  if (target == target_) return;
  target_ = target;
  restart_timer_ = true;
  out_.stuck = false;
}

void Cia402Master::request_fault_reset() noexcept {
  if (!fault_latched_) return;
  reset_requested_ = true;
}

std::uint16_t Cia402Master::command_for(PowerState state) const noexcept {
  switch (target_) {
    case Cia402Target::kDisabled:
      return Controlword::kDisableVoltage;
    case Cia402Target::kQuickStop:
      return Controlword::kQuickStop;
    case Cia402Target::kEnabled:
      break;
  }
  switch (state) {
    case PowerState::kSwitchOnDisabled:
      return Controlword::kShutdown;
    case PowerState::kReadyToSwitchOn:
      return Controlword::kSwitchOn;
    case PowerState::kSwitchedOn:
    case PowerState::kOperationEnabled:
      return Controlword::kEnableOperation;
    case PowerState::kNotReadyToSwitchOn:
    case PowerState::kQuickStopActive:
    case PowerState::kFaultReactionActive:
    case PowerState::kFault:
    case PowerState::kUnknown:
      break;
  }
  return Controlword::kDisableVoltage;
}

bool Cia402Master::at_target(PowerState state) const noexcept {
  switch (target_) {
    case Cia402Target::kEnabled:
      return state == PowerState::kOperationEnabled;
    case Cia402Target::kDisabled:
      return state == PowerState::kSwitchOnDisabled || state == PowerState::kNotReadyToSwitchOn;
    case Cia402Target::kQuickStop:
      return state == PowerState::kQuickStopActive || state == PowerState::kSwitchOnDisabled ||
             state == PowerState::kNotReadyToSwitchOn;
  }
  return false;
}

Cia402MasterOutput Cia402Master::update(std::uint16_t statusword) noexcept {
  const PowerState state = decode_power_state(statusword);
  const bool known = state != PowerState::kUnknown;
  const bool changed = state != last_state_;
  // The stuck timer restarts (this update counts as 0) on a state change, a new target or the
  // start of a fault reset.
  bool restart = changed || restart_timer_;
  restart_timer_ = false;
  if (changed) out_.stuck = false;
  if (!known) ++counters_.invalid_statuswords;

  if (known) {
    if (last_known_state_ == PowerState::kOperationEnabled &&
        state != PowerState::kOperationEnabled && target_ == Cia402Target::kEnabled) {
      ++counters_.dropouts;
    }
    last_known_state_ = state;
    if (in_fault(state) && !fault_latched_) {
      fault_latched_ = true;
      ++counters_.faults;
    }
    // Re-arm request: a reset edge if the drive is in fault, else only the latch is cleared.
    if (reset_requested_) {
      reset_requested_ = false;
      if (in_fault(state)) {
        reset_phase_ = ResetPhase::kLow;
        restart = true;
        out_.stuck = false;
      } else {
        fault_latched_ = false;
      }
    }
    // The drive left fault (transition 15): the reset is complete.
    if (reset_phase_ != ResetPhase::kNone && !in_fault(state)) {
      reset_phase_ = ResetPhase::kNone;
      fault_latched_ = false;
    }
  }

  // Stuck: waiting for a transition (towards the target, or out of fault during a reset) and
  // the state has not changed for the timeout. A corrupted statusword counts as no progress.
  const bool waiting =
      !known || (!at_target(state) && !(fault_latched_ && reset_phase_ == ResetPhase::kNone));
  if (!waiting || restart) {
    waited_periods_ = 0;
  } else {
    ++waited_periods_;
  }
  if (waiting && !out_.stuck && waited_periods_ >= settings_.transition_timeout_periods) {
    out_.stuck = true;
    ++counters_.stuck;
    // A reset the drive does not answer is abandoned (bit 7 falls, so a later request makes a
    // new edge); the fault stays latched.
    reset_phase_ = ResetPhase::kNone;
  }

  std::uint16_t cw;
  if (!known) {
    cw = out_.controlword;  // no decision on a corrupted statusword
  } else if (reset_phase_ == ResetPhase::kLow) {
    cw = Controlword::kDisableVoltage;  // bit 7 low ...
    if (state == PowerState::kFault) reset_phase_ = ResetPhase::kHigh;
  } else if (reset_phase_ == ResetPhase::kHigh) {
    cw = Controlword::kFaultReset;  // ... then high: a rising edge, held until the drive leaves
    if (out_.controlword != Controlword::kFaultReset) ++counters_.fault_resets;
  } else if (fault_latched_) {
    cw = Controlword::kDisableVoltage;
  } else {
    cw = command_for(state);
  }

  Cia402MasterOutput out;
  out.controlword = cw;
  out.state = state;
  out.at_target = known && at_target(state);
  out.fault = fault_latched_;
  out.stuck = out_.stuck;
  out.torque_allowed = target_ == Cia402Target::kEnabled &&
                       state == PowerState::kOperationEnabled && !fault_latched_ &&
                       reset_phase_ == ResetPhase::kNone;
  out_ = out;
  last_state_ = state;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Cia402Drive
// ---------------------------------------------------------------------------------------------

Cia402Drive::Cia402Drive(const Cia402DriveSettings& settings) : settings_(settings) {
  if (settings.quick_stop_option_code < 0 || settings.quick_stop_option_code > 8) {
    throw std::invalid_argument(
        "Cia402DriveSettings.quick_stop_option_code (0x605A) must be 0-8 (manufacturer "
        "specific codes are not emulated), got " +
        std::to_string(settings.quick_stop_option_code));
  }
  if (settings.max_torque_per_mille < 1) {
    throw std::invalid_argument(
        "Cia402DriveSettings.max_torque_per_mille (0x6072) must be 1-32767, got " +
        std::to_string(settings.max_torque_per_mille));
  }
}

void Cia402Drive::enter(PowerState next) noexcept {
  if (next == state_) return;
  state_ = next;
  periods_in_state_ = 0;
  entered_this_step_ = true;
  ++counters_.transitions;
}

void Cia402Drive::inject_fault(std::uint16_t error_code, bool persistent) noexcept {
  if (persistent) fault_condition_ = true;
  if (in_fault(state_)) return;  // the first fault's code is kept
  error_code_ = error_code;
  ++counters_.faults;
  enter(PowerState::kFaultReactionActive);  // transition 13
  applied_torque_ = 0;
  limited_ = target_reached_ = following_ = false;
}

void Cia402Drive::apply_command(std::uint16_t controlword) noexcept {
  const ControlCommand cmd = decode_controlword(controlword);
  const bool quick_stop_stays = settings_.quick_stop_option_code >= 5;
  switch (state_) {
    case PowerState::kNotReadyToSwitchOn:
    case PowerState::kFaultReactionActive:
    case PowerState::kUnknown:
      return;  // no commanded transition leaves these states
    case PowerState::kSwitchOnDisabled:
      if (cmd == ControlCommand::kShutdown) enter(PowerState::kReadyToSwitchOn);  // 2
      return;
    case PowerState::kReadyToSwitchOn:
      if (cmd == ControlCommand::kSwitchOn) enter(PowerState::kSwitchedOn);               // 3
      if (cmd == ControlCommand::kEnableOperation) enter(PowerState::kOperationEnabled);  // 3+4
      if (cmd == ControlCommand::kDisableVoltage || cmd == ControlCommand::kQuickStop) {
        enter(PowerState::kSwitchOnDisabled);  // 7
      }
      return;
    case PowerState::kSwitchedOn:
      if (cmd == ControlCommand::kEnableOperation) enter(PowerState::kOperationEnabled);  // 4
      if (cmd == ControlCommand::kShutdown) enter(PowerState::kReadyToSwitchOn);          // 6
      if (cmd == ControlCommand::kDisableVoltage || cmd == ControlCommand::kQuickStop) {
        enter(PowerState::kSwitchOnDisabled);  // 10
      }
      return;
    case PowerState::kOperationEnabled:
      if (cmd == ControlCommand::kSwitchOn) enter(PowerState::kSwitchedOn);              // 5
      if (cmd == ControlCommand::kShutdown) enter(PowerState::kReadyToSwitchOn);         // 8
      if (cmd == ControlCommand::kDisableVoltage) enter(PowerState::kSwitchOnDisabled);  // 9
      if (cmd == ControlCommand::kQuickStop) enter(PowerState::kQuickStopActive);        // 11
      return;
    case PowerState::kQuickStopActive:
      if (cmd == ControlCommand::kDisableVoltage) enter(PowerState::kSwitchOnDisabled);  // 12
      if (cmd == ControlCommand::kEnableOperation && quick_stop_stays) {
        enter(PowerState::kOperationEnabled);  // 16
      }
      return;
    case PowerState::kFault: {
      const bool rising = (controlword & ControlwordBit::kFaultReset) != 0 &&
                          (last_controlword_ & ControlwordBit::kFaultReset) == 0;
      if (rising && !fault_condition_) {
        error_code_ = 0;
        ++counters_.fault_resets;
        enter(PowerState::kSwitchOnDisabled);  // 15
      }
      return;
    }
  }
}

void Cia402Drive::step(std::uint16_t controlword, std::int16_t target_torque_per_mille) noexcept {
  ++counters_.steps;
  entered_this_step_ = false;

  // 1. Automatic transitions that are due.
  const std::int16_t qs_code = settings_.quick_stop_option_code;
  switch (state_) {
    case PowerState::kNotReadyToSwitchOn:
      if (periods_in_state_ >= settings_.init_periods) enter(PowerState::kSwitchOnDisabled);  // 1
      break;
    case PowerState::kFaultReactionActive:
      if (periods_in_state_ >= settings_.fault_reaction_periods) enter(PowerState::kFault);  // 14
      break;
    case PowerState::kQuickStopActive:
      if (qs_code <= 4 && periods_in_state_ >= (qs_code == 0 ? 0u : settings_.quick_stop_periods)) {
        enter(PowerState::kSwitchOnDisabled);  // 12, quick stop completed
      }
      break;
    default:
      break;
  }

  // 2. The command, unless the drive is under local control.
  if (settings_.remote) apply_command(controlword);
  last_controlword_ = controlword;

  // 3. Output torque.
  applied_torque_ = 0;
  limited_ = target_reached_ = following_ = false;
  if (state_ == PowerState::kOperationEnabled) {
    const bool halt = (controlword & ControlwordBit::kHalt) != 0;
    if (halt) {
      target_reached_ = true;  // simplified: the emulated drive stops at once
    } else if (settings_.modes_of_operation == kModeCyclicSynchronousTorque) {
      const std::int16_t max = settings_.max_torque_per_mille;
      std::int16_t t = target_torque_per_mille;
      if (t > max) t = max;
      if (t < -max) t = static_cast<std::int16_t>(-max);
      applied_torque_ = t;
      following_ = true;
      limited_ = t != target_torque_per_mille;
      target_reached_ = !limited_;
      if (limited_) ++counters_.torque_limited;
    }
  }

  if (!entered_this_step_) ++periods_in_state_;
}

std::uint16_t Cia402Drive::statusword() const noexcept {
  std::uint16_t sw = power_state_bits(state_);
  if (settings_.voltage_present) sw |= StatuswordBit::kVoltageEnabled;
  if (warning_) sw |= StatuswordBit::kWarning;
  if (settings_.remote) sw |= StatuswordBit::kRemote;
  if (target_reached_) sw |= StatuswordBit::kTargetReached;
  if (limited_) sw |= StatuswordBit::kInternalLimitActive;
  if (following_) sw |= StatuswordBit::kDriveFollowsCommand;
  return sw;
}

}  // namespace numen::hal
