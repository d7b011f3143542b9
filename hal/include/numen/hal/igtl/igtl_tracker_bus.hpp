#pragma once
/// @file igtl_tracker_bus.hpp
/// IgtlTrackerBus: an optical or electromagnetic tracker (NDI Polaris / Aurora, Atracsys,
/// OptiTrack, through PLUS or a vendor's bridge) read over OpenIGTLink as the encoders of a
/// pose-tracker instrument (DeviceKind::kPoseTracker, pose_tracker_kinematics.hpp), so that its
/// poses go through the one device path numen has: the controller's SYNC, the six axis values
/// (x, y, z, yaw, pitch, roll) as position TPDOs in the axes' counts, the instrument's checks
/// (freshness against max_sample_age on the message's own timestamp, range, jump), the
/// velocity estimate, the supervision and the summary. The tracker has no motors: the axes have
/// no drive, so no feedback is sent (the paper's non-haptic absolute-position device, its Fig. 1).
///
/// Each SYNC written (bus time t, set_time_ns()) takes the tool's TRANSFORMs queued by the
/// receiver thread (IgtlTrackerClient) and answers with the newest one's six TPDOs, stamped with
/// the message's time on the bus clock:
///  - following the tracker (`wait_for_tracker`, offline runs): message k's bus time is its
///    timestamp minus the first message's (the first message is bus time 0); the SYNC takes every
///    pose stamped <= t and waits (at most wait_timeout_ns, counted) until a later one is queued or
///    the receiver has ended — the run goes at the tracker's pace, deterministic for a replay. A
///    wait that runs out is not repeated: the following SYNCs do not wait for a pose, but go at
///    the tracker's pace while it is silent — each waits until CLOCK_MONOTONIC is as far past the
///    newest pose's arrival as the SYNC's bus time is past that pose's (real time since the last
///    pose; at once before any pose) or a pose comes — so that the run's clock stays the
///    tracker's and the poses of a tracker that resumes are fresh, not older than the run by
///    however far it raced ahead (issue 70: a 3 s stall ended the tracker's part of the run);
///  - paced (a real-time run): the SYNC takes every queued pose and never waits; a message's bus
///    time is its timestamp + the smallest (receive time − timestamp) seen so far, the clock
///    offset of the sender (Cristian's bound), on the monotonic clock shifted to bus time.
/// A pose's timestamp is checked before it is taken, against the stamp of the last pose taken
/// (both modes): one stamped before it (backwards), or more than max_stamp_gap_ns after it (far
/// ahead: a clock that jumped, a garbled stamp), is refused and counted, and the stream goes on
/// with the next pose — one bad stamp neither holds the queue (following: a pose 10^6 s ahead
/// was "due later" for the rest of the run) nor moves the clock offset (paced). Following the
/// tracker, an unstamped pose (stamp 0) is refused too: it has no place on the tracker's clock
/// (paced, it is its receive time, as before). Resynchronisation: resync_after poses in a row
/// refused as backwards or ahead whose stamps go on from one another (each at most
/// max_stamp_gap_ns after the previous refused one, not before it) are a clock that jumped (a
/// tracker restarted): the last of them is taken and the stream is re-based on it (following:
/// its bus time is the SYNC's; paced: the clock offset is measured again), counted in
/// stamp_resyncs.
/// After a silence (the newest pose taken older than the device's max sample age at the SYNC),
/// a pose that would itself arrive stale (its bus time more than the max sample age before the
/// SYNC: a sender that paused and goes on from the stamps where it stopped) re-bases the
/// stream on it, as a clock that jumped (following: taken at this SYNC; paced: the clock offset
/// measured again), counted in silence_rebases: the samples are valid again from the first pose
/// after a stall.
/// A pose is the tool tip's (the tracked frame's) world pose tip = registration · [R, units · t] ·
/// calibration (the tool-tip calibration in the tracked marker's frame, the registration
/// tracker → scene); the axes are those that put the tracked frame there:
/// PoseTrackerKinematics::inverse() of the controlled frame tip · tool_offset (its base applies
/// as for any pose tracker). Before the first pose nothing answers (the sample is not ready); a
/// pose that is not renewed ages and the instrument rejects it as stale, exactly as a stale
/// encoder.
///
/// Several tools on one connection (PLUS sends every tool's transform on one): one receiver
/// (make_igtl_tracker_client(), the tools' device names in its settings) shared by one
/// IgtlTrackerBus per tool, each a pose tracker device of its own (its configuration, tool
/// offset and calibration) reading its tool's queue; the registration is the connection's.
/// Following the tracker, the buses share the time origin (the first pose of any tool) and
/// each SYNC waits for its own tool, so a loop that runs them one after the other goes at the
/// tracker's pace (a tool whose queue fills — 1024 poses ahead of the others — holds the
/// receiver, and the other's SYNC waits out its wait_timeout_ns: a server must interleave its
/// tools, as PLUS does, one message of each per frame). docs/openigtlink.md "Several tracked
/// tools".
///
/// Not thread safe (one control loop). read / write / set_time_ns never allocate, throw or lock;
/// they never block, except a SYNC following the tracker (bounded by wait_timeout_ns; while the
/// tracker is silent after a wait ran out, by the wall time its bus time is ahead of the newest
/// pose's arrival: about a period's).

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/igtl/igtl_tracker_client.hpp"
#include "numen/hal/transport/bus.hpp"

namespace numen::hal {

/// The tracker of a scene ([device.igtl], docs/openigtlink.md).
struct IgtlTrackerSettings {
  IgtlTrackerClientSettings client;  ///< Server, device name, queue, reconnection.
  /// Metres per unit of the message's translation: 1e-3 for millimetres (PLUS), 1 for metres.
  double metres_per_unit = 1e-3;
  /// Tool-tip calibration: the tool tip (the tracked frame) in the marker's frame (m, unit
  /// quaternion).
  core::Pose calibration;
  /// Registration: the tracker's frame in the scene's world (m, unit quaternion). Replaced by
  /// the TRANSFORM client.registration_name when that is set (its translation in the message's
  /// units, as the tool's).
  core::Pose registration;
  /// With client.registration_name: the construction waits at most this long (ns, > 0) for that
  /// TRANSFORM, then throws IgtlRegistrationMissing.
  std::int64_t registration_wait_ns = 5'000'000'000;
  /// Follow the tracker's clock (offline) instead of the period's (see the file comment).
  bool wait_for_tracker = false;
  /// Longest wait of one SYNC following the tracker, ns (> 0).
  std::int64_t wait_timeout_ns = 2'000'000'000;
  /// Latencies kept for latency_ns() (received → taken by a SYNC), >= 1.
  std::size_t latency_capacity = 1 << 16;
  /// A pose stamped more than this after the last pose taken is refused as far ahead (ns, > 0;
  /// 10 s: longer than a tracker's dropout of a hidden marker, shorter than any clock jump the
  /// run could wait out).
  std::int64_t max_stamp_gap_ns = 10'000'000'000;
  /// Poses in a row refused for their stamps, going on from one another, that re-base the
  /// stream on the last of them (>= 2; see the file comment).
  int resync_after = 3;
};

/// The registration TRANSFORM named by the settings did not come within registration_wait_ns
/// (what() names the server, the name, the wait, whether it connected and the names it sent).
class IgtlRegistrationMissing : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Counters of an IgtlTrackerBus since construction.
struct IgtlBusCounters {
  std::uint64_t syncs = 0;            ///< SYNCs written.
  std::uint64_t syncs_without_pose = 0;  ///< SYNCs answered by nothing (no pose yet).
  std::uint64_t poses_taken = 0;      ///< Poses taken from the queue.
  std::uint64_t poses_superseded = 0; ///< ... of which a newer one replaced in the same SYNC.
  /// SYNCs following the tracker whose wait ran out (each starts a stretch without waits that
  /// ends at the next pose).
  std::uint64_t wait_timeouts = 0;
  std::uint64_t stamps_backwards = 0;  ///< Poses refused: stamped before the last pose taken.
  /// Poses refused: stamped more than max_stamp_gap_ns after the last pose taken.
  std::uint64_t stamps_ahead = 0;
  std::uint64_t stamps_unstamped = 0;  ///< Poses refused following the tracker: stamp 0.
  /// Re-basings on a clock that jumped (resync_after refused poses going on from one another).
  std::uint64_t stamp_resyncs = 0;
  /// Re-basings on the first pose after a silence that would have arrived stale (a sender that
  /// paused: the file comment).
  std::uint64_t silence_rebases = 0;
  /// SYNCs following the tracker that waited for its pace while it was silent (after a wait ran
  /// out; the file comment).
  std::uint64_t silent_paced_syncs = 0;
  /// SYNCs that found every pose taken and the receiver ended (the stream over: a replay's end,
  /// or a server gone with reconnect off).
  std::uint64_t syncs_after_end = 0;
};

/// The receiver for `settings`: settings.client with the connection's behaviour of the clock
/// (following the tracker: a full queue waits, and the stream's end is not reconnected). For
/// several tools, list them in settings.client (device_name, more_device_names) and give the
/// result to one IgtlTrackerBus per tool. Throws as IgtlTrackerClient's constructor.
std::shared_ptr<IgtlTrackerClient> make_igtl_tracker_client(const IgtlTrackerSettings& settings);

/// The tracker as a bus (see the file comment).
class IgtlTrackerBus final : public Bus {
 public:
  /// `config`: the pose tracker's device configuration (validated; DeviceKind::kPoseTracker,
  /// six axes, their encoder COB-IDs and counts); `kinematics` its kinematics (kept). Starts the
  /// receiver (IgtlTrackerClient). Throws std::invalid_argument: another kind, metres_per_unit
  /// not finite and > 0, a quaternion not of unit length within 1e-6, wait_timeout_ns or
  /// registration_wait_ns <= 0, max_stamp_gap_ns <= 0, resync_after < 2, or the client's
  /// settings. With client.registration_name, waits
  /// (on the calling thread: the setup's, never a period) for that TRANSFORM and takes it as the
  /// registration; throws IgtlRegistrationMissing when it does not come in time.
  IgtlTrackerBus(const DeviceConfig& config, std::unique_ptr<const Kinematics> kinematics,
                 IgtlTrackerSettings settings);
  /// The bus of tool `tool` of a shared receiver `client` (make_igtl_tracker_client() of
  /// settings whose client lists the tools; settings.client is not used again: the receiver
  /// has its own). `config`, `kinematics`, settings' calibration and units are this tool's.
  /// `client` null: one is made, make_igtl_tracker_client(settings) (the other constructor).
  /// Throws as the other constructor, and std::invalid_argument for a tool the client does
  /// not read. With the client's registration_name, waits for it as the other does (the
  /// second bus of a connection finds it at once).
  IgtlTrackerBus(const DeviceConfig& config, std::unique_ptr<const Kinematics> kinematics,
                 IgtlTrackerSettings settings, std::shared_ptr<IgtlTrackerClient> client,
                 std::size_t tool);
  ~IgtlTrackerBus() override;

  /// The next pending TPDO (kOk), or kWouldBlock.
  IoStatus read(CanFrame& frame) noexcept override;
  /// A SYNC (is_sync()) takes the due poses and queues the six TPDOs; any other well-formed frame
  /// is accepted and discarded (kOk); a malformed one is kError.
  IoStatus write(const CanFrame& frame) noexcept override;
  /// kOk while connected, and before the first connection attempt has concluded; kBusOff while
  /// not connected after that (an attempt refused or timed out, the connection lost, the
  /// receiver ended) until a connection is made again. Lock free (the receiver's atomics).
  BusState state() const noexcept override;
  /// frames_rx: TPDOs read; frames_tx: frames written; errors: malformed writes.
  BusCounters counters() const noexcept override { return counters_; }
  /// Sets the bus clock, ns (non-decreasing).
  void set_time_ns(std::int64_t t_ns) noexcept;

  /// This bus's counters.
  const IgtlBusCounters& tracker_counters() const noexcept { return tracker_counters_; }
  /// The receiver (its counters, faults, names seen), shared by the tools' buses.
  const IgtlTrackerClient& client() const noexcept { return *client_; }
  /// This bus's tool in client() (0: its device_name).
  std::size_t tool() const noexcept { return tool_; }
  /// Same, mutable (stop()).
  IgtlTrackerClient& client() noexcept { return *client_; }
  /// Latencies from a TRANSFORM received (IgtlPose::received_mono_ns) to the SYNC that took it
  /// (CLOCK_MONOTONIC), ns, in order, the first latency_capacity of the run.
  std::vector<std::int64_t> latency_ns() const;
  /// The tool tip's world pose of the newest pose taken (identity before any).
  const core::Pose& last_pose() const noexcept { return last_pose_; }
  /// The settings.
  const IgtlTrackerSettings& settings() const noexcept { return settings_; }

 private:
  // The bus time of `p` (see the file comment).
  std::int64_t bus_time_of(const IgtlPose& p) noexcept;
  // Whether `p`'s stamp may be taken (counts a refusal; re-bases after resync_after).
  bool stamp_acceptable(const IgtlPose& p) noexcept;
  // Re-bases the stream on `p` (a clock that jumped, a sender that paused): following, `p` is
  // due at this SYNC; paced, the sender's clock offset is measured again from it.
  void rebase_on(const IgtlPose& p) noexcept;
  void take(const IgtlPose& p, std::int64_t now_mono) noexcept;
  void on_sync() noexcept;
  // Waits for the registration TRANSFORM (construction; see the constructor).
  void take_registration();

  DeviceConfig config_;
  std::unique_ptr<const Kinematics> kinematics_;
  IgtlTrackerSettings settings_;
  std::shared_ptr<IgtlTrackerClient> client_;
  std::size_t tool_ = 0;
  std::array<CanFrame, kMaxAxes> pending_{};
  int pending_count_ = 0;
  int pending_next_ = 0;
  bool has_pose_ = false;
  bool starved_ = false;  // following: a wait ran out and no pose has come since
  AxisVector q_;
  std::int64_t pose_time_ns_ = 0;  // bus time of the newest pose
  std::int64_t pose_received_mono_ns_ = 0;  // when it arrived (CLOCK_MONOTONIC)
  std::int64_t max_sample_age_ns_ = 0;      // the device's (DeviceConfig::effective_max_sample_age_s())
  core::Pose last_pose_;
  std::int64_t now_ns_ = 0;
  bool has_origin_ = false;
  std::int64_t origin_mono_ns_ = 0;   // paced: CLOCK_MONOTONIC of bus time 0
  bool has_first_stamp_ = false;
  std::int64_t first_stamp_ns_ = 0;   // following: the first message's stamp
  bool has_offset_ = false;
  std::int64_t offset_ns_ = 0;        // paced: min(received − stamp)
  std::int64_t shift_ns_ = 0;         // following: added to stamp − first stamp (re-basings)
  bool has_last_stamp_ = false;
  std::int64_t last_stamp_ns_ = 0;  // the stamp of the last pose taken (0: unstamped)
  int refused_run_ = 0;             // poses in a row refused for stamps going on from one another
  std::int64_t refused_stamp_ns_ = 0;    // the last of them
  std::vector<std::int64_t> latencies_;  // reserved at construction
  BusCounters counters_;
  IgtlBusCounters tracker_counters_;
};

}  // namespace numen::hal
