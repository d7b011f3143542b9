#pragma once
/// @file peer_table.hpp
/// The comparison as a readable table (Markdown) and as CSV.
///
/// CSV columns (one header line, then one line per PeerRow, '.' decimal point):
///   scene, engine, variant, steps, step_median_us, step_p99_us, ratio_numen_over_this,
///   penetration_max_mm, tracking_rms_mm, tracking_max_mm, tracking_max_step, free_steps,
///   nonfinite_steps, divergences, contacts_max

#include <string>
#include <vector>

#include "peer_run.hpp"

namespace numen::peer {

/// Markdown table: scene | engine / variant | median µs/step | p99 | ratio numen/this |
/// max penetration mm | free-space tracking rms / max mm | diverged.
std::string format_table(const std::vector<PeerRow>& rows);

/// CSV with the columns of the file comment.
std::string format_csv(const std::vector<PeerRow>& rows);

}  // namespace numen::peer
