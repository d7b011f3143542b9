#pragma once
/// @file thread_summary.hpp
/// The suture threads of a run in its summary (docs/thread.md "The thread", docs/outputs.md
/// `thread.*`): the largest tension and stretch over the run, and the breaks.

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::sim {

struct RunSummary;

/// Adds one step's thread outputs (core::ThreadOutput of each Data::threads) to `s`: the largest
/// tension (N) and stretch, the breaks (core::ThreadOutput::broke) and the first break's time
/// (Data::time). Real-time path: no allocation, no throw.
void accumulate_thread_figures(const core::Data& data, RunSummary& s) noexcept;

/// After a run of `model`: RunSummary::threads (the scene has threads) and, for a thread that
/// broke, a warning naming it, the segment and the first break's time. Allocates (end of run).
void summarize_threads(const core::Model& model, const core::Data& data, RunSummary& s);

}  // namespace numen::sim
