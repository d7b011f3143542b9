#pragma once
/// @file trace.hpp
/// Per-step trace of a run (`numen run --trace FILE.csv`): target pose (the
/// device), god-object pose, contacts, penetrations, feedback wrench, axis
/// torques, step time, the implicit solve, the joints' drift, reactions and
/// Baumgarte terms and the deformable nets' contacts, stretch and strain.
/// Records go into storage reserved before the loop
/// (push never allocates; a full trace counts the records it drops) and are
/// written as CSV after the run.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/platform/control_loop.hpp"

namespace numen::sim {

/// Devices beside device 0 a trace record carries (platform::kMaxLoopDevices − 1).
inline constexpr int kMaxTraceExtraDevices = 3;

/// A device other than device 0 in one period, in a scene of several (docs/outputs.md, "Trace
/// columns": the columns `<name>@<device>`). Its body is the one its `tool` link drives, else the
/// first body its links drive that has spheres (SceneRunner; -1: none, the pose columns read 0).
/// Single precision (a trace holds one record per period of the whole run, reserved up front:
/// 40 bytes a device; 0.1 m to 6 nm): what a trace shows, not a state to restart from.
struct DeviceTraceRecord {
  std::array<float, 3> target{};          ///< Its body's coupling target (m, world).
  std::array<float, 3> tool{};            ///< Its body's position (m, world).
  std::array<float, 3> feedback_force{};  ///< Eq. 8 force sent to it (N, world).
  bool sample_valid = false;              ///< Its period's sample was valid.
};

/// One control period. World frame, SI units except where the name says mm/µs.
struct TraceRecord {
  double time_s = 0.0;
  int held_body = -1;
  // What the control loop did (platform::PeriodReport).
  int frames_read = 0;            ///< Frames taken from the bus this period.
  bool sample_valid = false;      ///< Every axis fresh and plausible this period.
  bool torque_commanded = false;  ///< Non-zero torque was commanded on a drive.
  int lifecycle = 0;              ///< hal::LifecycleState value after the period.
  core::Pose target;                 ///< Device target of the held body's COM frame.
  core::Pose tool;                   ///< Held body's pose (zero when none).
  int contacts = 0;                  ///< All contacts this step.
  int tool_contacts = 0;             ///< Contacts of the held body.
  double tool_penetration_mm = 0.0;
  double target_penetration_mm = 0.0;
  /// Closed loop (docs/device_plant.md; 0 in replay): the tool's depth where the hand means it
  /// to be, the force of the hand on the handle (N) and the energy the hand has put into the
  /// device so far (J).
  double hand_penetration_mm = 0.0;
  double handle_force_n = 0.0;
  double device_port_energy_j = 0.0;
  core::Wrench feedback;             ///< Eq. 8, sent to the device (N, N·m).
  std::array<double, hal::kMaxAxes> axis_torque{};  ///< N·m or N.
  int num_axes = 0;
  double step_time_us = 0.0;       ///< Wall time of core::step.
  double end_to_end_us = 0.0;      ///< SYNC sent to the torque writes returned.
  double wakeup_latency_us = 0.0;  ///< Wake-up time − deadline (paced runs).
  int solver_iterations = 0;
  // Articulation (zero without joints), paper Eq. 4–5.
  double joint_drift_mm = 0.0;            ///< Largest linear joint error |C| after the step.
  double joint_angle_drift_mrad = 0.0;    ///< Largest angular joint error |C| after the step.
  double joint_reaction_max_n = 0.0;      ///< Largest |reaction force| of a joint on its child (N).
  double baumgarte_rhs_max = 0.0;         ///< Largest |c| of a joint row (m/s or rad/s): the Baumgarte correction asked.
  // Deformable nets (zero without nets), paper §4.2; all nets together.
  int node_contacts = 0;            ///< Node contacts this step.
  double net_penetration_mm = 0.0;  ///< Deepest node contact this step.
  double net_tie_stretch_mm = 0.0;  ///< Largest |x − a| of a node from its rest position.
  double net_strain_max = 0.0;      ///< Largest |l − L|/L of a structural spring.
  double solver_residual = 0.0;     ///< Data::solver_residual: the solve's stopping measure.
  // CANopen EMCY (zero without a managed CANopen device), CiA 301 §7.2.7.
  int emcys = 0;          ///< EMCY messages received this period.
  int emcy_node = 0;      ///< Node id of the newest of them (0: none this period).
  int emcy_code = 0;      ///< Its emergency error code (0: none); named in the summary's EMCY list.
  /// Graspers holding a body, a thread or tissue after the step (core::GraspState::holding(); a grasp, a
  /// release or a slip changes it; the summary's grasp.events names each).
  int grasps_held = 0;
  // Threads and needles (zero without them; docs/thread.md, docs/suturing.md): all threads or
  // needles together.
  double thread_tension_n = 0.0;   ///< Largest segment tension after the step (N).
  double thread_stretch = 0.0;     ///< Largest segment strain (l − l0)/l0 after the step.
  /// Contacts of the threads this step: with bodies' spheres, obstacles, tissue and themselves.
  int thread_contacts = 0;
  int thread_newton_iterations = 0;  ///< Most Newton iterations a thread's step took.
  /// Threads whose step's Newton iteration ran out of its iterations (core::ThreadOutput::converged).
  int thread_unconverged = 0;
  /// Force of the tissue on a needle's tip against its tangent this step (N; > 0 resists the tip
  /// going forward; core::NeedleState::tip_force), the largest of the needles.
  double needle_tip_force_n = 0.0;
  int needle_points = 0;  ///< Puncture points the needles hold after the step (entries and exits).
  /// The step's needle event (core::PunctureEvent: 0 none, 1 puncture, 2 exit, 3 release; the
  /// last needle's with one).
  int needle_event = 0;
  /// Devices 1 .. num_extra_devices of a scene of several, in order (empty for one device).
  std::array<DeviceTraceRecord, kMaxTraceExtraDevices> devices{};
  int num_extra_devices = 0;
};

/// Builds a record from the state after a step: `report.feedback` is the feedback wrench whose
/// torques were sent (platform::PeriodReport), `axis_torques` the torques sent (N·m or N per
/// axis: hal::DeviceOutput::torque, the device face's; empty for a device that sends none).
TraceRecord make_trace_record(const core::Data& data, int held, int tool_contacts,
                              double tool_penetration_m, double target_penetration_m,
                              const platform::PeriodReport& report,
                              std::span<const double> axis_torques) noexcept;

/// Fixed-capacity store of records.
class Trace {
 public:
  /// Allocates room for `capacity` records.
  void reserve(std::size_t capacity) { records_.reserve(capacity); }
  /// Appends if there is room, else counts a drop. Never allocates.
  void push(const TraceRecord& r) noexcept {
    if (records_.size() < records_.capacity()) records_.push_back(r);
    else ++dropped_;
  }
  const std::vector<TraceRecord>& records() const noexcept { return records_; }
  std::uint64_t dropped() const noexcept { return dropped_; }
  /// Names the device's axes for the per-axis columns ("axis_torque_<name>"; setup only).
  /// Without names the axes are named by their index ("axis_torque_0").
  void set_axis_names(std::vector<std::string> names) { axis_names_ = std::move(names); }
  /// Names devices 1 .. N−1 of a scene of several for the per-device columns ("target_x@right";
  /// setup only). Without names they are numbered from 1 ("target_x@1").
  void set_device_names(std::vector<std::string> names) { device_names_ = std::move(names); }
  /// Writes a header line and one CSV row per record, the columns of trace_columns()
  /// (trace_columns.hpp). Throws std::runtime_error naming the path if it cannot be written.
  void write_csv(const std::string& path) const;

 private:
  std::vector<TraceRecord> records_;
  std::vector<std::string> axis_names_;
  std::vector<std::string> device_names_;
  std::uint64_t dropped_ = 0;
};

}  // namespace numen::sim
