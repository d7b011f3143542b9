#pragma once
/// @file device_config.hpp
/// DeviceConfig: everything the scene says about one tracked instrument on the bus — its kind,
/// its axes (CANopen ids, scaling, limits, drives), the sample checks' limits, the tool offset
/// and the kind's geometry. Built at load time (may allocate, may throw), read-only afterwards.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/device/axis.hpp"
#include "numen/hal/device/foaw_estimator.hpp"
#include "numen/hal/canopen/dcf.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"
#include "numen/hal/device/passivity_controller.hpp"
#include "numen/hal/device/phantom_kinematics.hpp"
#include "numen/hal/device/pose_tracker_kinematics.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "numen/hal/device/trocar_kinematics.hpp"

namespace numen::hal {

/// Which kinematics an instrument has.
enum class DeviceKind : std::uint8_t {
  kTrocarInstrument,  ///< Laparoscopic tool through a trocar: 5 axes (TrocarKinematics).
  kPoseTracker,       ///< 6-DOF hand controller / pose tracker: 6 axes (PoseTrackerKinematics).
  kPhantom,           ///< PHANToM-like haptic arm: 6 axes, 3 driven (PhantomKinematics).
};

/// Short English name of a DeviceKind (static string): "trocar instrument", "pose tracker",
/// "phantom"; "unknown" for a value outside the enum.
const char* to_string(DeviceKind kind) noexcept;

/// Number of axes a device kind has (5 trocar instrument, 6 pose tracker, 6 phantom); 0 for a
/// value outside the enum.
int expected_axis_count(DeviceKind kind) noexcept;

/// How InstrumentDevice estimates each axis's rate q̇ from its accepted encoder values
/// (docs/target_velocity.md). Every choice is bounded by the
/// axis's max_speed and handles missing, rejected and stale values the same way.
enum class VelocityEstimator : std::uint8_t {
  kDifference,  ///< The bare backward difference (RateEstimator at f_c = +∞).
  kFilter,      ///< The first-order filtered difference (RateEstimator at velocity_cutoff_hz).
  kFoaw,        ///< First-order adaptive windowing, end fit (FoawEstimator).
};

/// The scene spelling of a VelocityEstimator (static string): "difference", "filter", "foaw";
/// "unknown" for a value outside the enum.
const char* to_string(VelocityEstimator estimator) noexcept;

/// Base COB-ID of TPDO2 (0x280 + node id; CiA 301 predefined connection set): numen's default
/// drive TPDO (statusword 0x6041 + torque actual value 0x6077) of a driven axis's node.
inline constexpr std::uint32_t kTpdo2BaseCobId = 0x280;

/// CANopen communication of one axis's node in the managed stack (docs/canopen.md): which
/// node it is, its heartbeat, and its static PDO mappings (CiA 301 §7.4.8; the COB-IDs of the
/// encoder TPDO and the drive RPDO are AxisConfig::encoder_cob_id / drive_cob_id).
/// Several axes may share a node (a multi-axis module); they must then agree on the heartbeat.
struct CanopenAxisConfig {
  /// CANopen node id, 1–127.
  std::uint8_t node_id = 0;
  /// The node's producer heartbeat time (object 1017h), ms, >= 1.
  std::uint16_t heartbeat_period_ms = 10;
  /// The controller's consumer heartbeat time for this node (object 1016h on the controller),
  /// ms; 0 = 3 × heartbeat_period_ms. Must exceed heartbeat_period_ms.
  std::uint16_t heartbeat_timeout_ms = 0;
  /// Driven axis: COB-ID of the drive TPDO (sent by the drive at every SYNC), default 0x280 +
  /// node id (TPDO2). 0 for an axis without a drive.
  std::uint32_t drive_tpdo_cob_id = 0;
  /// Encoder TPDO mapping (0x1A00): must map the position value 0x6004 (or the position actual
  /// value 0x6064) as 32 bits; the other known objects may be mapped and are ignored.
  std::vector<PdoEntry> encoder_tpdo;
  /// Drive RPDO mapping (0x1600), driven axes only: must map controlword 0x6040 and target
  /// torque 0x6071; may map modes of operation 0x6060 (sent as 10, cst).
  std::vector<PdoEntry> drive_rpdo;
  /// Drive TPDO mapping (0x1A01), driven axes only: must map statusword 0x6041; may map torque
  /// actual value 0x6077, modes of operation display 0x6061, position actual value 0x6064.
  std::vector<PdoEntry> drive_tpdo;
  /// The node's DCF (CiA 306, dcf.hpp), its values resolved for node_id, or null. With a DCF
  /// the controller configures the node over SDO after its boot-up and before starting it
  /// (dcf_configuration.hpp); without, the node must come configured. Axes of one node give
  /// the same file. check_dcfs() checks it agrees with the fields above.
  std::shared_ptr<const Dcf> dcf;

  /// The consumer heartbeat time in effect, ms: heartbeat_timeout_ms or 3 × the period.
  std::uint32_t effective_heartbeat_timeout_ms() const noexcept {
    return heartbeat_timeout_ms != 0 ? heartbeat_timeout_ms : 3u * heartbeat_period_ms;
  }
};

/// How the controller talks CANopen to the device (scene section `[device.canopen]`).
struct CanopenConfig {
  /// true: the managed stack — NMT start-up, heartbeats both ways, EMCY, CiA 402 drives in cst
  /// with controlword + target torque RPDOs and statusword TPDOs, the device lifecycle and the
  /// safety supervisor (docs/canopen.md, docs/safety.md). false: the minimal protocol
  /// (SYNC, 4-byte encoder TPDOs, 2-byte torque RPDOs, no start-up) for encoders configured to
  /// start on their own and drives without a CiA 402 state machine.
  bool managed = true;
  /// The controller's own node id (its heartbeat COB-ID is 0x700 + this), 1–127, not used by
  /// the device.
  std::uint8_t controller_node_id = 127;
  /// The controller's producer heartbeat time, ms, >= 1.
  std::uint16_t controller_heartbeat_period_ms = 10;
  /// The drives' consumer heartbeat time for the controller (their object 1016h), ms; 0 = 3 ×
  /// controller_heartbeat_period_ms. A drive that does not hear the controller for this long
  /// faults on its own (EMCY 0x8130) and applies zero torque.
  std::uint16_t drive_heartbeat_timeout_ms = 0;
  /// Time the start-up (reset communication → boot-ups → start → every node operational) may
  /// take, ms, >= 1; beyond it the start-up has failed (reported with the first missing node).
  std::uint32_t startup_timeout_ms = 1000;
  /// Interval between repeats of an NMT command a node has not acted on during the start-up,
  /// ms, >= 1 (a lost frame is retried, a node that reset is started again).
  std::uint32_t startup_retry_ms = 50;
  /// Time an SDO transfer of a node's configuration (CanopenAxisConfig::dcf) may wait for the
  /// node's response, ms, >= 1; beyond it the configuration, and so the start-up, fails.
  std::uint32_t sdo_timeout_ms = 500;
  /// Once every node is operational, read each node's error register 0x1001 and each drive's
  /// statusword 0x6041 over SDO every this many ms (sdo_poller.hpp: one transfer per node at a
  /// time, advanced once per period, never waiting); 0 = no reads.
  std::uint32_t sdo_poll_period_ms = 0;
  /// One entry per DeviceConfig::axes entry, same order (managed stack only; ignored otherwise).
  std::vector<CanopenAxisConfig> axes;

  /// The drives' consumer heartbeat time in effect, ms.
  std::uint32_t effective_drive_heartbeat_timeout_ms() const noexcept {
    return drive_heartbeat_timeout_ms != 0 ? drive_heartbeat_timeout_ms
                                           : 3u * controller_heartbeat_period_ms;
  }
};

/// The default CANopen entry of an axis on node `node_id`: heartbeat 10 ms (timeout 30 ms), the
/// typical mappings (encoder_tpdo_mapping(); with a drive: drive_rpdo_mapping(),
/// drive_tpdo_mapping() and drive TPDO COB-ID 0x280 + node). No validation.
CanopenAxisConfig make_canopen_axis(std::uint8_t node_id, bool has_drive);

/// Longest DeviceConfig::soft_start_s accepted, s (a ramp longer than this is a typo, not a
/// soft start: the trainer would render almost no force for seconds).
inline constexpr double kMaxSoftStartS = 10.0;
/// The soft start of a scene that does not give `[device] soft_start`, s: 0.1 s, i.e. at the
/// shipped scenes' 8 N max_force and 1 ms period a rise of at most 0.08 N per period
/// (docs/safety.md, "Soft start", for the choice).
inline constexpr double kDefaultSceneSoftStartS = 0.1;

/// Configuration of one instrument. Checked by validate().
struct DeviceConfig {
  /// Name used in error messages and traces.
  std::string name = "device";
  /// Kinematic kind; fixes the number and meaning of the axes.
  DeviceKind kind = DeviceKind::kTrocarInstrument;
  /// Axes in the kind's order (TrocarKinematics::kPivotX.., PoseTrackerKinematics::kX..,
  /// PhantomKinematics::kTurret..).
  std::vector<AxisConfig> axes;
  /// Control period, s, > 0 (used for the default max sample age).
  double control_period_s = 1e-3;
  /// Oldest acceptable encoder sample, s (now − frame timestamp); unset = 3 control periods.
  std::optional<double> max_sample_age_s;
  /// Allowance of the jump check on top of max_speed · Δt, encoder counts, >= 0
  /// (quantisation and jitter).
  double jump_tolerance_counts = 2.0;
  /// Cutoff f_c of every axis's velocity filter (RateEstimator, rate_estimator.hpp), Hz, > 0;
  /// +infinity = the bare backward difference. The estimate lags the hand by about
  /// 1/(2π f_c) (3.2 ms at the default 50 Hz) and is bounded by each axis's max_speed.
  double velocity_cutoff_hz = kDefaultVelocityCutoffHz;
  /// Rate estimator of every axis (scene key `[device] velocity_estimator`); FOAW by default,
  /// chosen by measurement (docs/target_velocity.md).
  VelocityEstimator velocity_estimator = VelocityEstimator::kFoaw;
  /// kFoaw: the largest window, sample intervals, 1 … kFoawMaxWindow (1 = the bounded bare
  /// difference).
  int foaw_max_window = kFoawMaxWindow;
  /// kFoaw: the noise band d in encoder counts, finite and >= 0; each axis's d is this over its
  /// counts_per_unit (default: the quantisation half count).
  double foaw_noise_counts = kDefaultFoawNoiseCounts;
  /// Soft start, s, finite and in [0, kMaxSoftStartS]: ImpedanceDevice::write() scales the gated and
  /// clamped axis torques by r = min(1, k · control_period_s / soft_start_s) in the k-th write
  /// (k = 1, 2, …) since torque was enabled — the first write whose gate is open after the
  /// device was built or (managed stack) after the lifecycle entered kActive (start-up,
  /// activate(), the activation after a rearm()). 0 = off: torques pass unscaled, as before
  /// the soft start existed. The hal default is 0; a scene's `[device] soft_start` defaults to
  /// kDefaultSceneSoftStartS (docs/scenes.md, docs/safety.md "Soft start").
  double soft_start_s = 0.0;
  /// The time-domain passivity controller on the axis port (passivity_controller.hpp):
  /// ImpedanceDevice::write() runs it on the gated torques before the clamp. Off by default;
  /// a scene's `[device.passivity]` turns it on (docs/scenes.md, docs/passivity.md).
  PassivitySettings passivity;
  /// Pose of the controlled frame in the tool frame (tool tip frame for a trocar instrument,
  /// tracked frame for a pose tracker, stylus frame for a phantom). Identity: the controlled
  /// frame is the tool frame.
  core::Pose tool_offset;
  /// Trocar point and frame in world (kTrocarInstrument only).
  TrocarGeometry trocar;
  /// Tracker base frame in world (kPoseTracker only).
  PoseTrackerGeometry tracker;
  /// Arm base frame in world and link lengths (kPhantom only).
  PhantomGeometry phantom;
  /// CANopen communication (managed stack or minimal protocol).
  CanopenConfig canopen;

  /// The max sample age in effect, s: max_sample_age_s or 3 · control_period_s.
  double effective_max_sample_age_s() const noexcept {
    return max_sample_age_s ? *max_sample_age_s : 3.0 * control_period_s;
  }
};

/// Throws std::invalid_argument with a message naming the device and the field if `config`
/// is invalid: wrong axis count for the kind, an invalid axis (validate_axis()), COB-IDs
/// outside 0x001–0x7FF, equal to 0x080 (SYNC) or used twice, non-positive period or age,
/// negative jump tolerance, a velocity cutoff that is NaN or <= 0, a velocity estimator outside
/// the enum, a FOAW window outside 1 … kFoawMaxWindow, a FOAW noise band that is not finite or
/// < 0, a soft start that is not finite or outside [0, kMaxSoftStartS], a passivity velocity
/// threshold not finite or < 0 or an energy limit not > 0, non-finite positions,
/// non-unit quaternions (|‖q‖ − 1| > 1e-6), phantom link lengths not finite and > 0. Only the geometry of the config's kind is checked.
/// With canopen.managed also: one canopen.axes entry per axis; node ids 1–127 and not the
/// controller's; heartbeat periods >= 1 ms and timeouts above them (axes of one node agreeing);
/// drive TPDO COB-ID present exactly on driven axes; every PDO COB-ID (encoder, drive RPDO,
/// drive TPDO) used once and outside NMT 0x000, SYNC/EMCY 0x080–0x0FF and heartbeat
/// 0x700–0x77F; mappings valid (PdoMapping) and carrying their required objects (see
/// CanopenAxisConfig); start-up times >= 1 ms. Messages name the device, axis and field.
void validate(const DeviceConfig& config);

/// Throws DcfError, located at the line of the disagreeing DCF entry (or at the file when an
/// object is missing), if a managed axis's DCF does not configure what the rest of its
/// CanopenAxisConfig / AxisConfig says: an enabled TPDO with the encoder_cob_id mapping
/// encoder_tpdo exactly; on a driven axis, an enabled RPDO with the drive_cob_id mapping
/// drive_rpdo and an enabled TPDO with the drive_tpdo_cob_id mapping drive_tpdo; 0x1017 (if
/// given) equal to heartbeat_period_ms. Values are the ParameterValue, else the DefaultValue.
/// Axes of one node must give the same DCF file (std::invalid_argument otherwise).
void check_dcfs(const DeviceConfig& config);

/// A trocar instrument with typical trainer values; nodes first_node_id .. +4 for
/// (pivot_x, pivot_y, depth, roll, jaw); drives on pivot_x, pivot_y and depth (0x200 + node).
/// Resolutions: 2^14 counts/rev on angles, 10 µm on depth. Throws if the ids exceed 127.
/// The make_default_* configs use the managed CANopen stack with make_canopen_axis() per axis.
DeviceConfig make_default_trocar_config(std::uint8_t first_node_id = 1);

/// A non-haptic pose tracker with typical values; nodes first_node_id .. +5 for
/// (x, y, z, yaw, pitch, roll), 1 µm and 1 µrad resolution, no drives. Throws if the ids
/// exceed 127.
DeviceConfig make_default_pose_tracker_config(std::uint8_t first_node_id = 1);

/// A PHANToM Premium 1.0-like haptic arm (l1 = l2 = 0.14 m, base at the world origin); nodes
/// first_node_id .. +5 for (turret, shoulder, elbow, gimbal_yaw, gimbal_pitch, stylus_roll);
/// drives (0x200 + node) on turret, shoulder and elbow only, as on a PHANToM (rated 0.25 N·m,
/// saturated at 1.0 N·m: ~7 N at the 0.14 m gimbal); 2^16 counts/rev on the driven axes
/// (motor encoders through the capstan), 2^14 on the gimbal. Plausibility ranges around the
/// "L" home posture q = 0: turret ±1.0 rad, shoulder ±0.8 rad, elbow −1.0..0.7 rad (the
/// gimbal centre stays in front of the turret axis), gimbal yaw ±2.6 rad, gimbal pitch
/// ±1.2 rad (clear of the gimbal lock), stylus roll wraps; max speeds 10 rad/s on the arm,
/// 30 rad/s on the gimbal. Throws if the ids exceed 127.
DeviceConfig make_default_phantom_config(std::uint8_t first_node_id = 1);

}  // namespace numen::hal
