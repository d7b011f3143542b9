#pragma once
/// @file cli_values.hpp
/// Checks of the `numen` command's numeric option values, shared by its CLI11
/// validators (sim/app/main.cpp) and the tests. Each returns "" for a good
/// value and otherwise a message that quotes the value as typed and states
/// the accepted range with six significant digits (never DBL_MAX in full).

#include <string>

namespace numen::sim {

/// A time in seconds given on the command line (`--duration`, `--phase`):
/// `text` must be a whole decimal number (strtod syntax, nothing after it),
/// finite — "nan" and "inf" are refused, they would silently select a default
/// — and in [lo, hi], or in (lo, hi] when `lo_exclusive`. Returns "" when it
/// is, else e.g. "must be a finite number of seconds in (0, 1e+07], got 'nan'".
std::string check_seconds(const std::string& text, double lo, double hi, bool lo_exclusive);

/// A whole number given on the command line (`--overrun-limit`): `text` must be decimal digits
/// with an optional leading '-' (nothing else, no blanks) and in [lo, hi]. Returns "" when it
/// is, else e.g. "must be a whole number in [0, 4294967295], got '-1'" (CLI11's own message
/// would be "Could not convert", without the range).
std::string check_count(const std::string& text, long long lo, long long hi);

}  // namespace numen::sim
