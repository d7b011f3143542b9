#pragma once
/// @file device_emulator.hpp
/// DeviceEmulator: the device side of an instrument on a bus — its encoder nodes answering
/// SYNC with position TPDOs and its drives receiving torque RPDOs. Used by simulated
/// instruments and by tests in place of real CiA 406 encoders and CiA 402 drives.
/// Construction allocates and may throw; every other member is noexcept and allocation free.

#include <array>
#include <cstdint>

#include "numen/hal/bus.hpp"
#include "numen/hal/can_frame.hpp"
#include "numen/hal/device_config.hpp"
#include "numen/hal/kinematics.hpp"

namespace numen::hal {

/// Counters of a DeviceEmulator since construction.
struct EmulatorCounters {
  std::uint64_t syncs = 0;             ///< SYNC frames received.
  std::uint64_t syncs_ignored = 0;     ///< SYNCs not answered (set_responding(false)).
  std::uint64_t tpdos_sent = 0;        ///< Position TPDOs written with kOk.
  std::uint64_t tx_would_block = 0;    ///< TPDO writes refused (queue full).
  std::uint64_t tx_errors = 0;         ///< TPDO writes that failed.
  std::uint64_t rpdos = 0;             ///< Torque RPDOs decoded.
  std::uint64_t frames_malformed = 0;  ///< Frames on the SYNC or a drive COB-ID that failed to
                                       ///< decode (wrong length, not a data frame).
  std::uint64_t frames_ignored = 0;    ///< Frames of other ids.
};

/// Emulated encoders and drives of one instrument. Not thread safe.
class DeviceEmulator {
 public:
  /// Throws std::invalid_argument if validate(config) does. Axis values start at 0.
  explicit DeviceEmulator(DeviceConfig config);

  /// Sets the axis values to report, m or rad; `q` points to config().axes.size() values.
  /// Converted with value_to_counts() (rounded, saturated; no range check, so tests can feed
  /// out-of-range values).
  void set_axis_values(const double* q) noexcept;
  /// Sets the raw encoder counts to report; `counts` points to config().axes.size() values.
  void set_axis_counts(const std::int32_t* counts) noexcept;
  /// false: SYNCs are received but not answered (a silent device, for stale-bus tests).
  void set_responding(bool responding) noexcept { responding_ = responding; }

  /// Handles one frame read on the device port: a SYNC is answered by writing one position
  /// TPDO per axis on `device_port`, stamped with the SYNC's timestamp; a torque RPDO of an
  /// axis with a drive updates last_torques(); other frames are ignored.
  void on_frame(const CanFrame& frame, Bus& device_port) noexcept;

  /// Reads up to `max_frames` frames from `device_port` and handles each with on_frame().
  /// Returns the number read.
  int poll(Bus& device_port, int max_frames = 256) noexcept;

  /// Last received torque of each axis, N·m or N (0 for axes without a drive or before the
  /// first RPDO), n entries.
  const AxisVector& last_torques() const noexcept { return last_torques_; }
  /// Last received per mille of each axis.
  const std::array<std::int16_t, kMaxAxes>& last_torque_per_mille() const noexcept {
    return last_per_mille_;
  }
  /// Encoder counts currently reported, n entries used.
  const std::array<std::int32_t, kMaxAxes>& counts() const noexcept { return counts_; }
  /// Counters.
  const EmulatorCounters& counters() const noexcept { return counters_; }
  /// The configuration.
  const DeviceConfig& config() const noexcept { return config_; }

 private:
  DeviceConfig config_;
  int n_ = 0;
  bool responding_ = true;
  std::array<std::int32_t, kMaxAxes> counts_{};
  AxisVector last_torques_;
  std::array<std::int16_t, kMaxAxes> last_per_mille_{};
  EmulatorCounters counters_;
};

}  // namespace numen::hal
