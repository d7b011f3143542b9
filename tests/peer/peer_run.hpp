#pragma once
/// @file peer_run.hpp
/// One engine over one scene of the comparison: every period the scene's recorded input is
/// written into the engine, the engine steps — the only timed call (core::step for numen,
/// mj_step for MuJoCo), with the same clock (CLOCK_MONOTONIC, platform::monotonic_now_ns) in
/// the same process — and the state after the step is measured (peer_metrics.hpp).

#include <cstdint>
#include <string>
#include <vector>

#include "mjcf_translation.hpp"
#include "peer_metrics.hpp"
#include "peer_scene.hpp"
#include "step_percentiles.hpp"

namespace numen::peer {

/// One line of the comparison table.
struct PeerRow {
  std::string scene;
  std::string engine;   ///< "numen" or "mujoco".
  std::string variant;  ///< numen: its integrator and coupling; MuJoCo: to_string(Drive).
  std::int64_t steps = 0;
  double step_median_us = 0.0;  ///< Median wall time of one step (µs).
  double step_p99_us = 0.0;     ///< 99th percentile (µs).
  /// numen's median over this row's median (1 for numen's own row; > 0.5 misses the issue's
  /// target of numen at most half of MuJoCo's time).
  double ratio_numen_over_this = 1.0;
  PeerMetrics metrics;
  int divergences = 0;   ///< MuJoCo: resets after a bad qacc; numen: non-finite steps rolled back.
  int contacts_max = 0;  ///< Most contacts the engine itself detected in one step.
};

/// Median and 99th percentile (µs) of step durations in ns (nearest rank; step_percentiles.hpp,
/// shared with tests/soft_peer). Reorders `ns`.
using test::percentiles_us;

/// The bodies the device holds at some period of `inputs` (sorted, unique).
std::vector<int> held_bodies(const InputRecording& inputs);

/// numen: core::step on a fresh core::Data of scene.model, fed scene.inputs.
PeerRow run_numen(const PeerScene& scene);

/// MuJoCo: MujocoEngine(scene.model, drive, held_bodies(scene.inputs)) fed scene.inputs.
/// Throws what MujocoEngine's constructor throws.
PeerRow run_mujoco(const PeerScene& scene, Drive drive);

/// For each scene: numen, MuJoCo mocap weld, MuJoCo PD xfrc_applied, in that order, with the
/// ratios filled in. `progress`, if set, is called with each row as it completes.
std::vector<PeerRow> run_comparison(const std::vector<PeerScene>& scenes,
                                    void (*progress)(const PeerRow&) = nullptr);

}  // namespace numen::peer
