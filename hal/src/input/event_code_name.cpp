/// @file event_code_name.cpp
/// Event code names through libevdev (see event_code_name.hpp); without libevdev no name
/// resolves.

#include "numen/hal/input/event_code_name.hpp"

#include "numen/hal/features.hpp"

#if NUMEN_WITH_EVDEV
#include <libevdev/libevdev.h>
#endif

namespace numen::hal {

std::optional<std::uint16_t> event_code_from_name(std::uint16_t type, std::string_view name) noexcept {
#if NUMEN_WITH_EVDEV
  if (name.empty()) return std::nullopt;
  const int code = libevdev_event_code_from_name_n(type, name.data(), name.size());
  if (code < 0 || code > 0xffff) return std::nullopt;
  return static_cast<std::uint16_t>(code);
#else
  (void)type;
  (void)name;
  return std::nullopt;
#endif
}

bool event_code_names_available() noexcept { return kWithEvdev; }

}  // namespace numen::hal
