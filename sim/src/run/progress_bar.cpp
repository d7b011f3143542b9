/// @file progress_bar.cpp
/// A one-line progress bar (progress_bar.hpp).

#include "numen/sim/run/progress_bar.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace numen::sim {
namespace {

std::string duration_text(double s) {
  if (!(s >= 0.0) || !std::isfinite(s)) return "?";
  const long total = std::lround(s);
  char buf[32];
  if (total >= 60) {
    std::snprintf(buf, sizeof buf, "%ldm%02lds", total / 60, total % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%lds", total);
  }
  return buf;
}

}  // namespace

ProgressBar::ProgressBar(std::FILE* out, int width)
    : out_(out),
      width_(std::max(1, width)),
      tty_(out != nullptr && isatty(fileno(out)) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

std::string ProgressBar::render(double fraction, double elapsed_s, double remaining_s,
                                const std::string& label, int width) {
  const double f = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  const int filled = static_cast<int>(std::floor(f * width));
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.append(static_cast<std::size_t>(width - filled), '.');
  char buf[96];
  std::snprintf(buf, sizeof buf, "] %3d%% %s elapsed, %s left  ",
                static_cast<int>(std::floor(f * 100.0)), duration_text(elapsed_s).c_str(),
                duration_text(remaining_s).c_str());
  return "[" + bar + buf + label;
}

void ProgressBar::update(double done, double total, const std::string& label) {
  if (!out_) return;
  const auto now = std::chrono::steady_clock::now();
  fraction_ = total > 0.0 ? std::clamp(done / total, 0.0, 1.0) : 0.0;
  label_ = label;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  // The first few percent say little about the rest (runs differ in cost): no estimate yet.
  const double remaining = fraction_ >= 0.02 ? elapsed * (1.0 - fraction_) / fraction_ : -1.0;
  const std::string line = render(fraction_, elapsed, remaining, label, width_);
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && fraction_ < 1.0) return;
    last_draw_ = now;
    std::string padded = line;
    if (padded.size() < last_length_) padded.append(last_length_ - padded.size(), ' ');
    last_length_ = line.size();
    std::fprintf(out_, "\r%s", padded.c_str());
  } else {
    const int decile = static_cast<int>(std::floor(fraction_ * 10.0));
    if (decile == last_decile_) return;
    last_decile_ = decile;
    std::fprintf(out_, "%s\n", line.c_str());
  }
  std::fflush(out_);
}

void ProgressBar::finish() {
  if (!out_) return;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::string line = render(1.0, elapsed, 0.0, "done", width_);
  if (tty_) {
    std::string padded = line;
    if (padded.size() < last_length_) padded.append(last_length_ - padded.size(), ' ');
    std::fprintf(out_, "\r%s\n", padded.c_str());
  } else {
    std::fprintf(out_, "%s\n", line.c_str());
  }
  std::fflush(out_);
}

}  // namespace numen::sim
