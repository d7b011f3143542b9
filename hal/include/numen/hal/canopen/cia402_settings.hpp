#pragma once
/// @file cia402_settings.hpp
/// Cia402MasterSettings: the creation settings of a Cia402Master (cia402.hpp), alone in a
/// header of their own so that a device's settings (ImpedanceSettings::drive_settings,
/// device_status.hpp) carry them without the CiA 402 state machine's header.

#include <cstdint>

namespace numen::hal {

/// Creation settings of a Cia402Master (cia402.hpp), each drive's: how long a drive may take
/// to make a transition before the supervision reports it stuck (FaultCause::kDriveStuck).
struct Cia402MasterSettings {
  /// Periods, >= 3, that the drive may stay in one state while the master waits for a
  /// transition (towards the target, or out of fault after a reset) before it is reported
  /// stuck. At 1 kHz the default is 0.5 s; a drive's power-up (not ready to switch on) counts.
  std::uint32_t transition_timeout_periods = 500;
};

}  // namespace numen::hal
