#pragma once
/// @file needle_summary.hpp
/// The suture needles of a run in its summary (docs/suturing.md "The needle through tissue",
/// docs/outputs.md `needle.*`): per needle its punctures, exits, releases and tunnels, the tip's
/// force at the last puncture against its threshold, the largest deviation of a puncture point
/// from the arc, its passes (an entry, then the exit that follows it) and whether each went
/// through, and where each went in and came out against the scene's marks for it (`entry_mark`,
/// `exit_mark`, one per pass); and the largest force the needles and their threads put on the
/// tissue.

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::sim {

struct RunSummary;
struct Scene;

/// Sizes RunSummary::needle_runs to the scene's needles (one NeedleRunFigures each, with its
/// marks and threshold) and sets RunSummary::needles. Allocates (before the run).
void begin_needle_figures(const Scene& scene, RunSummary& s);

/// Adds one step's needle outputs (core::NeedleState of each Data::needles) to `s`'s
/// needle_runs: the counts, the largest deviation, and at a new entry (a new pass, or the one
/// still open replaced) or exit (the open pass ended) its material point's rest position (the
/// punctured triangle's rest nodes by its weights) and time, at a new tunnel its time; and the largest force on the tissue (RunSummary::needle_tissue_force_max_n:
/// |Σ F| of the needles' ties and the threads' eyelets on and contacts with tissue, their held
/// node springs) and its time. Real-time path: no allocation, no throw.
void accumulate_needle_figures(const core::Model& model, const core::Data& data, RunSummary& s) noexcept;

/// After a run: the needle.* figures from needle_runs (sums; the last puncture's tip force and
/// its threshold; the largest deviation; the passes through; the largest entry and exit errors of
/// the marked passes from their marks),
/// one line per needle (needle.lines) and, for a needle that tunnelled, a warning naming it.
/// Allocates (end of run).
void summarize_needles(RunSummary& s);

}  // namespace numen::sim
