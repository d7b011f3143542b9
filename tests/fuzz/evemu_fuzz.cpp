/// @file evemu_fuzz.cpp
/// libFuzzer harness of the evemu recording parser (hal/input/evemu_log.hpp): every line of the
/// input through parse_evemu_line() (an error's column must lie on the line, an event's type
/// in range); inputs of a size divisible by 8 also go whole through load_evemu_recording() as
/// a file, whose only accepted failure is std::runtime_error naming the place.

#include <cstdint>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/hal/input/evemu_log.hpp"

namespace {
void check_line(std::string_view line) {
  numen::hal::InputEvent event;
  const auto parsed = numen::hal::parse_evemu_line(line, event);
  if (!parsed.ok() && (parsed.column == 0 || parsed.column > line.size() + 1))
    numen::fuzz::finding("evemu: error column outside the line", line);
  if (parsed.ok() && parsed.is_event && event.type > 0x1f)
    numen::fuzz::finding("evemu: event type above EV_MAX", line);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  numen::fuzz::for_each_line({reinterpret_cast<const char*>(data), size}, check_line);
  numen::fuzz::load_file_sometimes(data, size, ".evemu", [](const std::string& path) {
    return numen::hal::load_evemu_recording(path);
  });
  return 0;
}
