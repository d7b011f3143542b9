#include "numen/hal/input/evemu_log.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "../text_chars.hpp"

namespace numen::hal {

namespace {

using detail::hex_value;
using detail::is_blank;
using detail::is_digit;

// Cursor over one line; columns are 1-based.
struct Cursor {
  std::string_view s;
  std::size_t i = 0;
  bool done() const noexcept { return i >= s.size(); }
  char peek() const noexcept { return done() ? '\0' : s[i]; }
  std::size_t column() const noexcept { return i + 1; }
  // Skips spaces and tabs; returns how many.
  std::size_t skip_blanks() noexcept {
    const std::size_t start = i;
    while (!done() && is_blank(s[i])) ++i;
    return i - start;
  }
};

// 1-4 hex digits followed by a blank or the end; false leaves the cursor at the bad char.
bool parse_hex16(Cursor& c, std::uint32_t& out) noexcept {
  std::uint32_t v = 0;
  std::size_t n = 0;
  while (!c.done() && !is_blank(c.peek())) {
    const int h = hex_value(c.peek());
    if (h < 0 || n == 4) return false;
    v = v * 16 + static_cast<std::uint32_t>(h);
    ++n;
    ++c.i;
  }
  out = v;
  return n > 0;
}

std::uint32_t max_code(std::uint32_t type) noexcept {
  switch (type) {
    case EV_SYN:
      return SYN_MAX;
    case EV_KEY:
      return KEY_MAX;
    case EV_REL:
      return REL_MAX;
    case EV_ABS:
      return ABS_MAX;
    case EV_MSC:
      return MSC_MAX;
    case EV_SW:
      return SW_MAX;
    case EV_LED:
      return LED_MAX;
    case EV_SND:
      return SND_MAX;
    case EV_REP:
      return REP_MAX;
    default:
      return KEY_MAX;  // the largest code space (EV_FF, EV_PWR, ...)
  }
}

EvemuParseResult fail(EvemuError e, std::size_t column) noexcept { return {e, column, false}; }

}  // namespace

EvemuParseResult parse_evemu_line(std::string_view line, InputEvent& event) noexcept {
  if (!line.empty() && line.back() == '\n') line.remove_suffix(1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  Cursor c{line};
  c.skip_blanks();
  if (c.done()) return {};  // blank line
  if (c.i == 0 && line[0] == '#') return {};
  if (c.i != 0 || line.size() < 2 || line[1] != ':')
    return fail(EvemuError::kUnknownLine, c.column());
  switch (line[0]) {
    case 'N':
    case 'I':
    case 'P':
    case 'B':
    case 'A':
    case 'L':
    case 'S':
      return {};  // device description: not needed to replay the events
    case 'E':
      break;
    default:
      return fail(EvemuError::kUnknownLine, 1);
  }
  c.i = 2;
  if (c.skip_blanks() == 0) return fail(EvemuError::kBadTimestamp, c.column());

  // <sec>.<usec>: seconds as digits, exactly 6 fraction digits.
  const std::size_t sec_col = c.column();
  std::uint64_t sec = 0;
  std::size_t sec_digits = 0;
  while (is_digit(c.peek())) {
    const std::uint64_t d = static_cast<std::uint64_t>(c.peek() - '0');
    if (sec > (std::numeric_limits<std::uint64_t>::max() - d) / 10) {
      return fail(EvemuError::kTimestampOutOfRange, sec_col);
    }
    sec = sec * 10 + d;
    ++sec_digits;
    ++c.i;
  }
  if (sec_digits == 0 || c.peek() != '.') return fail(EvemuError::kBadTimestamp, c.column());
  ++c.i;
  std::uint64_t usec = 0;
  for (int k = 0; k < 6; ++k) {
    if (!is_digit(c.peek())) return fail(EvemuError::kBadTimestamp, c.column());
    usec = usec * 10 + static_cast<std::uint64_t>(c.peek() - '0');
    ++c.i;
  }
  if (!c.done() && !is_blank(c.peek())) return fail(EvemuError::kBadTimestamp, c.column());
  constexpr std::uint64_t kMaxSec =
      static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()) / 1000000000u - 1;
  if (sec > kMaxSec) return fail(EvemuError::kTimestampOutOfRange, sec_col);

  // Type and code, hex.
  c.skip_blanks();
  const std::size_t type_col = c.column();
  std::uint32_t type = 0;
  if (!parse_hex16(c, type)) return fail(EvemuError::kBadType, c.column());
  if (type > EV_MAX) return fail(EvemuError::kTypeOutOfRange, type_col);
  if (c.skip_blanks() == 0) return fail(EvemuError::kBadCode, c.column());
  const std::size_t code_col = c.column();
  std::uint32_t code = 0;
  if (!parse_hex16(c, code)) return fail(EvemuError::kBadCode, c.column());
  if (code > max_code(type)) return fail(EvemuError::kCodeOutOfRange, code_col);
  if (c.skip_blanks() == 0) return fail(EvemuError::kBadValue, c.column());

  // Value: optional sign, decimal digits (evemu's %04d pads with zeros: "0001", "-001").
  const std::size_t value_col = c.column();
  bool negative = false;
  if (c.peek() == '-' || c.peek() == '+') {
    negative = c.peek() == '-';
    ++c.i;
  }
  std::int64_t value = 0;
  std::size_t value_digits = 0;
  while (is_digit(c.peek())) {
    value = value * 10 + (c.peek() - '0');
    if (value > static_cast<std::int64_t>(std::numeric_limits<std::int32_t>::max()) + 1) {
      return fail(EvemuError::kValueOutOfRange, value_col);
    }
    ++value_digits;
    ++c.i;
  }
  if (value_digits == 0 || (!c.done() && !is_blank(c.peek()))) {
    return fail(EvemuError::kBadValue, c.column());
  }
  if (negative) value = -value;
  if (value > std::numeric_limits<std::int32_t>::max()) {
    return fail(EvemuError::kValueOutOfRange, value_col);
  }
  c.skip_blanks();
  if (!c.done() && c.peek() != '#') return fail(EvemuError::kTrailingText, c.column());

  event.time_ns = static_cast<std::int64_t>(sec * 1000000000u + usec * 1000u);
  event.type = static_cast<std::uint16_t>(type);
  event.code = static_cast<std::uint16_t>(code);
  event.value = static_cast<std::int32_t>(value);
  return {EvemuError::kNone, 0, true};
}

const char* to_string(EvemuError error) noexcept {
  switch (error) {
    case EvemuError::kNone:
      return "no error";
    case EvemuError::kUnknownLine:
      return "unknown line: expected E:, a description line (N: I: P: B: A: L: S:), '#' or blank";
    case EvemuError::kBadTimestamp:
      return "bad time stamp: expected <sec>.<6-digit usec>";
    case EvemuError::kTimestampOutOfRange:
      return "time stamp out of range";
    case EvemuError::kBadType:
      return "bad event type: expected 1-4 hex digits";
    case EvemuError::kTypeOutOfRange:
      return "event type above EV_MAX (0x1f)";
    case EvemuError::kBadCode:
      return "bad event code: expected 1-4 hex digits";
    case EvemuError::kCodeOutOfRange:
      return "event code above the maximum of its type";
    case EvemuError::kBadValue:
      return "bad value: expected a decimal integer";
    case EvemuError::kValueOutOfRange:
      return "value outside int32";
    case EvemuError::kTrailingText:
      return "trailing text after the value (comments start with '#')";
  }
  return "unknown error";
}

std::vector<InputEvent> load_evemu_recording(const std::string& path, EvemuLoadStats* stats) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw std::runtime_error(path + ": cannot open: " + std::strerror(err));
  }
  std::vector<InputEvent> events;
  EvemuLoadStats counts;
  std::string line;
  while (std::getline(in, line)) {
    ++counts.lines;
    InputEvent ev;
    const EvemuParseResult r = parse_evemu_line(line, ev);
    if (!r.ok()) {
      throw std::runtime_error(path + ":" + std::to_string(counts.lines) + ":" +
                               std::to_string(r.column) + ": " + to_string(r.error));
    }
    if (r.is_event) {
      events.push_back(ev);
    } else {
      ++counts.skipped;
    }
  }
  if (in.bad()) {
    const int err = errno;
    throw std::runtime_error(path + ":" + std::to_string(counts.lines + 1) +
                             ": read error: " + std::strerror(err));
  }
  counts.events = events.size();
  if (stats != nullptr) *stats = counts;
  return events;
}

}  // namespace numen::hal
