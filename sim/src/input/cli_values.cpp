/// @file cli_values.cpp
/// Checks of `numen` option values (see cli_values.hpp).

#include "numen/sim/input/cli_values.hpp"

#include <cctype>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <system_error>

#include "numen/sim/input/input_error.hpp"

namespace numen::sim {

std::string check_seconds(const std::string& text, double lo, double hi, bool lo_exclusive) {
  const std::string range = std::string(lo_exclusive ? "(" : "[") + format_input_number(lo) +
                            ", " + format_input_number(hi) + "]";
  const std::string expected = "must be a finite number of seconds in " + range + ", got '" +
                               InputError::visible(text) + "'";
  // strtod would skip leading blanks; CLI11 passes the value as typed, so none is expected.
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return expected;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v)) return expected;
  if (v > hi || v < lo || (lo_exclusive && v == lo)) return expected;
  return "";
}

std::string check_count(const std::string& text, long long lo, long long hi) {
  const std::string expected = "must be a whole number in [" + std::to_string(lo) + ", " +
                               std::to_string(hi) + "], got '" + InputError::visible(text) + "'";
  long long v = 0;
  const char* end = text.data() + text.size();
  const std::from_chars_result r = std::from_chars(text.data(), end, v);
  if (text.empty() || r.ec != std::errc() || r.ptr != end || v < lo || v > hi) return expected;
  return "";
}

}  // namespace numen::sim
