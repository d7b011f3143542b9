#pragma once
/// @file evemu_log.hpp
/// Recorded event streams in the text format of evemu (Debian package evemu-tools:
/// `evemu-record /dev/input/eventN > mouse.evemu`, replayed by `evemu-play`). A recording is
/// the device description followed by the events, one per line:
///
///     # EVEMU 1.3                       comment ('#' to the end of the line)
///     N: Logitech USB Optical Mouse     device name
///     I: 0003 046d c077 0111            bus, vendor, product, version (hex)
///     P: 00 00 00 00 00 00 00 00        input properties
///     B: 02 03 00 00 00 00 00 00 00     event bits per type
///     A: 00 0 1023 0 0 0                absolute axis (index min max fuzz flat resolution)
///     L: ..., S: ...                    LEDs, switches
///     E: 0.000001 0002 0000 0001	# EV_REL / REL_X                1
///     E: 0.000001 0000 0000 0000	# ------------ SYN_REPORT (0) ---------- +0ms
///
/// An event line is `E: <sec>.<usec> <type hex> <code hex> <value decimal>` (evemu's
/// evemu_write_event: "E: %lu.%06u %04x %04x %04d", so negative values look like `-001`),
/// optionally followed by whitespace and a `#` comment (file format 1.1 and later).
/// evemu-record writes times relative to the first event, which it puts at 0.000001 s.
/// Description lines (N: I: P: B: A: L: S:), comments and blank lines are skipped: replaying
/// into the integrator needs only the events. The line parser is noexcept and allocation
/// free; load_evemu_recording() is setup code.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "numen/hal/input/input_event.hpp"

namespace numen::hal {

/// What is wrong with a recording line (parse_evemu_line()). The column says where.
enum class EvemuError : std::uint8_t {
  kNone,                 ///< Parsed (an event, or a line to skip).
  kUnknownLine,          ///< Not blank, not '#', not one of the prefixes E: N: I: P: B: A:
                         ///< L: S:.
  kBadTimestamp,         ///< Not `digits.6digits` (evemu writes microseconds, 6 digits).
  kTimestampOutOfRange,  ///< More than int64 nanoseconds.
  kBadType,              ///< Event type: not 1–4 hex digits.
  kTypeOutOfRange,       ///< Event type above EV_MAX (0x1f).
  kBadCode,              ///< Event code: not 1–4 hex digits.
  kCodeOutOfRange,       ///< Event code above its type's maximum (SYN_MAX, KEY_MAX, REL_MAX,
                         ///< ABS_MAX, MSC_MAX, SW_MAX, LED_MAX, SND_MAX, REP_MAX; KEY_MAX
                         ///< for the other types).
  kBadValue,             ///< Value: not an optionally signed decimal integer.
  kValueOutOfRange,      ///< Value outside int32.
  kTrailingText,         ///< Something after the value other than whitespace and a '#'
                         ///< comment.
};

/// Outcome of parse_evemu_line().
struct EvemuParseResult {
  EvemuError error = EvemuError::kNone;
  /// 1-based column (byte) of the offending character; one past the end of the line when
  /// something is missing there. 0 when error == kNone.
  std::size_t column = 0;
  /// True when the line was an event line and `event` was set.
  bool is_event = false;
  bool ok() const noexcept { return error == EvemuError::kNone; }
};

/// Parses one recording line (a trailing "\n" or "\r\n" is allowed). An event line sets
/// `event` (time_ns = sec·10⁹ + usec·10³) and is_event; a description line, comment or blank
/// line is skipped (ok, is_event false, `event` unchanged); anything else is an error and
/// `event` is unchanged. Fields are separated by spaces or tabs. noexcept, no allocation.
EvemuParseResult parse_evemu_line(std::string_view line, InputEvent& event) noexcept;

/// Short English description of an EvemuError (static string).
const char* to_string(EvemuError error) noexcept;

/// Line counts of one load_evemu_recording() call.
struct EvemuLoadStats {
  std::size_t lines = 0;    ///< Lines in the file.
  std::size_t events = 0;   ///< Event lines loaded.
  std::size_t skipped = 0;  ///< Description lines, comments and blank lines.
};

/// Reads the events of an evemu recording into memory (setup code), in file order. Throws
/// std::runtime_error "path: cannot open: <errno text>" or "path:line:column: <what>" for the
/// first bad line. Memory: sizeof(InputEvent) (16 bytes) per event.
std::vector<InputEvent> load_evemu_recording(const std::string& path,
                                             EvemuLoadStats* stats = nullptr);

}  // namespace numen::hal
