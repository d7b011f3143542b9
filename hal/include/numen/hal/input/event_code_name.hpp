#pragma once
/// @file event_code_name.hpp
/// Names of evdev event codes ("REL_X", "REL_WHEEL", "BTN_LEFT", "KEY_SPACE") turned into their
/// numbers by libevdev (libevdev_event_code_from_name_n, Debian package libevdev-dev), so that
/// settings written by people (a scene's `[trajectory.pointer]`) can name the codes of
/// <linux/input-event-codes.h> instead of giving numbers. Setup code (load time).

#include <cstdint>
#include <optional>
#include <string_view>

namespace numen::hal {

/// The code named `name` within event type `type` (EV_REL, EV_KEY, ...), as libevdev gives it:
/// "REL_X" → 0 for EV_REL, "BTN_LEFT" → 0x110 for EV_KEY (names are case sensitive, as in the
/// kernel header). std::nullopt when the name is not a code of that type ("BTN_LEFT" for
/// EV_REL, "REL_Q") and always in a build without libevdev (NUMEN_WITH_EVDEV=OFF: see
/// event_code_names_available()). Does not throw.
std::optional<std::uint16_t> event_code_from_name(std::uint16_t type, std::string_view name) noexcept;

/// True when event_code_from_name() can resolve names: the build has libevdev
/// (NUMEN_WITH_EVDEV, hal/features.hpp).
bool event_code_names_available() noexcept;

}  // namespace numen::hal
