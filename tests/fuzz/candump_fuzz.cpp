/// @file candump_fuzz.cpp
/// libFuzzer harness of the candump log parser (hal/candump_log.hpp): every line of the input
/// through parse_candump_line(); a line that parses must format (format_candump_line()) and
/// parse back to the same record. The whole input also goes through load_candump_log() as a
/// file, whose only accepted failure is std::runtime_error naming the place.

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/hal/candump_log.hpp"

namespace {

using numen::hal::CandumpRecord;

[[noreturn]] void fail(const char* what, std::string_view line) {
  std::fprintf(stderr, "candump_fuzz: %s: '%.*s'\n", what, static_cast<int>(line.size()),
               line.data());
  std::abort();
}

bool same(const CandumpRecord& a, const CandumpRecord& b) {
  if (a.timestamp_ns != b.timestamp_ns || !(a.iface == b.iface) || a.direction != b.direction ||
      a.frame.id != b.frame.id || a.frame.flags != b.frame.flags || a.frame.len != b.frame.len ||
      a.frame.timestamp_ns != b.frame.timestamp_ns) {
    return false;
  }
  if (a.frame.remote()) return true;  // a remote request carries no data
  for (int i = 0; i < a.frame.len; ++i) {
    if (a.frame.data[i] != b.frame.data[i]) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    CandumpRecord record;
    const auto parsed = numen::hal::parse_candump_line(line, record);
    if (parsed.ok()) {
      char out[numen::hal::kCandumpLineBufferSize];
      const auto formatted = numen::hal::format_candump_line(record.timestamp_ns, record.iface,
                                                             record.frame, record.direction, out);
      if (!formatted.ok()) fail("a parsed record does not format", line);
      CandumpRecord again;
      if (!numen::hal::parse_candump_line({out, formatted.length}, again).ok())
        fail("a formatted record does not parse", line);
      if (!same(record, again)) fail("parse(format(parse(line))) differs", line);
    } else if (parsed.column == 0 || parsed.column > line.size() + 1) {
      fail("error column outside the line", line);
    }
    start = end + 1;
  }
  try {
    (void)numen::hal::load_candump_log(numen::fuzz::input_file(data, size, ".log"));
  } catch (const std::runtime_error&) {
    // a located error: the expected outcome for a bad log
  }
  return 0;
}
