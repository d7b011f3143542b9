#pragma once
/// @file divergence.hpp
/// The divergence monitor of a run (docs/safety.md, "Divergence"): finite is not bounded. A
/// scene whose gains its time step cannot integrate (a coupling stiffness of 1e12 N/m at 1 ms)
/// stays finite for seconds while its bodies fly off at 55 m/s and its net's nodes at 933 m/s.
/// The monitor judges each period's state by physics and latches the first breach with its
/// cause; the run then stops commanding torque and exits with ExitStatus::kDiverged:
///
/// | cause | quantity | limit |
/// | --- | --- | --- |
/// | "body speed" | |v| + |ω| r of a body (r: its bounding radius) | speed_factor × v_ref |
/// | "node speed" | |v| of a net node | speed_factor × v_ref |
/// | "tie stretch" | |x − a| of a node from its anchor on the rigid component | stretch_factor × the net's rest radius + 2 × its largest stretch at the base |
/// | "energy" | stored energy + gravity's potential (energy.hpp) | energy_factor × max(E₀ + W_in, energy_floor_j) |
///
/// E₀ counts the contacts' potential at the base (½ k d² of the first period's contacts).
///
/// v_ref = max(the hand's fastest speed so far (|v_t| + |ω_t| r of the held body, and the
/// coupling spring's step response to a target that jumps between two periods further than
/// its twist explains, step_response_speed()), √(2 |g| H)
/// with H the height of the scene's bounding box at the start (its extent along gravity:
/// bodies, nets, bounded obstacles), √(2 E_c0 / m_min) with E_c0 the contacts' potential ½ k d²
/// at the base (a tool that starts inside an obstacle is pushed out by it; m_min the lightest
/// colliding body), speed_floor_mps): whatever
/// moves in a god-object scene is driven by the hand or falls under gravity, and a penalty
/// contact throws a light body at most at about twice the speed of what hits it.
/// W_in is the work the hand puts in through the coupling springs and dampers (the jump of the
/// springs' potential when the target moves at the unchanged state, plus h times the dampers'
/// power through the target's twist, as the stability study counts it: study_stability.hpp);
/// E₀ + W_in is what a passive scene (Adams & Hannaford 1999: the virtual coupling is passive)
/// can hold at most. The energy bound applies where the coupling springs act (god-object and
/// first-order modes); it is rebased when the held body changes (an attach event).
///
/// A tool that starts inside an obstacle is pushed out by it (the run's start-up, RunSummary):
/// E_c0 then sets v_ref and E₀ for the push-out only. When the runner says the start-up has
/// ended (end_startup()), both are rebased on the state then: the push speed becomes the
/// larger of √(2 E_c / m_min) of the contacts then and the fastest body's speed then (what the
/// push-out left moving), E₀ the stored energy then. A trial that starts 20.9 mm inside the
/// tissue no longer runs its whole length under a 989 m/s speed limit.

#include <algorithm>
#include <cstdint>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::sim {

/// Limits of the divergence monitor (the table in the file comment).
struct DivergenceLimits {
  double speed_factor = 10.0;     ///< Speeds may reach this × v_ref.
  double speed_floor_mps = 0.5;   ///< v_ref is at least this (m/s).
  double stretch_factor = 1.0;    ///< Tie stretch may reach this × the net's rest radius (+ 2 × the start's).
  double energy_factor = 100.0;   ///< E may reach this × max(E₀ + W_in, energy_floor_j).
  double energy_floor_j = 0.01;   ///< J: what a scene at rest may hold without a verdict.
};

/// What the monitor latched.
struct Divergence {
  /// nullptr: none; else "body speed", "node speed", "tie stretch", "energy" or one latched
  /// from outside (DivergenceMonitor::latch_external(): "device plant").
  const char* cause = nullptr;
  int body = -1;  ///< The body ("body speed"), the net's rigid component, or the device axis
                  ///< ("device plant").
  int net = -1;                 ///< The net ("node speed", "tie stretch"); -1 otherwise.
  double value = 0.0;           ///< The quantity (m/s, m or J; "device plant": m/s or rad/s).
  double limit = 0.0;           ///< Its limit then (same unit).
  std::int64_t period = -1;     ///< Period of the breach (0-based).
  double time_s = 0.0;          ///< Its simulated time (s).
};

/// Peak speed (m/s, |v| + |ω| r as the speed bound measures it) of body `b` when its coupling
/// target steps from `from` to `to` in one period of h = model.dt while its twist is `twist`:
/// the jump is the part of the step the twist does not explain, Δ = max(0, |Δx| − |v_t| h)
/// (and Δθ = max(0, |Δθ| − |ω_t| h)); an undamped mass on the coupling spring stepped by Δ
/// peaks at Δ ω_n, with ω_n = √(k_t/m) in translation and √(k_r/I_u) in rotation (I_u the
/// body's inertia about the step's axis, at its pose in `data`), and a step integrated at h
/// reaches its target in no less than a period, so ω_n is taken at most 1/h. A held sample that
/// jumps to the hand's pose after a link outage is such a step (the HIL scenario
/// run_device_link); a hand that moves smoothly gives Δ ≈ 0, so a coupling too stiff for h
/// (1e12 N/m) does not raise its own limit.
double step_response_speed(const core::Model& model, const core::Data& data, int b,
                           const core::Pose& from, const core::Pose& to,
                           const core::Twist& twist) noexcept;

/// Per-period divergence monitor of one run. Construction allocates (setup); observe() never
/// allocates, throws, locks or blocks, and costs O(bodies + nets) on a state whose step measured
/// its nets (Data::stages_run has core::kStageMeasureNets: every core::step of a model with nets;
/// the nets are judged from core::NetOutput), else O(bodies + nodes + springs), less the organs'
/// where the caller says they are unchanged.
class DivergenceMonitor {
 public:
  /// Sizes the monitor for `model` and takes the scene's scale from `data` (the state at the
  /// start: body poses, nodes, finite obstacles).
  DivergenceMonitor(const core::Model& model, const core::Data& data,
                    const DivergenceLimits& limits = {});

  /// Judges the state after period `period` (simulated time `time_s`). Returns true in the
  /// period of the first breach (then latched: later calls return false and change nothing).
  /// Where `data.stages_run` has core::kStageMeasureNets, each net's node speeds and tie
  /// stretches are its NetOutput's largest (at the step's end) and its energy NetOutput's
  /// start_energy (the forces stage's, at the step's start: the energy bound one step behind for
  /// the nets): `data` must then be the state that step made (a state changed by hand after the
  /// step needs stages_run cleared of that bit).
  /// `organs_unchanged`: the nodes of the organs (nets on anchored bodies) are those of the last
  /// call (a multirate run's view between two scene samples, whose Data carries no step's
  /// measures: MultirateRun::took_model()), so that a device period does not pay
  /// O(nodes + springs) for a state the scene loop has not changed: the organs keep their last
  /// judgement (the energy bound their last energy). Ignored on a measured state and on the
  /// first call.
  bool observe(const core::Model& model, const core::Data& data, std::int64_t period, double time_s,
               bool organs_unchanged = false) noexcept;

  /// The run's start-up push-out ended with `data` (see the file comment): the speed bound's
  /// push speed and the energy base E₀ + W_in are rebased on this state. No allocation.
  void end_startup(const core::Model& model, const core::Data& data) noexcept;

  /// A live input's first sample brought the tool to where the instrument lies, far from the
  /// scene's start (platform::ControlLoopSettings::place_at_first_sample): what came before is
  /// not the run's. The next observe() takes its base (E₀ + W_in, the contacts' push speed) from
  /// that state as at a first period, and neither the hand's speed so far nor the targets' jump
  /// from the scene's start to the live pose raises the speed limit. No allocation.
  void restart() noexcept {
    prev_held_ = -2;
    hand_speed_max_mps_ = 0.0;
    push_speed_mps_ = 0.0;
  }

  /// Latches a breach found outside the monitor (e.g. "device plant": the emulated device's
  /// mechanics ran away, PlantMotion) with `cause` (a static string), the axis or body index
  /// `subject` in Divergence::body, the quantity `value` that breached its `limit` (the device
  /// plant: the axis's speed and its runaway speed, m/s or rad/s), in period `period` at
  /// simulated time `time_s`. Returns true if this latched it (false if a breach was already
  /// latched). noexcept, no allocation.
  bool latch_external(const char* cause, int subject, double value, double limit,
                      std::int64_t period, double time_s) noexcept {
    if (latched_.cause != nullptr) return false;
    latch(cause, subject, -1, value, limit, period, time_s);
    return true;
  }
  /// The latched breach (cause nullptr while none).
  const Divergence& divergence() const noexcept { return latched_; }
  /// Largest E / max(E₀ + W_in, energy_floor_j) seen (0 where the energy bound does not apply).
  double energy_ratio_max() const noexcept { return energy_ratio_max_; }
  /// Largest speed / speed limit of a body or node seen (1 is the limit).
  double speed_ratio_max() const noexcept { return speed_ratio_max_; }
  /// Largest tie stretch / its limit seen.
  double stretch_ratio_max() const noexcept { return stretch_ratio_max_; }
  /// The scene's bounding-box diagonal (m) at the start.
  double scene_size_m() const noexcept { return scene_size_m_; }
  /// √(2 |g| H) (m/s): the speed of a fall over the scene's height H.
  double fall_speed_mps() const noexcept { return fall_speed_mps_; }
  /// The hand's fastest speed so far (m/s).
  double hand_speed_max_mps() const noexcept { return hand_speed_max_mps_; }
  /// The push speed in v_ref (m/s): √(2 E_c0 / m_min) of the start's contacts, or what
  /// end_startup() left.
  double push_speed_mps() const noexcept { return push_speed_mps_; }
  /// The speed limit now: speed_factor × v_ref (m/s).
  double speed_limit_mps() const noexcept {
    return limits_.speed_factor * std::max({hand_speed_max_mps_, fall_speed_mps_,
                                            push_speed_mps_, limits_.speed_floor_mps});
  }
  /// The limits in force.
  const DivergenceLimits& limits() const noexcept { return limits_; }

 private:
  void latch(const char* cause, int body, int net, double value, double limit,
             std::int64_t period, double time_s) noexcept;
  /// The hand's work (J) through the coupling over the step that led from prev_ to `data`.
  double input_work(const core::Model& model, const core::Data& data) const noexcept;
  void remember(const core::Data& data) noexcept;
  void rebase(const core::Model& model, const core::Data& data) noexcept;

  DivergenceLimits limits_;
  double scene_size_m_ = 0.0;
  double fall_speed_mps_ = 0.0;            // √(2 |g| H)
  double hand_speed_max_mps_ = 0.0;
  double push_speed_mps_ = 0.0;            // √(2 E_c0 / m): the start's contacts, all in one body
  double contact0_ = 0.0;                  // the contacts' potential at the (re)base (J)
  std::vector<double> net_radius_m_;       // per net: max |rest offset| of its nodes
  std::vector<double> base_stretch_m_;     // per net: largest tie stretch at the (re)base
  std::vector<double> net_energy_;         // per net: its energy and gravity potential, last taken
  bool net_energy_taken_ = false;          // net_energy_ holds every net's
  std::vector<core::BodyState> prev_bodies_;
  std::vector<core::Pose> prev_targets_;   // per body: its coupling target in the last period
  std::vector<char> prev_coupled_;         // per body: it had a coupling target then
  int prev_held_ = -2;                     // -2: nothing observed yet
  double energy0_ = 0.0;                   // stored energy at the (re)base
  double gravity0_ = 0.0;                  // gravity's potential at the (re)base
  double work_in_ = 0.0;                   // W_in since the (re)base
  double energy_ratio_max_ = 0.0;
  double speed_ratio_max_ = 0.0;
  double stretch_ratio_max_ = 0.0;
  Divergence latched_;
};

}  // namespace numen::sim
