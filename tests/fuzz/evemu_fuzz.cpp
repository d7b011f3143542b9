/// @file evemu_fuzz.cpp
/// libFuzzer harness of the evemu recording parser (hal/evemu_log.hpp): every line of the
/// input through parse_evemu_line() (an error's column must lie on the line, an event's type
/// and code in range), and the whole input through load_evemu_recording() as a file, whose
/// only accepted failure is std::runtime_error naming the place.

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/hal/evemu_log.hpp"

namespace {
[[noreturn]] void fail(const char* what, std::string_view line) {
  std::fprintf(stderr, "evemu_fuzz: %s: '%.*s'\n", what, static_cast<int>(line.size()),
               line.data());
  std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    numen::hal::InputEvent event;
    const auto parsed = numen::hal::parse_evemu_line(line, event);
    if (!parsed.ok() && (parsed.column == 0 || parsed.column > line.size() + 1))
      fail("error column outside the line", line);
    if (parsed.ok() && parsed.is_event && event.type > 0x1f) fail("event type above EV_MAX", line);
    start = end + 1;
  }
  try {
    (void)numen::hal::load_evemu_recording(numen::fuzz::input_file(data, size, ".evemu"));
  } catch (const std::runtime_error&) {
    // a located error: the expected outcome for a bad recording
  }
  return 0;
}
