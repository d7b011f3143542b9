#pragma once
/// @file instrument_device.hpp
/// InstrumentDevice: the controller-side driver of one tracked instrument on a CAN bus. Each
/// control period it turns the encoder TPDOs received since the last period into a checked
/// target pose and twist for the god-object (paper Eq. 2 inputs) — one per link of an
/// articulated instrument (paper Eq. 6) — and maps feedback wrenches to axis torques
/// τ = Σ_l J_lᵀ w_l (paper Eq. 8 output, virtual coupling) at the sample's axis values. It
/// sends nothing: hal::Device (device.hpp) owns the bus side — it gates, clamps and encodes τ
/// in the protocol's RPDOs.
/// Construction allocates and may throw; every other member is noexcept, allocation free,
/// lock free and never blocks. See docs/protocol.md for the order of one period.

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "numen/core/types.hpp"
#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/device/device_config.hpp"
#include "numen/hal/device/device_sample.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/canopen/pdo_mapping.hpp"
#include "numen/hal/device/foaw_estimator.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "numen/hal/device/sample_check.hpp"

namespace numen::hal {

/// Monotonic counters of an InstrumentDevice since construction or reset_counters().
struct DeviceCounters {
  // Frames seen by on_frame().
  std::uint64_t frames_decoded = 0;       ///< Encoder TPDOs decoded.
  std::uint64_t frames_wrong_length = 0;  ///< TPDOs of an axis with a wrong length.
  /// Remote requests and CAN FD frames on an axis's 11-bit COB-ID (the axis is marked
  /// malformed for the period).
  std::uint64_t frames_not_data = 0;
  std::uint64_t frames_fd = 0;      ///< ... of which CAN FD frames.
  std::uint64_t frames_remote = 0;  ///< ... of which remote requests (classic).
  /// Frames whose identifier belongs to no axis, 29-bit frames included (even with the number
  /// of an axis's COB-ID: a different identifier).
  std::uint64_t frames_unknown_id = 0;
  /// Controller error reports (CanFlag::kErrorFrame) given to on_frame(): ignored, whatever
  /// their error-class bits read; the bus state is the transport's (Bus::state()).
  std::uint64_t frames_error = 0;
  // Samples (one per axis per sample() call).
  std::uint64_t samples = 0;                ///< sample() calls.
  std::uint64_t samples_valid = 0;          ///< sample() calls that returned valid.
  std::uint64_t values_accepted = 0;        ///< Axis values accepted.
  std::uint64_t values_rejected = 0;        ///< Axis-periods with a failed check.
  std::uint64_t rejected_malformed = 0;     ///< ... of which the latest frame was malformed.
  std::uint64_t rejected_non_finite = 0;    ///< ... non-finite value.
  std::uint64_t rejected_out_of_range = 0;  ///< ... outside [min, max].
  std::uint64_t rejected_stale = 0;         ///< ... stale (including periods with no frame).
  std::uint64_t rejected_jump = 0;          ///< ... implausible jump.
  // Mappings (torques_for()).
  std::uint64_t commands = 0;             ///< torques_for() calls.
  /// ... given a NaN/inf wrench (mapped all the same: hal::ImpedanceDevice::write() trips on the
  /// non-finite τ, FaultCause::kNonFiniteTorque).
  std::uint64_t non_finite_wrenches = 0;
  /// torques_for() calls given more wrenches than the instrument has links (the extra
  /// entries were ignored).
  std::uint64_t extra_link_wrenches = 0;
};

/// Controller-side driver of one instrument: encoder TPDOs in, checked target out; link
/// wrenches in, axis torques out. Not thread safe (one control loop owns it).
class InstrumentDevice {
 public:
  /// Takes the configuration and the kinematics. Throws std::invalid_argument if
  /// validate(config) throws, `kinematics` is null, its num_axes() differs from
  /// config.axes.size() or its num_links() is outside 1..kMaxLinks.
  InstrumentDevice(DeviceConfig config, std::unique_ptr<const Kinematics> kinematics);
  /// Same with make_kinematics(config).
  explicit InstrumentDevice(DeviceConfig config);

  /// Handles one received frame: an encoder TPDO of an axis becomes that axis's pending
  /// sample (the newest frame of an axis wins); a malformed one marks the axis malformed
  /// for this period. Minimal protocol: the 4-byte position PDO (decode_position_pdo());
  /// managed stack (config.canopen.managed): the axis's static encoder TPDO mapping
  /// (PdoMapping::unpack(), exact length), position from 0x6004 or 0x6064. Acceptance
  /// (can_frame.hpp): a frame belongs to an axis if it is on the axis's 11-bit COB-ID
  /// (has_standard_id()); a remote or CAN FD frame there is malformed. Returns true if the
  /// frame belongs to an axis. Other frames are counted as unknown (29-bit ones too) and
  /// error reports as frames_error; neither touches an axis. The frames come from the bus
  /// through Device::read() (device.hpp), the one frame-reading loop.
  bool on_frame(const CanFrame& frame) noexcept;

  /// Checks the pending samples at time `now_ns` (bus clock), accepts or rejects each axis,
  /// and returns the target. See DeviceSample and check_sample().
  DeviceSample sample(std::int64_t now_ns) noexcept;

  /// The map from link wrenches to axis torques (paper Eq. 8 per body, mapped by virtual
  /// work): τ = Σ_l J_lᵀ [force_l; torque_l] into `tau` (n entries, N·m or N), with
  /// w_l = link_wrenches[l] in world coordinates about link l's origin and
  /// J_l = Kinematics::link_jacobian(l, q) at the axis values of the last sample(). Links
  /// without an entry (l >= link_wrenches.size()) get a zero wrench; entries beyond
  /// num_links() are ignored and counted (extra_link_wrenches). It computes and never gates:
  /// no gate, no clamp and no zeroing (that is hal::ImpedanceDevice::write(), once); every axis gets its
  /// Σ, with a drive or not (before the first accepted sample, at the held axis values:
  /// write() gates that period, whose sample is not valid). A non-finite wrench is mapped as
  /// it is (counted in non_finite_wrenches): its τ reaches write(), whose non-finite trip
  /// latches the safe state.
  void torques_for(std::span<const core::Wrench> link_wrenches, AxisVector& tau) noexcept;

  /// The last sample() result (default-constructed with q = 0 before the first call).
  const DeviceSample& last_sample() const noexcept { return last_sample_; }
  /// Geometric Jacobian of link `link` (0 <= link < num_links(); 6 × n, world, linear part at
  /// the link's origin) at the last sample's axis values (Kinematics::link_jacobian()).
  const Jacobian& link_jacobian(int link) const noexcept {
    return link_jacobians_[static_cast<std::size_t>(link)];
  }
  /// Counters.
  const DeviceCounters& counters() const noexcept { return counters_; }
  /// Zeroes the counters.
  void reset_counters() noexcept { counters_ = DeviceCounters{}; }
  /// Forgets every accepted and pending value (e.g. after re-homing); the next samples are
  /// not ready until each axis has a new accepted value.
  void reset() noexcept;

  /// The configuration (validated).
  const DeviceConfig& config() const noexcept { return config_; }
  /// The kinematics.
  const Kinematics& kinematics() const noexcept { return *kinematics_; }
  /// Number of axes n.
  int num_axes() const noexcept { return n_; }
  /// Number of links (Kinematics::num_links(), 1..kMaxLinks).
  int num_links() const noexcept { return num_links_; }

 private:
  struct AxisState {
    bool pending = false;    // a well-formed frame arrived since the last sample()
    bool malformed = false;  // the newest frame since the last sample() was malformed
    // Range faults of values overwritten by a newer frame before sample() read them: a bad
    // value is a fault even if a good one follows within the period (docs/safety.md).
    FaultMask superseded = SampleFault::kNone;
    double pending_q = 0.0;        // the pending frame's axis value, m or rad (counts_to_value)
    FaultMask pending_range = SampleFault::kNone;  // its range check, made where it was decoded
    std::int64_t pending_stamp_ns = 0;
    bool has_value = false;  // an accepted value exists
    AcceptedValue last;      // last accepted value
    // sample() calls since the last accepted value (DeviceSample::periods_since_accepted).
    std::uint32_t periods_since_accepted = 0;
  };

  // Link targets, twists and Jacobians of `s` from s.q, s.qdot (link 0 from forward/jacobian).
  void evaluate_links(DeviceSample& s) noexcept;

  DeviceConfig config_;
  std::unique_ptr<const Kinematics> kinematics_;
  std::vector<PdoMapping> encoder_maps_;          // managed: one per axis
  std::array<int, kMaxAxes> encoder_position_{};  // managed: index of the position entry
  int n_ = 0;
  int num_links_ = 1;
  std::array<AxisCheckLimits, kMaxAxes> limits_{};
  std::array<AxisState, kMaxAxes> axes_{};
  // Velocity of each axis from its accepted values (configured once; reset() restarts them):
  // rates_ for the difference and the filter, foaws_ for FOAW (config_.velocity_estimator).
  std::array<RateEstimator, kMaxAxes> rates_{};
  std::array<FoawEstimator, kMaxAxes> foaws_{};
  bool use_foaw_ = false;
  AxisVector hold_;  // value used before an axis's first accepted value
  std::array<Jacobian, kMaxLinks> link_jacobians_{};  // at last_sample_.q; [0]: jacobian()
  DeviceSample last_sample_;
  DeviceCounters counters_;
};

}  // namespace numen::hal
