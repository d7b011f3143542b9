/// @file candump_fuzz.cpp
/// libFuzzer harness of the candump log parser (hal/transport/candump_log.hpp): every line of the input
/// through parse_candump_line(); a line that parses must give a well-formed frame (check_frame():
/// what a replay hands a Bus) and format (format_candump_line()) and parse back to the same
/// record. Inputs of a size divisible by 8 also go whole through load_candump_log() as a file,
/// whose only accepted failure is std::runtime_error naming the place, and each record it
/// loads must pass check_frame() too.

#include <cstdint>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/hal/transport/candump_log.hpp"

namespace {

using numen::hal::CandumpRecord;

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

void check_line(std::string_view line) {
  using numen::fuzz::finding;
  CandumpRecord record;
  const auto parsed = numen::hal::parse_candump_line(line, record);
  if (!parsed.ok()) {
    if (parsed.column == 0 || parsed.column > line.size() + 1)
      finding("candump: error column outside the line", line);
    return;
  }
  if (numen::hal::check_frame(record.frame) != numen::hal::FrameError::kNone)
    finding("candump: a parsed frame fails check_frame()", line);
  char out[numen::hal::kCandumpLineBufferSize];
  const auto formatted = numen::hal::format_candump_line(record.timestamp_ns, record.iface,
                                                         record.frame, record.direction, out);
  if (!formatted.ok()) finding("candump: a parsed record does not format", line);
  CandumpRecord again;
  if (!numen::hal::parse_candump_line({out, formatted.length}, again).ok())
    finding("candump: a formatted record does not parse", line);
  if (!same(record, again)) finding("candump: parse(format(parse(line))) differs", line);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  numen::fuzz::for_each_line({reinterpret_cast<const char*>(data), size}, check_line);
  numen::fuzz::load_file_sometimes(data, size, ".log", [](const std::string& path) {
    const auto records = numen::hal::load_candump_log(path);
    for (const CandumpRecord& r : records)
      if (numen::hal::check_frame(r.frame) != numen::hal::FrameError::kNone)
        numen::fuzz::finding("candump: a loaded frame fails check_frame()");
    return records;
  });
  return 0;
}
