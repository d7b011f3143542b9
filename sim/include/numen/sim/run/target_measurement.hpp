#pragma once
/// @file target_measurement.hpp
/// The run's measurement of the target: the tool's bodies placed where the encoders put them
/// (the held body at Data::target, the others at their own targets, Eq. 6 of the paper) and,
/// closed loop, where the hand means to be, detected against the scene (its nets at rest,
/// against the organs' rest shapes). It gives the summary's "penetration max: target" and
/// the hand's depth (docs/outputs.md): a report figure, not an input of the control law.
///
/// Its cost is the scene's contact detection again, and grows with the meshes: a tool placed
/// deep inside a 200 000-triangle rigid core searches the core's tree over a large patch
/// (docs/realtime.md, "Paced on a 16-core machine": about 45 % of a 10 kHz device loop's work).
/// An offline run measures inline (TargetMeasurement::measure(), deterministic); a paced run
/// measures on a thread of its own (TargetMeasurementThread): the loop copies the inputs
/// (TargetInputs, sized at setup) into a lock-free triple buffer and reads the newest result
/// back, so that the loop thread's period carries a copy of a few poses, not the detection.
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"
#include "numen/platform/triple_buffer.hpp"

namespace numen::sim {

/// What one measurement of the target found: penetration depths in m, contact count.
struct TargetContacts {
  double target_pen = 0.0;  ///< Deepest contact of the tool's bodies and nets at the target.
  double hand_pen = 0.0;    ///< Closed loop: at the hand's intent (the target's in replay).
  int target_contacts = 0;  ///< Contacts of the tool at the target.
};

/// The loop's state that one measurement reads, copied at a period (world frame, m, unit
/// quaternions). Sized by make_target_inputs(); filling it again never allocates.
struct TargetInputs {
  std::vector<core::BodyState> bodies;          ///< Data::bodies, one per body.
  std::vector<core::BodyTarget> body_targets;   ///< Data::body_targets, one per body.
  /// Data::nodes where the model has nets on bodies that are not anchored (a tool's or a free
  /// body's net: their nodes as the loop has them); empty otherwise (organs' are at rest).
  std::vector<core::NodeState> nodes;
  core::Pose target;                            ///< Data::target: the held body's target.
  /// Closed loop: the pose of each body bound to an instrument link at the hand's intent
  /// (valid where hand_bound is 1), one per body.
  std::vector<core::Pose> hand_pose;
  std::vector<std::uint8_t> hand_bound;         ///< Per body: 1 where hand_pose is set.
  bool closed_loop = false;                     ///< The hand is simulated (a plant).
  int held = -1;                                ///< The held body (Data::held_body).
  int tree = -1;                                ///< Its articulation (Articulation::body_tree).
};

/// TargetInputs sized for `model` (allocates).
TargetInputs make_target_inputs(const core::Model& model);

/// The measurement itself, on a ghost Data of its own (allocated at construction; measure()
/// never allocates). Not thread-safe: one caller at a time.
class TargetMeasurement {
 public:
  /// Keeps a reference to `model` (must outlive this).
  explicit TargetMeasurement(const core::Model& model);
  /// Measures `in` (in.held ≥ 0). O(the scene's contact detection).
  TargetContacts measure(const TargetInputs& in) noexcept;

 private:
  const core::Model* model_;
  core::Data ghost_;
  bool organs_placed_ = false;  // the anchored bodies' nets placed at rest in ghost_
};

/// A TargetMeasurement on a thread of its own (SCHED_OTHER, on the CPUs the process may use
/// but those of the loop and the scene thread: start()). One producer (the loop thread: inputs(), submit(), latest()) and the
/// measuring thread; neither waits for the other (platform::TripleBuffer both ways). The thread
/// polls for new inputs every kPollNs when idle. What passes is the newest: inputs submitted
/// faster than they are measured are skipped (submitted() − measured()).
class TargetMeasurementThread {
 public:
  /// How long the measuring thread sleeps when no new inputs have come (ns): half the
  /// shortest spacing of its inputs (at most 1 kHz, a run's ghost_every_).
  static constexpr std::int64_t kPollNs = 500'000;
  /// Sizes the buffers for `model` (allocates); does not start the thread.
  explicit TargetMeasurementThread(const core::Model& model);
  /// Stops the thread (stop()).
  ~TargetMeasurementThread();
  TargetMeasurementThread(const TargetMeasurementThread&) = delete;
  TargetMeasurementThread& operator=(const TargetMeasurementThread&) = delete;

  /// Starts the measuring thread, kept off `avoid_cpus` (the loop's and the scene thread's
  /// pinned CPUs: the measurement must not take their time) where the process's affinity
  /// leaves another CPU; returns whether it was (false: none asked, or no CPU left, and the
  /// thread runs where the scheduler puts it). Throws std::system_error if it cannot start.
  bool start(const std::vector<int>& avoid_cpus = {});
  /// Stops and joins the thread; idempotent.
  void stop() noexcept;
  /// Loop thread: the inputs to fill for the next submit() (an older value's storage).
  TargetInputs& inputs() noexcept { return in_.back(); }
  /// Loop thread: hands inputs() to the measuring thread. Never allocates, locks or blocks.
  void submit() noexcept;
  /// Loop thread: the newest measurement (zeros before the first). Never allocates, locks or
  /// blocks.
  const TargetContacts& latest() noexcept;
  /// Inputs submitted so far.
  std::int64_t submitted() const noexcept { return submitted_.load(std::memory_order_relaxed); }
  /// Inputs measured so far (at most submitted()).
  std::int64_t measured() const noexcept { return measured_.load(std::memory_order_relaxed); }

 private:
  void run() noexcept;

  TargetMeasurement measurement_;
  platform::TripleBuffer<TargetInputs> in_;
  platform::TripleBuffer<TargetContacts> out_;
  std::atomic<std::int64_t> submitted_{0};
  std::atomic<std::int64_t> measured_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace numen::sim
