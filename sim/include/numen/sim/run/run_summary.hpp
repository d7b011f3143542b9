#pragma once
/// @file run_summary.hpp
/// What a run measured (RunSummary and its parts), and its text and JSON forms. The figures
/// of a summary are listed once in run_figures.hpp.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/platform/latency_histogram.hpp"
#include "numen/platform/loop_statistics.hpp"

namespace numen::sim {

struct Scene;

/// Percentiles of a duration distribution (µs).
struct DurationSummary {
  double median = 0.0;
  double p99 = 0.0;
  double p999 = 0.0;
  double max = 0.0;
  double mean = 0.0;
};

/// The percentiles of a histogram of durations in ns, converted to µs.
DurationSummary summarize_ns(const platform::LatencyHistogram& h);

/// The multirate god-object of a run (scene [multirate]; docs/multirate.md); all zero without.
struct MultirateSummary {
  bool enabled = false;          ///< The scene ran multirate.
  double scene_dt_s = 0.0;       ///< The scene loop's period (s).
  int ratio = 0;                 ///< Device periods per scene period.
  double margin_mm = 0.0;        ///< Proximity margin δ (mm).
  std::int64_t scene_steps = 0;  ///< Scene periods stepped.
  std::int64_t planes_max = 0;   ///< Most contact planes handed to the device loop at once.
  /// Contacts of the god-object the scene loop found beyond core::kMaxContactPlanes (summed
  /// over scene periods): surfaces the device loop did not see.
  std::int64_t planes_dropped = 0;
  /// Device periods that used planes older than one scene period (a late scene step); 0 in
  /// runs that interleave the loops on one thread.
  std::int64_t stale_models = 0;
  std::int64_t switches = 0;     ///< Tool switches the god-object followed.
  bool scene_thread = false;     ///< The scene loop ran on its own thread (a paced run).
  /// Scene periods on the scene thread that ended past the next deadline (a paced run).
  std::int64_t scene_overruns = 0;
  DurationSummary scene_step_us;  ///< Wall time of the scene steps on the scene thread (us).
  /// Largest change of the feedback force sent (N) into a period that took a new scene model
  /// (a scene-step boundary), and into any other period.
  double model_force_jump_max_n = 0.0;
  double other_force_jump_max_n = 0.0;
  /// Energy the new planes added at the samples (J; core::MultirateCounters::reset_energy),
  /// and the most one sample added.
  double reset_energy_j = 0.0;
  double reset_energy_max_j = 0.0;
  /// Scene steps taken in sub-steps because an organ's surface had folded under the tool
  /// (core::MultirateCounters::folded_scene_steps).
  std::int64_t folded_scene_steps = 0;
};

/// The divergence monitor of a run (divergence.hpp; docs/safety.md, "Divergence").
struct DivergenceSummary {
  bool latched = false;            ///< A breach latched: the run stopped (ExitStatus::kDiverged).
  /// "body speed", "node speed", "tie stretch", "energy" or "device plant" (an axis of the
  /// emulated device ran away, docs/device_plant.md).
  std::string cause;
  std::string subject;  ///< The body, the net or the device axis ("device axis N") that breached.
  double value = 0.0;   ///< The quantity (m/s, m or J; a device axis's speed: m/s or rad/s).
  double limit = 0.0;              ///< Its limit (same unit).
  double time_s = 0.0;             ///< Simulated time of the breach (s).
  std::int64_t period = -1;        ///< Its period (0-based).
  double speed_ratio_max = 0.0;    ///< Largest speed / its limit of a body or node (1: the limit).
  double stretch_ratio_max = 0.0;  ///< Largest tie stretch / its limit (0 without nets).
  /// Largest held energy / max(E₀ + W_in, floor) (0 where the coupling springs do not act).
  double energy_ratio_max = 0.0;
  double scene_size_m = 0.0;       ///< The scene's bounding-box diagonal at the start (m).
  double speed_limit_mps = 0.0;    ///< The speed limit at the end (10 × v_ref; m/s).
};

/// What a run of an admittance device measured (AdmittanceRunner; docs/outputs.md). Positions
/// are the controlled frame's origin (world): "device" where the emulated device is, "hand"
/// where the simulated hand wants it (the scene trajectory), "god-object" the held body's COM.
struct AdmittanceSummary {
  bool enabled = false;                  ///< The run was an admittance run.
  double measured_force_max_n = 0.0;     ///< Largest |measured force| that drove the god-object.
  double measured_torque_max_nm = 0.0;   ///< Largest |measured torque| (about the COM).
  double device_error_max_mm = 0.0;      ///< Largest |x_device − x_god-object|.
  double device_error_rms_mm = 0.0;      ///< Its RMS over the periods.
  double hand_separation_max_mm = 0.0;   ///< Largest |x_hand − x_device|.
  double final_measured_force_n = 0.0;   ///< |measured force| in the last period.
  double final_hand_separation_mm = 0.0; ///< |x_hand − x_device| in the last period.
  double k_hand = 0.0;                   ///< The hand's stiffness (N/m), for k_hand × separation.
  std::int64_t sensor_frames = 0;        ///< Force sensor TPDOs received.
  std::int64_t sensor_rejected_periods = 0;  ///< Periods whose reading was rejected.
  std::int64_t csp_rpdos = 0;            ///< csp RPDOs written.
  std::int64_t setpoints_clamped = 0;    ///< Set-points clamped to an axis range.
  std::int64_t setpoints_rate_limited = 0;  ///< Set-points limited to max_speed · dt.
  std::int64_t hold_periods = 0;         ///< Periods not active (drives disabled, god-object braked).
};

/// What a run measured. Penetrations are the deepest overlap (mm) of the
/// tool's spheres (the held body and the bodies jointed to it, and the node
/// spheres of the deformable nets whose rigid component is one of them) with
/// obstacles and other bodies; "target" is the same bodies placed at the
/// device's target poses (where the hand is) with their nets in their rest
/// shape, "tool" the god-object itself (its nets as deformed).
///
/// Start-up: the god-object starts where the hand is. When the hand starts
/// inside an obstacle, so does the tool, and the contact forces first push it
/// out. The start-up runs from the first period through the last period that
/// lowers the tool's penetration to a new minimum before kStartupSettle (run.hpp)
/// passes without a new minimum (or before a period without contact): the
/// push-out, whose pauses last a few periods (the default instrument spawned
/// 21 mm into the tissue: 90 periods, pauses of up to 6). Its depth is
/// startup_tool_penetration_mm (with a warning naming the obstacle), and
/// tool_penetration_max_mm covers every period after it.
/// One device's figures in a run of a scene of several devices (RunSummary::devices;
/// docs/outputs.md, "Several devices"). Device 0's are also the summary's own keys.
struct DeviceRunSummary {
  std::string name;                    ///< Its DeviceConfig::name (the scene's `name`).
  double feedback_force_max_n = 0.0;   ///< Largest |feedback force| sent to it (N).
  double feedback_torque_max_nm = 0.0; ///< Largest |feedback torque| sent to it (N·m).
  std::int64_t torque_periods = 0;     ///< Periods in which it was sent non-zero torque.
  std::int64_t invalid_periods = 0;    ///< Periods whose sample was not valid (target held).
  std::int64_t rejected_samples = 0;   ///< Its axis samples rejected by the checks.
  /// The same by cause ("1500 stale (older than max_sample_age, or none came), 2 implausible
  /// jump"; rejection_causes()); "" for none.
  std::string rejected_causes;
  std::int64_t faults = 0;             ///< Managed stack: its safe states latched.
  std::string lifecycle;               ///< Managed stack: its lifecycle state at the end.
  bool closed_loop = false;            ///< Its emulated device moved under its torques (a plant).
  double handle_force_max_n = 0.0;     ///< Closed loop: largest force of its hand on the handle (N).
  double hand_separation_max_mm = 0.0; ///< Closed loop: largest hand–handle separation (mm).
  double device_port_energy_j = 0.0;   ///< Closed loop: energy into its handle's port (J).
};

}  // namespace numen::sim

namespace numen::hal {
struct DeviceCounters;
}  // namespace numen::hal

namespace numen::sim {

/// The axis samples a device rejected, by cause, from its counters: "N stale (older than
/// max_sample_age, or none came)", "N implausible jump", "N out of range", "N malformed",
/// "N non-finite", the non-zero ones joined by ", "; "" when none was rejected.
std::string rejection_causes(const hal::DeviceCounters& c);

/// The text line of one device (RunSummary::device_lines): "NAME: feedback force max F N, ...".
std::string format_device_line(const DeviceRunSummary& d);

/// The figures of a scene's [task] (summarize_task(); docs/outputs.md, "task.*").
struct TaskSummary {
  bool enabled = false;           ///< The scene has a [task].
  std::int64_t objects = 0;       ///< Objects the task names.
  /// Objects placed (let go by a release, held by no grasper, and resting within `reach` of a
  /// peg at the end) after at least one hand-over: the task's transfers.
  std::int64_t transferred = 0;
  std::int64_t placed = 0;        ///< Objects placed, handed over or not.
  /// Hand-overs: a grasper let an object go while another held it.
  std::int64_t handovers = 0;
  /// Drops: an object let go (released or slipped) with no other grasper holding it, but for
  /// the release that placed it.
  std::int64_t drops = 0;
  /// The task's time (s): from the first grasp of an object to the last placement (0: none placed).
  double time_s = 0.0;
  /// Per object: "NAME: 2 grasps, 1 hand-over, 0 drops; placed on PEG at T s" (or where it ends).
  std::vector<std::string> lines;
};

/// Most passes a needle's marks name and its run's figures record (`entry_mark`, `exit_mark`;
/// NeedleRunFigures::passes).
inline constexpr std::size_t kMaxNeedlePasses = 8;

/// One pass of a needle through tissue: an entry and, once it went through, the exit that
/// followed it. Material points at rest (m, world: the punctured triangle's rest nodes by the
/// point's weights) and their times (s; −1: none).
struct NeedlePassFigures {
  std::array<double, 3> entry{}, exit{};
  double entry_s = -1.0, exit_s = -1.0;
};

/// One needle's passage over a run (needle_summary.hpp; docs/suturing.md, "The needle through
/// tissue"), accumulated step by step.
struct NeedleRunFigures {
  std::string name;
  std::int64_t punctures = 0;          ///< Entries (core::NeedleState::punctures_made).
  std::int64_t exits = 0;              ///< Exits.
  std::int64_t releases = 0;           ///< Puncture points let go.
  std::int64_t tunnels = 0;            ///< Steps its tip crossed tissue inwards without a puncture.
  /// Steps its tip was held back at tissue its step would have taken it through
  /// (core::NeedleState::tunnels_stopped).
  std::int64_t tunnels_stopped = 0;
  double first_tunnel_s = -1.0;        ///< Time of the first tunnel (s; −1: none).
  double puncture_tip_force_n = 0.0;   ///< Its tip's force along it at its last puncture (N).
  /// What the tip's contacts asked there before the tissue gave way at the threshold (N;
  /// core::NeedleState::puncture_contact_force).
  double puncture_contact_force_n = 0.0;
  double puncture_force_n = 0.0;       ///< Its threshold (NeedleModel::puncture_force; 0: none).
  double deviation_max_mm = 0.0;       ///< Largest deviation of a puncture point from its arc (mm).
  /// Its passes in order, [0, num_passes): each entry starts one; an entry drawn back out before
  /// an exit (every point let go, or a new entry) is replaced by the next; an exit ends the open
  /// pass (a pass through). Entries past kMaxNeedlePasses are counted in passes_lost.
  std::array<NeedlePassFigures, kMaxNeedlePasses> passes{};
  std::size_t num_passes = 0;
  std::int64_t passes_lost = 0;
  /// The scene's marks (`entry_mark`, `exit_mark`, m, world), one per pass, if given.
  std::vector<std::array<double, 3>> entry_marks, exit_marks;
};

struct RunSummary {
  std::string scene;
  std::string coupling;
  std::string integrator;
  std::int64_t steps = 0;
  double dt_s = 0.0;
  double sim_time_s = 0.0;
  double wall_time_s = 0.0;
  DurationSummary step_time_us;            ///< Wall time of core::step per period.
  /// Deepest overlap of the target: the tool's bodies where the encoders put them (the hand in
  /// replay, the device's handle in closed loop), mm.
  double target_penetration_max_mm = 0.0;
  /// The device: "replay" (the encoders read the trajectory, whatever the torques), "closed"
  /// (the emulated device moves under the drives' torques and the hand: [device.plant]),
  /// "external" (--bus on a real bus or a log: the device is not this process's) or
  /// "admittance" (AdmittanceRunner's emulated device).
  std::string device_loop = "replay";
  bool closed_loop = false;                ///< device_loop is "closed".
  /// Closed loop: the held body where the hand means to be (the trajectory), mm deep.
  double hand_penetration_max_mm = 0.0;
  /// Where the device's handle is (its encoders): the same quantity as
  /// target_penetration_max_mm, under the closed loop's name, mm.
  double device_penetration_max_mm = 0.0;
  /// Closed loop (PlantMotion::figures()): the largest force of the hand on the handle (N), the
  /// energy the hand put into the device (J: final, minimum and when), the largest hand–handle
  /// separation (mm), and the handle's limit cycle (LimitCycleDetector).
  double handle_force_max_n = 0.0;
  double device_port_energy_j = 0.0;
  double device_port_energy_min_j = 0.0;
  double device_port_energy_min_time_s = 0.0;
  double hand_separation_max_mm = 0.0;
  bool limit_cycle_detected = false;
  double limit_cycle_amplitude_mm = 0.0;
  double limit_cycle_hz = 0.0;
  double limit_cycle_time_s = 0.0;
  double tool_penetration_max_mm = 0.0;    ///< God-object, after the start-up (see above).
  /// The god-object's penetration at the first period when it starts inside an obstacle (mm;
  /// the deepest of the start-up); 0 when it starts free.
  double startup_tool_penetration_mm = 0.0;
  std::int64_t startup_steps = 0;          ///< Periods of the start-up (0: the tool started free).
  double any_penetration_max_mm = 0.0;     ///< Deepest contact of any body this run.
  /// |x_tool − x_target| (held body's origin) RMS over the free-space steps: steps where
  /// neither the tool nor the target (the hand) touches anything.
  double tracking_error_free_rms_mm = 0.0;
  double tracking_error_free_max_mm = 0.0; ///< Largest of the same (mm).
  std::int64_t free_steps = 0;             ///< Steps counted in the free-space error.
  double feedback_force_max_n = 0.0;       ///< Largest |feedback force| sent (after saturation).
  /// Largest |F_k − F_{k−1}| of the feedback force sent between consecutive periods (N).
  double feedback_force_jump_max_n = 0.0;
  /// The device's soft start (hal::DeviceConfig::soft_start_s, s; 0: off): the feedback ramps
  /// in over this time at start-up and after every re-arm.
  double soft_start_s = 0.0;
  /// Soft-start ramps run (hal::TorqueCounters::soft_starts: the start-up's and one per
  /// activation after a re-arm that enabled torque again).
  std::int64_t soft_start_ramps = 0;
  /// The device's time-domain passivity controller runs (hal::DeviceConfig::passivity;
  /// scene `[device.passivity]`, docs/passivity.md "Passivity controller").
  bool passivity_controller = false;
  /// Periods in which it added damping on some axis (hal::PassivityCounters::acting_periods).
  std::int64_t passivity_acting_periods = 0;
  /// Energy its dampers dissipated, J (hal::PassivityCounters::dissipated_j).
  double passivity_dissipated_j = 0.0;
  double feedback_torque_max_nm = 0.0;
  double axis_torque_max = 0.0;            ///< Largest |axis torque| commanded (N·m or N).
  double free_body_speed_max_mps = 0.0;    ///< Fastest body not part of the held tool (m/s): blocks thrown about.
  int num_bodies = 0;
  int num_joints = 0;
  double joint_drift_max_mm = 0.0;         ///< Largest linear joint error |C| after a step (mm).
  double joint_angle_drift_max_mrad = 0.0; ///< Largest angular joint error |C| after a step (mrad).
  std::int64_t rejected_samples = 0;       ///< Axis samples rejected by the checks.
  /// The same by cause (DeviceRunSummary::rejected_causes); "" for none.
  std::string rejected_causes;
  std::int64_t invalid_periods = 0;        ///< Periods whose sample was not valid (target held).
  /// Stretches of consecutive periods whose sample (device 0's) was stale: an input that stalled
  /// or went silent for longer than max_sample_age (a warning says the longest).
  std::int64_t stale_stretches = 0;
  std::int64_t stale_periods = 0;          ///< Periods whose sample was stale, all stretches.
  double stale_longest_s = 0.0;            ///< The longest stretch, s (periods × dt).
  double stale_longest_from_s = 0.0;       ///< Simulated time of its first period, s.
  /// Times the samples came back valid after stale ones and the loop glided the target to the
  /// resumed pose and ramped the feedback in again (live inputs;
  /// platform::ControlLoopSettings::rejoin_after_stale).
  std::int64_t stale_rejoins = 0;
  double stale_rejoin_gap_mm = 0.0;        ///< The largest gap those glides bridged, mm.
  double stale_rejoin_gap_deg = 0.0;       ///< ... and angle, degrees.
  std::int64_t contact_overflow = 0;       ///< Steps that ran out of contact capacity.
  /// Steps with a contact whose stiffness the time-constant floor lowered
  /// (core::Data::contact_clamped_steps; core::SolverSettings::contact_max_omega_dt).
  std::int64_t contact_clamped_steps = 0;
  /// Steps in which a sphere pair of two bodies (e.g. the two instruments' jaws) had its centres
  /// past each other and was pushed back along its approach normal
  /// (core::Data::crossed_contact_steps; docs/dynamics.md, "Crossing").
  std::int64_t crossed_contact_steps = 0;
  /// Sphere pairs of two bodies that went through each other: left contact with their centres
  /// past each other (core::Data::pass_throughs). A warning names the first.
  std::int64_t pass_throughs = 0;
  double first_pass_through_s = -1.0;  ///< Simulated time of the first, s; −1: none.
  int contacts_max = 0;           ///< Rigid sphere contacts in one step (node contacts apart).
  int solver_iterations_max = 0;  ///< Iterations of the implicit solve in one step.
  double solver_iterations_mean = 0.0;  ///< Mean over the steps.
  double solver_residual_max = 0.0;  ///< Largest Data::solver_residual of a step.
  /// Steps whose implicit solve ended at max_iterations above the tolerance.
  std::int64_t solver_not_converged_steps = 0;
  // Deformable nets (paper §4.2); all zero without nets.
  int num_nets = 0;
  int num_nodes = 0;
  int node_contacts_max = 0;            ///< Node contacts in one step (all nets).
  /// Deepest node contact of any net, crossed ones included (mm).
  double net_penetration_max_mm = 0.0;
  /// Multirate scene steps in which a sphere of the god-object was past a net's surface
  /// (core::Data::net_crossed_steps: those contacts dropped, their depth in
  /// net_penetration_max_mm); 0 single-rate.
  std::int64_t net_crossed_steps = 0;
  double net_tie_stretch_max_mm = 0.0;  ///< Largest |x − a| of a node from its rest position (mm).
  double net_strain_max = 0.0;  ///< Largest |l − L|/L of a structural spring (dimensionless).
  double net_node_speed_max_mps = 0.0;  ///< Fastest node (m/s).
  /// An organ given by its material: most of its tetrahedra turned inside out (or flat) at a
  /// step's end (core::NetOutput::inverted_tetrahedra), over the run and the nets; the first
  /// time any was (s, −1: never) and that net's name. Any is a warning (docs/tissue.md,
  /// "Inversion").
  std::int64_t net_inverted_tetrahedra_max = 0;
  double net_first_inversion_s = -1.0;
  std::string net_first_inversion_net;
  bool nan_detected = false;
  std::int64_t nonfinite_steps = 0;
  /// Steps whose device target was not finite (core::Data::invalid_target_steps): coupling
  /// skipped, feedback held at its last value.
  std::int64_t invalid_target_steps = 0;
  // Suture threads (docs/thread.md; accumulate_thread_figures(), summarize_threads()).
  bool threads = false;                  ///< The scene has a thread ([[thread]]).
  double thread_tension_max_n = 0.0;     ///< Largest segment tension of any thread over the run (N).
  double thread_tension_max_s = -1.0;  ///< When (s; −1: no thread).
  double thread_stretch_max = 0.0;       ///< Largest segment strain of any thread over the run.
  std::int64_t thread_breaks = 0;        ///< Threads that broke (a pull past break_strain).
  double thread_first_break_s = -1.0;    ///< Time of the first break (s; −1: none).
  /// Steps in which a thread's Newton iteration ran out of its iterations and took the last
  /// iterate (core::ThreadOutput::converged false for any thread).
  std::int64_t thread_newton_not_converged_steps = 0;
  /// Puncture points the threads took over from their needles as eyelets on tissue (core::
  /// ThreadState::eyelets_taken, summed), those let go as a free end slid out, and those dropped
  /// for want of a free eyelet (each thread's a warning).
  std::int64_t thread_eyelets_taken = 0;
  std::int64_t thread_eyelets_let_go = 0;
  std::int64_t thread_eyelets_dropped = 0;
  // Suture needles (docs/suturing.md; begin_needle_figures(), accumulate_needle_figures(),
  // summarize_needles()): sums over the needles, their lines.
  bool needles = false;                  ///< The scene has a needle ([[needle]]).
  std::vector<NeedleRunFigures> needle_runs;  ///< Per needle (Model::needles order).
  std::int64_t needle_punctures = 0;     ///< Entries of all needles.
  std::int64_t needle_exits = 0;         ///< Exits.
  std::int64_t needle_releases = 0;      ///< Puncture points let go.
  std::int64_t needle_tunnels = 0;       ///< Tunnels (each needle's a warning; exit status 7).
  std::int64_t needle_tunnels_stopped = 0;  ///< Steps a needle's tip was held back at tissue.
  std::int64_t needle_passes = 0;        ///< Passes that went through (an entry, then an exit), all needles.
  double needle_puncture_tip_force_n = 0.0;  ///< Tip force at the run's last puncture (N).
  double needle_puncture_contact_force_n = 0.0;  ///< What its contacts asked there (N).
  double needle_puncture_force_n = 0.0;  ///< That needle's threshold (N).
  double needle_deviation_max_mm = 0.0;  ///< Largest deviation of a puncture point from its arc (mm).
  /// Largest force the needles and their threads put on the tissue over the run (N): |Σ F| over
  /// the needles' puncture ties and the threads' eyelets on and contacts with tissue, their held node springs
  /// (Data::num_node_needle_ties, num_node_thread_ties) at each step, all nets together.
  double needle_tissue_force_max_n = 0.0;
  double needle_tissue_force_max_s = -1.0;  ///< When (s; −1: never any force on the tissue).
  bool needle_marks = false;             ///< A needle has an entry_mark or exit_mark.
  /// Largest distance of a needle's k-th pass's entry (exit) from its k-th mark, over the marked
  /// passes of all needles (mm; −1: a marked pass that never went in, or never came out).
  double needle_entry_error_mm = -1.0;
  double needle_exit_error_mm = -1.0;
  /// Per needle: "NAME: 1 puncture, 1 exit, ...; through; ..." (summarize_needles()).
  std::vector<std::string> needle_lines;
  // The hands' sight (`[device.trajectory.servo]`; hand_servo.hpp, docs/suturing.md "The
  // drivers' sight"): over the devices whose hand has a servo.
  bool servos = false;                       ///< A device's hand has a servo.
  double servo_offset_max_mm = 0.0;          ///< Largest correction of a hand (mm).
  double servo_error_max_mm = 0.0;           ///< Largest error a servo saw while aimed (mm).
  std::int64_t servo_saturated_periods = 0;  ///< Periods a hand's correction was clamped.
  /// Per servo: "DEVICE watches BODY: offset max … mm, error max … mm, saturated … periods".
  std::vector<std::string> servo_lines;
  // Grasping (docs/grasping.md; summarize_grasps()): sums over the scene's graspers.
  bool grasping = false;                 ///< The scene has a grasper ([[grasp]]).
  std::int64_t grasps_started = 0;       ///< Grasps that started.
  std::int64_t grasps_released = 0;      ///< Grasps the jaws' opening ended.
  std::int64_t grasps_slipped = 0;       ///< Grasps that slipped (pull past max_force).
  /// Each grasper's logged events, "6.961 s grasp grasper: organ (7 nodes)" (format_grasp_event()).
  std::vector<std::string> grasp_events;
  /// Per grasper (summarize_graspers()), in [[grasp]] order: "NAME (device D): …" with its own
  /// counts, the hand-overs it gave and took and the largest feedback force on its device's hand.
  std::vector<std::string> grasper_lines;
  /// The scene's [task] (task_summary.hpp; docs/grasping.md "Peg transfer"): what became of
  /// each object, from the graspers' logs and the objects' final poses.
  TaskSummary task;
  /// Per device of a scene of several (docs/scenes.md "Several devices"), device 0 first;
  /// empty for one device. The JSON summary's `devices` array.
  std::vector<DeviceRunSummary> devices;
  /// The text summary's line of each of `devices` (format_device_line()); empty for one device.
  std::vector<std::string> device_lines;
  std::int64_t bus_frames_dropped = 0;
  std::int64_t bus_frames_corrupted = 0;
  std::string bus = "sim";                 ///< BusChoice::spec of the run.
  std::int64_t bus_frames_replayed = 0;    ///< log: records read by the controller.
  std::int64_t bus_log_records = 0;        ///< log: frame records in the file.
  std::int64_t bus_log_lost_frames = 0;    ///< log: frames the recording itself lost (DROPCOUNT notes).
  std::int64_t bus_log_out_of_order = 0;   ///< log: records earlier than a record before them
                                           ///< (another interface or direction).
  // --bus igtl: the OpenIGTLink tracker (igtl_run.hpp, docs/openigtlink.md); empty / 0 otherwise.
  std::string igtl;                        ///< igtl: "HOST:PORT 'DEVICE'"; empty on other buses.
  std::int64_t igtl_messages = 0;          ///< igtl: messages read (every type and name).
  std::int64_t igtl_poses = 0;             ///< igtl: the tool's TRANSFORMs accepted.
  std::int64_t igtl_poses_taken = 0;       ///< igtl: ... taken by the controller's SYNCs.
  std::int64_t igtl_other_devices = 0;     ///< igtl: good TRANSFORMs of other device names.
  std::int64_t igtl_ignored = 0;           ///< igtl: other known message types, skipped.
  std::int64_t igtl_faults = 0;            ///< igtl: messages rejected (igtl_fault_records).
  std::int64_t igtl_dropped = 0;           ///< igtl: poses dropped by a full queue (paced).
  std::int64_t igtl_connects = 0;          ///< igtl: connections made.
  std::int64_t igtl_connect_failures = 0;  ///< igtl: connection attempts refused / timed out.
  std::int64_t igtl_disconnects = 0;       ///< igtl: connections lost.
  std::int64_t igtl_wait_timeouts = 0;     ///< igtl: SYNCs whose wait for the tracker ran out.
  std::int64_t igtl_syncs_without_pose = 0;  ///< igtl: SYNCs before the first pose.
  /// igtl: poses refused for their timestamps (hal::IgtlBusCounters): stamped before the last
  /// pose taken, more than 10 s after it (IgtlTrackerSettings::max_stamp_gap_ns), unstamped
  /// (following the tracker's clock); and the re-basings on a clock that jumped.
  std::int64_t igtl_stamps_backwards = 0;
  std::int64_t igtl_stamps_ahead = 0;
  std::int64_t igtl_stamps_unstamped = 0;
  std::int64_t igtl_stamp_resyncs = 0;
  /// igtl: re-basings on the first pose after a silence that would have come stale (a sender
  /// that paused; hal::IgtlBusCounters::silence_rebases).
  std::int64_t igtl_silence_rebases = 0;
  /// igtl: the run followed the tracker's clock (offline: a replay's end is the stream's end);
  /// false: paced (a live tracker: a lost connection is a fault).
  bool igtl_follows = false;
  /// igtl: periods that found the stream over (every pose taken, the receiver ended).
  std::int64_t igtl_periods_after_end = 0;
  /// igtl: the first message of each fault kind: "CRC mismatch: TRANSFORM 'Stylus', message 3
  /// at stream byte 318, field at byte 50 (2 such)".
  std::vector<std::string> igtl_fault_records;
  std::vector<std::string> igtl_names_seen;  ///< igtl: other TRANSFORM device names (≤ 8).
  /// igtl: from a TRANSFORM received to the SYNC that applied it (µs).
  DurationSummary igtl_latency_us;
  std::int64_t bus_frames_recorded = 0;    ///< --record: frames queued for the log.
  std::int64_t bus_record_dropped = 0;     ///< --record: lost to a full queue (paced runs).
  std::int64_t bus_record_written = 0;     ///< --record: lines the writer thread wrote.
  std::int64_t bus_record_io_errors = 0;   ///< --record: failed writes / flushes (disk full).
  std::int64_t bus_record_format_errors = 0;  ///< --record: records that could not be formatted.
  bool view_streamed = false;              ///< The state stream ran (--record-view, --view).
  bool view_recorded = false;              ///< ... into a view recording (--record-view).
  std::int64_t view_frames_published = 0;  ///< Frames queued by the loop.
  std::int64_t view_frames_decimated = 0;  ///< Periods left out by the display rate.
  std::int64_t view_frames_dropped = 0;    ///< Due frames lost: every buffer was in use.
  std::int64_t view_frames_delivered = 0;  ///< Frames handed to the consumers.
  std::int64_t view_bytes = 0;             ///< Bytes of the frames delivered.
  std::int64_t view_sink_errors = 0;       ///< Consumer refusals (write or flush failures).
  std::int64_t view_record_frames = 0;     ///< --record-view: frames in the file.
  std::int64_t view_record_io_errors = 0;  ///< --record-view: failed writes / flushes / close.
  std::int64_t realtime_overruns = 0;      ///< Paced periods (--realtime) that began after their deadline.
  std::int64_t realtime_missed_periods = 0;  ///< Whole periods skipped to re-phase after overruns.
  /// RunOptions::overrun_limit in effect: consecutive overruns that latch (0: counted only, as
  /// in an unpaced run or a minimal-protocol one, whose loop does not supervise overruns).
  std::uint32_t overrun_limit = 3;
  DurationSummary wakeup_latency_us;       ///< Paced runs: wake-up time − deadline (µs).
  /// RunOptions::rt outcome, one line per step plus the kernel and the limits
  /// (platform::describe()); empty when nothing was requested.
  std::vector<std::string> realtime_setup;
  // Device lifecycle and safety (managed CANopen stack; docs/safety.md). Minimal protocol:
  // managed = false and the rest at their defaults.
  bool managed = false;                    ///< The device ran the managed CANopen stack.
  std::string startup;                     ///< Start-up phase at the end ("operational",
                                           ///< "failed (node 3)", ...).
  std::int64_t periods_to_operational = -1;  ///< Period index at which every node was heard
                                             ///< operational (-1: never).
  std::int64_t periods_to_active = -1;     ///< Period index at which the lifecycle became active.
  std::int64_t periods_to_torque = -1;     ///< Period index of the first non-zero torque command.
  std::string lifecycle;                   ///< Lifecycle state at the end.
  std::int64_t faults = 0;                 ///< Safe states latched.
  std::int64_t fault_records = 0;          ///< Fault records written (latching or not).
  std::string first_fault;                 ///< Cause of the first latched fault ("" if none).
  int first_fault_id = 0;                  ///< Its axis / node / drive (FaultRecord::id).
  double first_fault_value = 0.0;          ///< Its value (FaultRecord::value).
  double first_fault_time_s = 0.0;         ///< Its bus time, s.
  std::int64_t first_fault_period = -1;    ///< Its period index.
  std::int64_t emcys = 0;                  ///< EMCY messages received.
  std::int64_t emcy_faults = 0;            ///< ... of which reported a fault.
  std::int64_t configured_nodes = 0;       ///< Node configurations from a DCF completed (read back
                                           ///< equal) at start-ups.
  std::int64_t sdo_reads = 0;              ///< In-loop SDO reads completed (canopen.sdo_poll_period).
  std::int64_t sdo_read_errors = 0;        ///< ... aborted by a node or timed out.
  std::int64_t heartbeat_losses = 0;       ///< Heartbeat losses over all nodes.
  std::int64_t zero_torque_periods = 0;    ///< Periods that commanded zero torque on every drive.
  /// zero_torque_periods by cause, each period counted once, under the first that applies in
  /// this order (they sum to zero_torque_periods): a safe state latched; the loop shutting
  /// down (end of a real-bus run); the device not yet active (start-up: NMT, CiA 402
  /// enabling); every axis gated by the device (no valid sample, torque not yet allowed, a
  /// non-finite τ); the soft start's ramp scaling τ to under half a per mille of rated torque;
  /// the gate open and every τ under half a per mille of its rated torque (the tool in free
  /// space or barely touching: below the drives' resolution).
  std::int64_t zero_torque_safe_state = 0;
  std::int64_t zero_torque_shutdown = 0;         ///< See zero_torque_safe_state.
  std::int64_t zero_torque_startup = 0;          ///< See zero_torque_safe_state.
  std::int64_t zero_torque_gated = 0;            ///< See zero_torque_safe_state.
  std::int64_t zero_torque_soft_start = 0;       ///< See zero_torque_safe_state.
  std::int64_t zero_torque_below_resolution = 0; ///< See zero_torque_safe_state.
  std::vector<std::string> drive_states;   ///< "axis: CiA 402 state" per drive at the end.
  /// The EMCY messages the master still holds at the end (its log keeps the last 16), oldest
  /// first: "node 3 at 1.234 s: 0x4310 <CiA 301 name> (register 0x09)"; an error reset says
  /// "no error / reset".
  std::vector<std::string> emcy_messages;
  // Real buses (can:, serial:) — zeros / empty otherwise.
  bool real_bus = false;                   ///< The controller ran on a real bus, paced.
  hal::BusCounters port;                   ///< Counters of the controller's port (rx, tx,
                                           ///< dropped, errors, would-block).
  std::string transport;                   ///< describe_transport_counters() of the port.
  std::string bus_state;                   ///< Port state at the end (hal::to_string(BusState)).
  std::int64_t bus_error_periods = 0;      ///< Periods whose port state was not kOk or that
                                           ///< saw a read / write error (link down, bus off).
  std::int64_t read_errors = 0;            ///< ControlLoopCounters::read_errors.
  std::int64_t sync_write_failures = 0;    ///< ControlLoopCounters::sync_write_failures.
  std::int64_t command_failures = 0;       ///< ControlLoopCounters::command_failures.
  std::int64_t frames_rejected = 0;        ///< Encoder frames of a wrong length / kind, frames of
                                           ///< no known id, malformed drive TPDOs (InstrumentDevice
                                           ///< and CanopenMaster counters).
  std::int64_t frames_unknown_id = 0;      ///< ... of which of an id no axis has.
  /// Encoder frames rejected (on an encoder's 11-bit COB-ID, InstrumentDevice): CAN FD frames,
  /// remote requests, classic data frames of a wrong length. Part of frames_rejected; each
  /// rejects its axis's sample for the period (docs/inputs.md).
  std::int64_t encoder_frames_fd = 0;
  std::int64_t encoder_frames_remote = 0;
  std::int64_t encoder_frames_wrong_length = 0;
  std::int64_t error_frames = 0;           ///< Controller error reports the device ignored
                                           ///< (never decoded as PDOs; docs/protocol.md).
  std::int64_t values_out_of_range = 0;    ///< Axis values rejected as out of [min, max].
  std::int64_t values_jump = 0;            ///< Axis values rejected as implausible jumps.
  platform::LoopSummary loop;              ///< LoopStatistics of the periods (paced runs).
  std::int64_t last_device_frame_period = -1;  ///< Last period that read a frame (-1: none).
  std::int64_t last_torque_stop_period = -1;   ///< Last period whose torque was zero after a
                                               ///< period with torque (the last safe stop).
  /// The trace (--trace): a real bus streams it (TraceWriter: records queued, refused by a full
  /// queue, written, failed writes); a simulated run keeps it in memory and writes it after the
  /// run (write_in_memory_trace(): records taken, refused by a full store, written, 1 failure).
  std::int64_t trace_pushed = 0;           ///< Trace: records queued / taken.
  std::int64_t trace_dropped = 0;          ///< ... refused by a full queue (must be 0).
  std::int64_t trace_written = 0;          ///< ... lines written to the file.
  std::int64_t trace_io_errors = 0;        ///< ... failed writes / flushes (disk full).
  /// `numen run`: why its summary could not be written on stdout (the system's reason: "Broken
  /// pipe", "No space left on device", "Bad file descriptor" for a closed stdout); empty: it
  /// was, or has not been tried. Set after the run by the command, then judge_run() again:
  /// lost records (docs/outputs.md, "Standard output").
  std::string stdout_error;
  bool stopped = false;                    ///< Ended early by RunOptions::stop (signal).
  int stop_signal = 0;                     ///< ... by this signal (RunOptions::stop_signal; 0: unknown).
  std::int64_t rearm_requests = 0;         ///< RunOptions::rearm requests taken.
  std::int64_t rearms_accepted = 0;        ///< Of these, ControlLoop::rearm() kAccepted.
  std::int64_t rearm_first_period = -1;    ///< Period before which the first request was taken.
  std::int64_t shutdown_periods = 0;       ///< Periods run to shut down.
  bool drives_disabled = false;            ///< Every drive disabled at the end of the shutdown.
  std::vector<std::string> warnings;
  std::string trocar_note;
  /// Admittance device runs only (enabled = true); the impedance-only fields above stay 0.
  AdmittanceSummary admittance;
  MultirateSummary multirate;
  DivergenceSummary divergence;
  /// The run's exit status (run_verdict(): ExitStatus as int, 0 clean; 128 + stop_signal for
  /// a run a signal stopped that is otherwise clean) and every condition behind it, most
  /// severe first; set by run_scene(). The status the `numen run` process returns.
  int exit_status = 0;
  std::vector<std::string> exit_reasons;
};

/// Fills what a run's summary says of its scene, whichever runner runs it: name, coupling,
/// integrator, dt, the scene's warnings and trocar note, the numbers of bodies, joints, nets
/// and net nodes.
void describe_scene(const Scene& scene, RunSummary& s);

/// Readable multi-line summary: the layout of run_summary_text.hpp, whose placeholders are
/// figures of run_figures() (run_summary_text.cpp).
std::string format_summary(const RunSummary& s);
/// Exactly one JSON object (no trailing newline): every figure of run_figures() in the table's
/// order, dotted names as nested objects, non-finite numbers as null (run_summary_json.cpp).
std::string format_summary_json(const RunSummary& s);

}  // namespace numen::sim
