#pragma once
/// @file progress_bar.hpp
/// A one-line progress bar for the long studies (`numen study …`) on a terminal: fraction
/// done, elapsed and estimated remaining wall time (linear extrapolation of the work done),
/// and what runs (no estimate before 2 %). On a terminal the line is redrawn in place (carriage
/// return, at most every 0.1 s); otherwise (a log file, CI) one line is printed per 10 % so that
/// logs stay short. No Debian package offers one for C++ (indicators is not packaged). Not
/// real-time code.

#include <chrono>
#include <cstdio>
#include <string>

namespace numen::sim {

/// Progress of a task measured in arbitrary work units.
class ProgressBar {
 public:
  /// Draws on `out` (stderr by default); `width` characters of bar.
  explicit ProgressBar(std::FILE* out = stderr, int width = 30);
  /// Work `done` of `total` (same units, 0 ≤ done ≤ total) and a label of what just ran.
  void update(double done, double total, const std::string& label);
  /// Draws 100 % and ends the line.
  void finish();
  /// The line drawn for a fraction in [0, 1], elapsed and remaining seconds (< 0: unknown)
  /// and a label, without carriage return or newline. Exposed for tests.
  static std::string render(double fraction, double elapsed_s, double remaining_s,
                            const std::string& label, int width);

 private:
  std::FILE* out_;
  int width_;
  bool tty_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  int last_decile_ = -1;
  std::size_t last_length_ = 0;
  double fraction_ = 0.0;
  std::string label_;
};

}  // namespace numen::sim
