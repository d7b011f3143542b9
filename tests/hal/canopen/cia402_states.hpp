#pragma once
/// @file cia402_states.hpp
/// Every CiA 402 power state (CiA 402-2, the state machine's eight states), shared by the
/// tests of the emulated drive (cia402_test.cpp) and of the master (cia402_master_test.cpp).

#include "numen/hal/canopen/cia402.hpp"

namespace numen::test {

inline const hal::PowerState kAllStates[] = {
    hal::PowerState::kNotReadyToSwitchOn, hal::PowerState::kSwitchOnDisabled,
    hal::PowerState::kReadyToSwitchOn,    hal::PowerState::kSwitchedOn,
    hal::PowerState::kOperationEnabled,   hal::PowerState::kQuickStopActive,
    hal::PowerState::kFaultReactionActive, hal::PowerState::kFault};

}  // namespace numen::test
