#pragma once
/// @file control_loop.hpp
/// One control period of numen (DESIGN.md, "One control period"):
///   begin_period: SYNC on the bus;
///   end_period:   read every pending frame → decode → check → forward kinematics
///                 → core::Data target → core::step → feedback wrench (Eq. 8)
///                 → axis torques Jᵀ w → saturate → torque PDOs on the bus.
/// The same object runs against SimBus in simulation and, later, SocketCAN.
/// Construction may allocate; begin_period/end_period never allocate, throw,
/// lock or block.

#include <array>
#include <cstdint>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/hal/bus.hpp"
#include "numen/hal/instrument_device.hpp"
#include "numen/platform/device_binding.hpp"
#include "numen/platform/latency_histogram.hpp"

namespace numen::platform {

/// What one end_period() did.
struct PeriodReport {
  int frames_read = 0;              ///< Frames taken from the bus this period.
  bool sample_valid = false;        ///< Every axis fresh and plausible this period.
  bool target_ready = false;        ///< The device has a target (possibly held from earlier).
  std::int64_t step_ns = 0;         ///< Wall time of core::step (ns, CLOCK_MONOTONIC).
  hal::IoStatus command_status = hal::IoStatus::kOk;  ///< Result of the torque writes.
};

/// Counters since construction.
struct ControlLoopCounters {
  std::uint64_t periods = 0;          ///< end_period() calls.
  std::uint64_t sync_write_failures = 0;  ///< SYNC writes not accepted by the bus.
  std::uint64_t command_failures = 0;     ///< Periods whose torque writes did not all succeed.
  std::uint64_t periods_zero_torque = 0;  ///< Periods that sent zero torque (no body held, or no valid sample).
};

/// The control loop of one instrument driving one core::Data.
/// Not thread safe: one real-time thread owns it.
class ControlLoop {
 public:
  /// Keeps references: `model`, `data`, `bus` and `device` must outlive the loop.
  /// `binding` says which bodies the device's links drive and which prescribed
  /// joints its axes impose (copied; the default drives the attached body by
  /// link 0). Throws std::invalid_argument if a link, body, joint or axis index
  /// of the binding is out of range, a body is bound to two links, or a
  /// prescription names a joint that is not prescribed. The attached body
  /// follows its own binding if it has one, else the binding with body = -1.
  /// Allocates (construction only).
  ControlLoop(const core::Model& model, core::Data& data, hal::Bus& bus,
              hal::InstrumentDevice& device, DeviceBinding binding = DeviceBinding::rigid());

  /// Starts period k: writes a SYNC (CANopen COB-ID 0x080) stamped `now_ns`.
  void begin_period(std::int64_t now_ns) noexcept;

  /// Ends the period at bus time `now_ns` (after the encoders answered): reads the
  /// frames, checks the sample and, when the device is ready (a rejected sample
  /// keeps the last good target inside the device), sets the bound bodies'
  /// targets — body pose = link pose · body_in_link, twist carried to the body's
  /// origin; the attached body's into data.target, the others into
  /// data.body_targets (paper Eq. 6) — and the prescribed joints'
  /// values; runs one core::step; then sends the torques
  /// τ = Σ_l J_lᵀ w_l, w_l the bound bodies' Eq. 8 feedback (data.body_feedback)
  /// carried to their link's origin (Eq. 9) — zero torque while no bound body
  /// is driven or this period's sample is not valid (stale, rejected, or the
  /// device not ready).
  const PeriodReport& end_period(std::int64_t now_ns) noexcept;

  /// Wall time of core::step per period (ns).
  const LatencyHistogram& step_time() const noexcept { return step_time_; }
  /// Counters since construction.
  const ControlLoopCounters& counters() const noexcept { return counters_; }
  /// What the last end_period() did.
  const PeriodReport& last_report() const noexcept { return report_; }

 private:
  void apply_targets(const hal::DeviceSample& sample) noexcept;
  bool send_feedback(std::int64_t now_ns) noexcept;

  const core::Model* model_;
  core::Data* data_;
  hal::Bus* bus_;
  hal::InstrumentDevice* device_;
  DeviceBinding binding_;
  std::vector<core::Vec3> link_origin_;   // per binding: world origin of its link this period
  std::vector<core::Vec3> body_target_;   // per binding: target point of its body this period
  std::vector<int> bound_body_;           // per binding: body driven this period (-1: none)
  std::vector<std::uint8_t> explicit_bound_;  // per body: 1 if a binding names it
  std::array<core::Wrench, hal::kMaxLinks> link_wrench_{};
  std::uint8_t sync_counter_ = 0;
  LatencyHistogram step_time_;
  ControlLoopCounters counters_;
  PeriodReport report_;
};

}  // namespace numen::platform
