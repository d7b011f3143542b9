#pragma once
/// @file force_sensor.hpp
/// A 6-axis force/torque sensor on the bus (the handle of an admittance device, paper Fig. 2
/// note): its two transmit PDOs, their static mappings, the device-side encoding and the
/// controller-side decoder with its checks (docs/protocol.md).
///
/// Frames (numen's own convention, modelled on the analog inputs of CiA 404 measuring devices
/// but with objects in the manufacturer-specific range 0x2000–0x5FFF of CiA 301 §7.4.1, since
/// no CiA profile fixes a 6-axis F/T layout): on every SYNC the sensor node sends
///   force TPDO  (default 0x180 + node, TPDO1): Fx, Fy, Fz, INTEGER16 little endian, 6 bytes,
///               objects 0x2200:01..03;
///   torque TPDO (default 0x280 + node, TPDO2): Tx, Ty, Tz, INTEGER16 little endian, 6 bytes,
///               objects 0x2201:01..03;
/// in the sensor frame, force in counts of `force_scale` N, torque about the sensor origin in
/// counts of `torque_scale` N·m. ±32767 and −32768 mean "saturated" and are rejected as out of
/// range. Setup validates and throws std::invalid_argument; the per-period calls are noexcept
/// and never allocate.

#include <array>
#include <cstdint>
#include <string>

#include "numen/core/types.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"
#include "numen/hal/device/sample_check.hpp"

namespace numen::hal {

/// Manufacturer-specific objects of the force/torque sensor (numen's own, see the file comment).
struct ForceSensorObject {
  /// 0x2200:01 force x, INTEGER16, counts of ForceSensorConfig::force_scale N.
  static constexpr PdoEntry kForceX{0x2200, 0x01, 16, true};
  /// 0x2200:02 force y, INTEGER16.
  static constexpr PdoEntry kForceY{0x2200, 0x02, 16, true};
  /// 0x2200:03 force z, INTEGER16.
  static constexpr PdoEntry kForceZ{0x2200, 0x03, 16, true};
  /// 0x2201:01 torque x about the sensor origin, INTEGER16, counts of torque_scale N·m.
  static constexpr PdoEntry kTorqueX{0x2201, 0x01, 16, true};
  /// 0x2201:02 torque y, INTEGER16.
  static constexpr PdoEntry kTorqueY{0x2201, 0x02, 16, true};
  /// 0x2201:03 torque z, INTEGER16.
  static constexpr PdoEntry kTorqueZ{0x2201, 0x03, 16, true};
};

/// Force TPDO mapping (0x1A00): 0x22000110, 0x22000210, 0x22000310; 6 bytes.
PdoMapping force_tpdo_mapping();
/// Torque TPDO mapping (0x1A01): 0x22010110, 0x22010210, 0x22010310; 6 bytes.
PdoMapping torque_tpdo_mapping();

/// The sensor as the scene describes it (`[device.force_sensor]`, docs/scenes.md).
struct ForceSensorConfig {
  /// CANopen node id of the sensor, 1–127 (default COB-IDs derive from it).
  std::uint8_t node_id = 32;
  /// COB-ID of the force TPDO (11-bit); 0 = 0x180 + node_id.
  std::uint32_t force_cob_id = 0;
  /// COB-ID of the torque TPDO (11-bit); 0 = 0x280 + node_id.
  std::uint32_t torque_cob_id = 0;
  /// N per count, > 0 (0.01 N: ±327 N full scale).
  double force_scale = 0.01;
  /// N·m per count, > 0 (1e-4 N·m: ±3.27 N·m full scale).
  double torque_scale = 1e-4;
  /// Largest accepted |F|, N, > 0 (range check on the norm).
  double max_force = 100.0;
  /// Largest accepted |T|, N·m, > 0.
  double max_torque = 2.0;
  /// Oldest accepted frame, s, > 0 (now − frame timestamp, both halves).
  double max_age_s = 3e-3;
  /// Pose of the sensor frame in the device's controlled (tool) frame.
  core::Pose sensor_in_tool;

  /// The force TPDO COB-ID in effect.
  std::uint32_t effective_force_cob_id() const noexcept {
    return force_cob_id != 0 ? force_cob_id : 0x180u + node_id;
  }
  /// The torque TPDO COB-ID in effect.
  std::uint32_t effective_torque_cob_id() const noexcept {
    return torque_cob_id != 0 ? torque_cob_id : 0x280u + node_id;
  }
};

/// Throws std::invalid_argument naming `name` and the field when: node id outside 1–127;
/// a COB-ID in effect outside 0x001–0x7FF, in 0x080–0x0FF (SYNC/EMCY) or 0x700–0x77F
/// (heartbeat), or both equal; a scale, max or age not finite and > 0; sensor_in_tool not
/// finite or its quaternion not unit (|‖q‖ − 1| > 1e-6).
void validate(const ForceSensorConfig& config, const std::string& name = "force_sensor");

/// Device side: the two TPDOs for `wrench` (sensor frame; N, N·m about the sensor origin),
/// values rounded to counts and saturated to ±32767 (what a saturated sensor reports), stamped
/// `timestamp_ns`. A non-finite component is sent as 32767 (saturated, rejected downstream).
void encode_force_tpdos(const ForceSensorConfig& config, const core::Wrench& wrench,
                        std::int64_t timestamp_ns, CanFrame& force_frame,
                        CanFrame& torque_frame) noexcept;

/// One checked reading (ForceSensor::sample()).
struct ForceSample {
  /// Both halves present, fresh, decoded and in range this period.
  bool valid = false;
  /// The last accepted reading: sensor frame, N and N·m about the sensor origin (zero until one
  /// was accepted). Held when the current one is rejected.
  core::Wrench wrench;
  /// Union of the SampleFault bits of this period (kNoData, kMalformed, kOutOfRange, kStale).
  FaultMask faults = SampleFault::kNoData;
  /// sample() calls since the last valid one (0 when valid now).
  std::uint32_t periods_since_valid = 0;
};

/// Counters since construction.
struct ForceSensorCounters {
  std::uint64_t frames = 0;        ///< Frames with either COB-ID.
  std::uint64_t malformed = 0;     ///< ... rejected by the mapping (length, remote, CAN FD).
  std::uint64_t out_of_range = 0;  ///< Periods rejected for saturation or |F|, |T| too large.
  std::uint64_t stale = 0;         ///< Periods rejected because a half was too old or missing.
  std::uint64_t accepted = 0;      ///< Periods with a valid reading.
};

/// Controller side: decodes the two TPDOs and checks them once per period like encoder samples
/// (sample_check.hpp): finite (int16 always is; saturation counts are rejected), in range
/// (|F| <= max_force, |T| <= max_torque), fresh (each half no older than max_age_s). Not
/// thread safe; one control loop owns it.
class ForceSensor {
 public:
  /// Validates (throws std::invalid_argument, see validate()).
  explicit ForceSensor(const ForceSensorConfig& config);

  /// Takes `frame` if it is on one of the sensor's 11-bit COB-IDs (has_standard_id(); returns
  /// true, even when malformed — wrong length, remote, CAN FD: rejected and counted); false
  /// for any other frame, error reports and 29-bit frames included (they never mark the
  /// reading malformed).
  bool on_frame(const CanFrame& frame) noexcept;

  /// The checked reading at bus time `now_ns` (see ForceSample). Call once per period.
  ForceSample sample(std::int64_t now_ns) noexcept;

  const ForceSensorConfig& config() const noexcept { return config_; }
  const ForceSensorCounters& counters() const noexcept { return counters_; }

 private:
  ForceSensorConfig config_;
  PdoMapping force_map_;
  PdoMapping torque_map_;
  std::uint32_t force_id_;
  std::uint32_t torque_id_;
  std::array<std::int64_t, 3> force_counts_{};
  std::array<std::int64_t, 3> torque_counts_{};
  std::int64_t force_stamp_ns_ = 0;
  std::int64_t torque_stamp_ns_ = 0;
  bool have_force_ = false;
  bool have_torque_ = false;
  bool malformed_ = false;  // a malformed frame arrived since the last sample()
  core::Wrench accepted_;
  std::uint32_t since_valid_ = 0;
  ForceSensorCounters counters_;
};

}  // namespace numen::hal
