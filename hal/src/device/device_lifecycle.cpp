/// @file device_lifecycle.cpp
/// DeviceLifecycle: unconfigured / inactive / active / safe stop / fault (see the header).

#include "numen/hal/device/device_lifecycle.hpp"

#include <stdexcept>

namespace numen::hal {

const char* to_string(LifecycleState state) noexcept {
  switch (state) {
    case LifecycleState::kUnconfigured:
      return "unconfigured";
    case LifecycleState::kInactive:
      return "inactive";
    case LifecycleState::kActive:
      return "active";
    case LifecycleState::kSafeStop:
      return "safe stop";
    case LifecycleState::kFault:
      return "fault";
  }
  return "unknown";
}

const char* to_string(LifecycleResult result) noexcept {
  switch (result) {
    case LifecycleResult::kOk:
      return "ok";
    case LifecycleResult::kNotUnconfigured:
      return "configure() needs the unconfigured state";
    case LifecycleResult::kNotInactive:
      return "activate() and cleanup() need the inactive state";
    case LifecycleResult::kNotActive:
      return "deactivate() needs the active state";
    case LifecycleResult::kFaultLatched:
      return "a fault is latched: only rearm() leaves the safe state";
    case LifecycleResult::kSafeStopInProgress:
      return "safe stop in progress: the drives are not yet disabled";
    case LifecycleResult::kNotFaulted:
      return "rearm() needs the fault state";
    case LifecycleResult::kCausePresent:
      return "a fault cause is still present";
  }
  return "unknown";
}

DeviceLifecycle::DeviceLifecycle(const LifecycleSettings& settings) : settings_(settings) {
  if (settings.safe_stop_timeout_periods == 0) {
    throw std::invalid_argument(
        "LifecycleSettings.safe_stop_timeout_periods must be >= 1 (periods the safe stop waits "
        "for the drives to disable), got 0");
  }
}

LifecycleResult DeviceLifecycle::refuse(LifecycleResult reason) noexcept {
  ++counters_.refused;
  return reason;
}

void DeviceLifecycle::enter(LifecycleState next) noexcept {
  if (next != state_) ++counters_.transitions;
  state_ = next;
}

LifecycleResult DeviceLifecycle::configure() noexcept {
  if (latched()) return refuse(LifecycleResult::kFaultLatched);
  if (state_ != LifecycleState::kUnconfigured) return refuse(LifecycleResult::kNotUnconfigured);
  enter(LifecycleState::kInactive);
  return LifecycleResult::kOk;
}

LifecycleResult DeviceLifecycle::activate() noexcept {
  if (latched()) return refuse(LifecycleResult::kFaultLatched);
  if (state_ != LifecycleState::kInactive) return refuse(LifecycleResult::kNotInactive);
  if (cause_present_) return refuse(LifecycleResult::kCausePresent);
  enter(LifecycleState::kActive);
  return LifecycleResult::kOk;
}

LifecycleResult DeviceLifecycle::deactivate() noexcept {
  if (latched()) return refuse(LifecycleResult::kFaultLatched);
  if (state_ != LifecycleState::kActive) return refuse(LifecycleResult::kNotActive);
  enter(LifecycleState::kInactive);
  return LifecycleResult::kOk;
}

LifecycleResult DeviceLifecycle::cleanup() noexcept {
  if (latched()) return refuse(LifecycleResult::kFaultLatched);
  if (state_ != LifecycleState::kInactive) return refuse(LifecycleResult::kNotInactive);
  enter(LifecycleState::kUnconfigured);
  return LifecycleResult::kOk;
}

LifecycleResult DeviceLifecycle::rearm() noexcept {
  if (state_ == LifecycleState::kSafeStop) return refuse(LifecycleResult::kSafeStopInProgress);
  if (state_ != LifecycleState::kFault) return refuse(LifecycleResult::kNotFaulted);
  if (cause_present_) return refuse(LifecycleResult::kCausePresent);
  enter(LifecycleState::kInactive);
  ++counters_.rearms;
  return LifecycleResult::kOk;
}

LifecycleUpdate DeviceLifecycle::enter_safe_stop() noexcept {
  LifecycleUpdate u;
  if (state_ == LifecycleState::kInactive || state_ == LifecycleState::kActive) {
    enter(LifecycleState::kSafeStop);
    ++counters_.safe_stops;
    safe_stop_periods_ = 0;
    safe_stop_since_ns_ = now_ns_;
    timed_out_ = false;
    u.entered_safe_stop = true;
  }
  u.state = state_;
  return u;
}

LifecycleUpdate DeviceLifecycle::trip() noexcept { return enter_safe_stop(); }

LifecycleUpdate DeviceLifecycle::update(std::int64_t now_ns,
                                        const LifecycleInputs& inputs) noexcept {
  ++counters_.updates;
  now_ns_ = now_ns;
  cause_present_ = inputs.cause_present;
  LifecycleUpdate u;
  if (state_ == LifecycleState::kSafeStop) {
    // The zero torque and the disable command went out in the period of the trip; their effect
    // can be seen from the next statusword on, so counting starts with this update.
    if (safe_stop_periods_ < settings_.safe_stop_timeout_periods) ++safe_stop_periods_;
    if (inputs.drives_disabled || safe_stop_periods_ >= settings_.safe_stop_timeout_periods) {
      timed_out_ = !inputs.drives_disabled;
      if (timed_out_) ++counters_.safe_stop_timeouts;
      enter(LifecycleState::kFault);
      fault_since_ns_ = now_ns;
      u.entered_fault = true;
      u.timed_out = timed_out_;
    }
  } else if (inputs.fault) {
    u = enter_safe_stop();
  }
  u.state = state_;
  return u;
}

}  // namespace numen::hal
