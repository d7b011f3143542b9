#pragma once
/// @file input_event.hpp
/// InputEvent: one Linux input event (struct input_event of linux/input.h: type, code, value
/// and a time stamp), the unit of the evdev protocol (kernel documentation
/// Documentation/input/event-codes.rst and input.rst). Used by the relative pose integrator,
/// the evdev reader (evdev_pointer.hpp) and the evemu recordings (evemu_log.hpp). The type and
/// code constants are those of <linux/input-event-codes.h> (EV_REL, REL_X, BTN_LEFT, ...),
/// included here so that settings can name them.

#include <linux/input-event-codes.h>

#include <cstdint>

namespace numen::hal {

/// One evdev event. Events between two EV_SYN/SYN_REPORT events form one report: the state
/// changes of one hardware sample, to be applied together (event-codes.rst, "EV_SYN").
struct InputEvent {
  /// Time stamp, ns. EvdevPointer: CLOCK_MONOTONIC (libevdev_set_clock_id); evemu recordings:
  /// the recording's time (evemu-record starts near 0).
  std::int64_t time_ns = 0;
  std::uint16_t type = 0;  ///< Event type: EV_SYN, EV_KEY, EV_REL, ... (0 .. EV_MAX).
  std::uint16_t code = 0;  ///< Event code within the type: SYN_REPORT, BTN_LEFT, REL_X, ...
  std::int32_t value = 0;  ///< REL: signed displacement, counts; KEY: 0 release, 1 press,
                           ///< 2 autorepeat; SYN: 0.
};

}  // namespace numen::hal
