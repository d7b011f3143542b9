/// @file safety_supervisor.cpp
/// SafetySupervisor: watchdogs, plausibility, fault log, torque saturation (see the header).

#include "numen/hal/device/safety_supervisor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

// The sample check bits that latch and the cause each latches, in the order update() records
// them and find_present() reports the first present: the one map from a sample fault to a
// fault cause. kStale and kMalformed only reject (the encoder timeout covers them).
struct SampleFaultCause {
  FaultMask bit;
  FaultCause cause;
};
constexpr std::array<SampleFaultCause, 3> kSampleFaultCauses{{
    {SampleFault::kNonFinite, FaultCause::kNonFinite},
    {SampleFault::kOutOfRange, FaultCause::kOutOfRange},
    {SampleFault::kJump, FaultCause::kEncoderJump},
}};
constexpr FaultMask kLatchingSampleBits =
    SampleFault::kNonFinite | SampleFault::kOutOfRange | SampleFault::kJump;
static_assert((kSampleFaultCauses[0].bit | kSampleFaultCauses[1].bit | kSampleFaultCauses[2].bit) ==
              kLatchingSampleBits);

// CiA 402 states in which the power stage applies no torque and the drive is disabled.
constexpr bool is_disabled(PowerState s) noexcept {
  return s == PowerState::kNotReadyToSwitchOn || s == PowerState::kSwitchOnDisabled ||
         s == PowerState::kFault;
}

const SafetySettings& validated(const SafetySettings& s) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("SafetySettings." + what);
  };
  if (s.encoder_timeout_periods == 0) fail("encoder_timeout_periods must be >= 1, got 0");
  if (s.overrun_limit == 0) fail("overrun_limit must be >= 1, got 0");
  if (s.safe_stop_timeout_periods == 0) fail("safe_stop_timeout_periods must be >= 1, got 0");
  if (s.num_axes == 0 || s.num_axes > static_cast<std::size_t>(kMaxAxes)) {
    fail("num_axes must be 1-" + std::to_string(kMaxAxes) + ", got " + std::to_string(s.num_axes));
  }
  return s;
}

}  // namespace

const char* to_string(FaultCause cause) noexcept {
  switch (cause) {
    case FaultCause::kNone:
      return "none";
    case FaultCause::kBadInput:
      return "bad input";
    case FaultCause::kBusOff:
      return "bus off";
    case FaultCause::kIoError:
      return "I/O error";
    case FaultCause::kHeartbeatLost:
      return "heartbeat lost";
    case FaultCause::kNodeReset:
      return "node reset";
    case FaultCause::kEmcy:
      return "EMCY";
    case FaultCause::kDriveFault:
      return "drive fault";
    case FaultCause::kDriveStuck:
      return "drive stuck";
    case FaultCause::kDriveEnergized:
      return "drive not disabled";
    case FaultCause::kOverruns:
      return "overruns";
    case FaultCause::kEncoderTimeout:
      return "encoder timeout";
    case FaultCause::kEncoderJump:
      return "encoder jump";
    case FaultCause::kOutOfRange:
      return "out of range";
    case FaultCause::kNonFinite:
      return "non-finite value";
    case FaultCause::kNonFiniteTorque:
      return "non-finite torque";
    case FaultCause::kSafeStopTimeout:
      return "safe stop timeout";
    case FaultCause::kForceOutOfRange:
      return "force out of range";
    case FaultCause::kForceTimeout:
      return "force reading timeout";
    case FaultCause::kPeerFault:
      return "peer fault";
  }
  return "unknown";
}

SafetySupervisor::SafetySupervisor(const SafetySettings& settings)
    : settings_(validated(settings)), lifecycle_(settings) {
  n_ = settings_.num_axes;
}

const FaultRecord* SafetySupervisor::fault_log_at(std::size_t i) const noexcept {
  if (i >= log_size_) return nullptr;
  return &log_[(log_head_ + kFaultLogCapacity - log_size_ + i) % kFaultLogCapacity];
}

void SafetySupervisor::record(FaultCause cause, std::uint8_t id, double value,
                              bool latching) noexcept {
  const FaultRecord r{cause, id, value, now_ns_, period_, latching};
  log_[log_head_] = r;
  log_head_ = (log_head_ + 1) % kFaultLogCapacity;
  if (log_size_ < kFaultLogCapacity) {
    ++log_size_;
  } else {
    ++counters_.records_overwritten;
  }
  ++counters_.records;
  if (latching) {
    first_ = r;
    has_first_ = true;
    latch_this_period_ = true;
  }
}

LifecycleResult SafetySupervisor::rearm() noexcept {
  const LifecycleResult r = lifecycle_.rearm();
  if (r == LifecycleResult::kOk) has_first_ = false;
  return r;
}

FaultRecord SafetySupervisor::find_present(const SafetyInputs& in,
                                           bool drives_disabled) const noexcept {
  FaultRecord p;
  p.time_ns = now_ns_;
  p.period = period_;
  auto found = [&p](FaultCause c, std::size_t id, double value) {
    p.cause = c;
    p.id = static_cast<std::uint8_t>(id);
    p.value = value;
    return p;
  };
  if (in.periods_since_accepted.size() < n_ || in.axis_faults.size() < n_ ||
      in.drives.size() > kMaxSupervisedDrives) {
    return found(FaultCause::kBadInput, 0, 0.0);
  }
  if (in.bus_state == BusState::kBusOff) {
    return found(FaultCause::kBusOff, 0, static_cast<double>(in.bus_state));
  }
  for (const HeartbeatConsumer& c : in.heartbeats) {
    if (c.node_id() == 0 || c.status() == HeartbeatStatus::kAlive) continue;
    const double silent = c.heard() ? static_cast<double>(now_ns_ - c.last_heard_ns()) * 1e-9 : 0.0;
    return found(c.status() == HeartbeatStatus::kBootedUnexpectedly ? FaultCause::kNodeReset
                                                                    : FaultCause::kHeartbeatLost,
                 c.node_id(), silent);
  }
  for (std::size_t i = 0; i < in.drives.size(); ++i) {
    const Cia402MasterOutput& d = in.drives[i];
    const double state = static_cast<double>(d.state);
    if (d.fault) return found(FaultCause::kDriveFault, i, state);
    if (d.stuck) return found(FaultCause::kDriveStuck, i, state);
  }
  if (!drives_disabled && !lifecycle_.torque_allowed()) {
    for (std::size_t i = 0; i < in.drives.size(); ++i) {
      if (!is_disabled(in.drives[i].state)) {
        return found(FaultCause::kDriveEnergized, i, static_cast<double>(in.drives[i].state));
      }
    }
  }
  if (consecutive_overruns_ >= settings_.overrun_limit) {
    return found(FaultCause::kOverruns, 0, consecutive_overruns_);
  }
  for (std::size_t a = 0; a < n_; ++a) {
    const FaultMask m = in.axis_faults[a];
    for (const SampleFaultCause& c : kSampleFaultCauses)
      if (m & c.bit) return found(c.cause, a, m);
    const std::uint32_t age = in.periods_since_accepted[a];
    if ((m & SampleFault::kNoData) || age >= settings_.encoder_timeout_periods) {
      return found(FaultCause::kEncoderTimeout, a, age);
    }
  }
  return p;
}

LifecycleUpdate SafetySupervisor::update(std::int64_t now_ns, const SafetyInputs& in) noexcept {
  period_ = counters_.updates;
  ++counters_.updates;
  now_ns_ = now_ns;
  latch_this_period_ = false;
  const LifecycleState st = lifecycle_.state();
  const bool supervising = st != LifecycleState::kUnconfigured;
  const bool can_latch = st == LifecycleState::kInactive || st == LifecycleState::kActive;
  // A cause detected this period: recorded (when supervising); the first one in a state that
  // can latch is the one that latches.
  auto event = [&](FaultCause cause, std::size_t id, double value) {
    if (supervising) {
      record(cause, static_cast<std::uint8_t>(id), value, can_latch && !latch_this_period_);
    }
  };

  // Inputs that do not match the configuration: missing axes read as "no data".
  const bool bad_input = in.periods_since_accepted.size() < n_ || in.axis_faults.size() < n_ ||
                         in.drives.size() > kMaxSupervisedDrives;
  if (bad_input && !bad_input_prev_) event(FaultCause::kBadInput, 0, 0.0);
  bad_input_prev_ = bad_input;

  const bool bus_off = in.bus_state == BusState::kBusOff;
  if (bus_off && !bus_off_prev_) event(FaultCause::kBusOff, 0, static_cast<double>(in.bus_state));
  bus_off_prev_ = bus_off;

  if (in.io_error && !io_error_prev_) event(FaultCause::kIoError, 0, 0.0);
  io_error_prev_ = in.io_error;

  // Heartbeats: the counters are events (a loss that already recovered still counts).
  for (const HeartbeatConsumer& c : in.heartbeats) {
    const std::uint8_t node = c.node_id();
    if (node == 0 || node > kMaxNodeId) continue;
    const HeartbeatConsumerCounters& k = c.counters();
    const HeartbeatFault& f = c.last_fault();
    const double silent = static_cast<double>(f.detected_ns - f.last_heard_ns) * 1e-9;
    if (k.losses > hb_losses_seen_[node]) event(FaultCause::kHeartbeatLost, node, silent);
    if (k.unexpected_boot_ups > hb_boot_ups_seen_[node]) {
      event(FaultCause::kNodeReset, node, silent);
    }
    hb_losses_seen_[node] = k.losses;
    hb_boot_ups_seen_[node] = k.unexpected_boot_ups;
  }

  if (in.emcy_faults > emcy_seen_) {
    const EmcyRecord* r = in.emcy_last_fault;
    event(FaultCause::kEmcy, r != nullptr ? r->message.node_id : 0,
          r != nullptr ? static_cast<double>(r->message.error_code) : 0.0);
  }
  emcy_seen_ = in.emcy_faults;

  bool drives_disabled = true;
  std::size_t first_energized = 0;
  const std::size_t n_drives = std::min(in.drives.size(), kMaxSupervisedDrives);
  for (std::size_t i = 0; i < n_drives; ++i) {
    const Cia402MasterOutput& d = in.drives[i];
    const double state = static_cast<double>(d.state);
    if (d.fault && !drive_fault_prev_[i]) event(FaultCause::kDriveFault, i, state);
    if (d.stuck && !drive_stuck_prev_[i]) event(FaultCause::kDriveStuck, i, state);
    drive_fault_prev_[i] = d.fault;
    drive_stuck_prev_[i] = d.stuck;
    if (drives_disabled && !is_disabled(d.state)) {
      drives_disabled = false;
      first_energized = i;
    }
  }
  if (in.drives.size() > kMaxSupervisedDrives) drives_disabled = false;

  if (in.overrun) {
    ++counters_.overruns;
    if (consecutive_overruns_ < std::numeric_limits<std::uint32_t>::max()) ++consecutive_overruns_;
    if (consecutive_overruns_ == settings_.overrun_limit) {
      event(FaultCause::kOverruns, 0, consecutive_overruns_);
    }
  } else {
    consecutive_overruns_ = 0;
  }

  for (std::size_t a = 0; a < n_; ++a) {
    const FaultMask m = a < in.axis_faults.size() ? in.axis_faults[a]
                                                  : static_cast<FaultMask>(SampleFault::kNoData);
    const std::uint32_t age = a < in.periods_since_accepted.size()
                                  ? in.periods_since_accepted[a]
                                  : std::numeric_limits<std::uint32_t>::max();
    const FaultMask rising = static_cast<FaultMask>(m & ~prev_mask_[a]);
    for (const SampleFaultCause& c : kSampleFaultCauses)
      if (rising & c.bit) event(c.cause, a, m);
    // The timeout is armed once the axis has had a value; in kActive always (an axis that lost
    // its value while active, e.g. after InstrumentDevice::reset(), must time out too).
    const bool armed = st == LifecycleState::kActive || (m & SampleFault::kNoData) == 0;
    const bool timed_out = armed && age >= settings_.encoder_timeout_periods;
    if (timed_out && !timeout_active_[a]) event(FaultCause::kEncoderTimeout, a, age);
    timeout_active_[a] = timed_out;
    if (supervising && !timed_out && (m & kLatchingSampleBits) == 0 &&
        (m & (SampleFault::kStale | SampleFault::kMalformed)) != 0) {
      ++counters_.rejected_samples;
    }
    prev_mask_[a] = m;
  }

  blocking_ = find_present(in, drives_disabled);
  LifecycleInputs li;
  li.fault = latch_this_period_;
  li.cause_present = blocking_.cause != FaultCause::kNone;
  li.drives_disabled = drives_disabled;
  const LifecycleUpdate u = lifecycle_.update(now_ns, li);
  if (u.entered_safe_stop) ++counters_.latches;
  if (u.timed_out) {
    record(FaultCause::kSafeStopTimeout, static_cast<std::uint8_t>(first_energized),
           lifecycle_.safe_stop_periods(), false);
  }
  return u;
}

void SafetySupervisor::trip_non_finite_torque(std::size_t axis) noexcept {
  ++counters_.non_finite_torques;
  trip(FaultCause::kNonFiniteTorque, static_cast<std::uint8_t>(axis), 0.0);
}

void SafetySupervisor::trip(FaultCause cause, std::uint8_t id, double value) noexcept {
  latch_this_period_ = false;
  record(cause, id, value, true);
  if (lifecycle_.trip().entered_safe_stop) ++counters_.latches;
}

}  // namespace numen::hal
