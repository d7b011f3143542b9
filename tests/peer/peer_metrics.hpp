#pragma once
/// @file peer_metrics.hpp
/// The accuracy figures of the peer comparison, computed by the same code from either engine's
/// body states (docs/peer.md):
///   penetration     the deepest overlap (mm) of a tool sphere with an obstacle or another body
///                   — the tool is the held body and every body of its articulation — found by
///                   numen's own collision detection (core::detect_contacts) on the states;
///   tracking error  |x_held − x_target| (mm) of the held body's COM against the device target,
///                   over the periods in which no tool sphere touches anything (free space):
///                   RMS and maximum.
/// These are the definitions of sim::RunSummary (tool penetration, free-space tracking error),
/// evaluated on the state after each step.

#include <cstdint>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "step_inputs.hpp"

namespace numen::peer {

/// Accuracy over a run.
struct PeerMetrics {
  double penetration_max_mm = 0.0;      ///< Deepest tool sphere overlap.
  double tracking_rms_mm = 0.0;         ///< Free-space tracking error, RMS over free_steps.
  double tracking_max_mm = 0.0;         ///< Its maximum.
  std::int64_t tracking_max_step = -1;  ///< Period (0-based) of that maximum; -1 if none.
  std::int64_t free_steps = 0;          ///< Periods with a held body and no tool contact.
  std::int64_t steps = 0;               ///< Periods measured.
  std::int64_t nonfinite_steps = 0;     ///< Periods whose states were not finite (not measured).
};

/// Accumulates PeerMetrics period by period.
class MetricAccumulator {
 public:
  /// `model` must outlive the accumulator. Allocates its scratch Data once.
  explicit MetricAccumulator(const core::Model& model);

  /// Measures one period: `bodies` (one state per body of the model, after the step) and the
  /// input the step was given (held body, target). No allocation.
  void add(const StepInput& input, const std::vector<core::BodyState>& bodies) noexcept;

  /// The figures so far.
  PeerMetrics result() const noexcept;

 private:
  const core::Model* model_;
  core::Data ghost_;  // collision scratch: the bodies placed at the measured states
  PeerMetrics acc_;
  double free_sq_ = 0.0;
};

}  // namespace numen::peer
