/// @file peer_table.cpp
/// Table and CSV output of the comparison.

#include "peer_table.hpp"

#include <cstdio>
#include <sstream>

namespace numen::peer {
namespace {

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

std::string format_table(const std::vector<PeerRow>& rows) {
  std::ostringstream os;
  os << "| scene | engine / variant | median µs/step | p99 µs | ratio numen/this | max penetration "
        "mm "
        "| free-space tracking rms / max mm | diverged |\n";
  os << "| --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const PeerRow& r : rows) {
    os << "| " << r.scene << " | " << r.engine << " / " << r.variant << " | "
       << fixed(r.step_median_us, 2) << " | " << fixed(r.step_p99_us, 2) << " | "
       << (r.engine == "numen" ? "—" : fixed(r.ratio_numen_over_this, 2)) << " | "
       << fixed(r.metrics.penetration_max_mm, 3) << " | " << fixed(r.metrics.tracking_rms_mm, 3)
       << " / " << fixed(r.metrics.tracking_max_mm, 3) << " | "
       << (r.divergences > 0 || r.metrics.nonfinite_steps > 0
               ? "yes (" + std::to_string(r.divergences) + " resets)"
               : "no")
       << " |\n";
  }
  return os.str();
}

std::string format_csv(const std::vector<PeerRow>& rows) {
  std::ostringstream os;
  os << "scene,engine,variant,steps,step_median_us,step_p99_us,ratio_numen_over_this,penetration_"
        "max_mm,"
        "tracking_rms_mm,tracking_max_mm,tracking_max_step,free_steps,nonfinite_steps,divergences,"
        "contacts_max\n";
  for (const PeerRow& r : rows) {
    os << r.scene << "," << r.engine << ",\"" << r.variant << "\"," << r.steps << ","
       << fixed(r.step_median_us, 4) << "," << fixed(r.step_p99_us, 4) << ","
       << fixed(r.ratio_numen_over_this, 4) << "," << fixed(r.metrics.penetration_max_mm, 6) << ","
       << fixed(r.metrics.tracking_rms_mm, 6) << "," << fixed(r.metrics.tracking_max_mm, 6) << ","
       << r.metrics.tracking_max_step << "," << r.metrics.free_steps << ","
       << r.metrics.nonfinite_steps << "," << r.divergences << "," << r.contacts_max << "\n";
  }
  return os.str();
}

}  // namespace numen::peer
