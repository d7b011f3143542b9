/// @file igtl_tracker_bus.cpp
/// The OpenIGTLink tracker as the encoders of a pose tracker (igtl_tracker_bus.hpp).

#include "numen/hal/igtl/igtl_tracker_bus.hpp"

#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/axis.hpp"

namespace numen::hal {

namespace {

std::int64_t igtl_bus_mono_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void check_igtl_pose(const core::Pose& p, const char* name) {
  if (!p.position.allFinite() || !(std::abs(p.orientation.norm() - 1.0) <= 1e-6))
    throw std::invalid_argument(std::string("OpenIGTLink tracker: ") + name +
                                " must have a finite position and a unit quaternion");
}

}  // namespace

std::shared_ptr<IgtlTrackerClient> make_igtl_tracker_client(const IgtlTrackerSettings& settings) {
  IgtlTrackerClientSettings cs = settings.client;
  cs.wait_when_full = settings.wait_for_tracker;
  cs.reconnect = cs.reconnect && !settings.wait_for_tracker;  // a replay's end is the end
  return std::make_shared<IgtlTrackerClient>(std::move(cs));
}

IgtlTrackerBus::IgtlTrackerBus(const DeviceConfig& config,
                               std::unique_ptr<const Kinematics> kinematics,
                               IgtlTrackerSettings settings)
    : IgtlTrackerBus(config, std::move(kinematics), settings, nullptr, 0) {}

IgtlTrackerBus::IgtlTrackerBus(const DeviceConfig& config,
                               std::unique_ptr<const Kinematics> kinematics,
                               IgtlTrackerSettings settings,
                               std::shared_ptr<IgtlTrackerClient> client, std::size_t tool)
    : config_(config), kinematics_(std::move(kinematics)), settings_(std::move(settings)),
      tool_(tool) {
  if (config_.kind != DeviceKind::kPoseTracker)
    throw std::invalid_argument(
        "OpenIGTLink tracker: the device must be a pose tracker (kind = \"pose-tracker\")");
  if (!kinematics_ || kinematics_->num_axes() != static_cast<int>(config_.axes.size()))
    throw std::invalid_argument("OpenIGTLink tracker: the kinematics must have the device's axes");
  if (!std::isfinite(settings_.metres_per_unit) || !(settings_.metres_per_unit > 0.0))
    throw std::invalid_argument("OpenIGTLink tracker: metres_per_unit must be finite and > 0");
  if (settings_.wait_timeout_ns <= 0)
    throw std::invalid_argument("OpenIGTLink tracker: wait_timeout_ns must be > 0");
  check_igtl_pose(settings_.calibration, "calibration");
  check_igtl_pose(settings_.registration, "registration");
  settings_.calibration.orientation.normalize();
  settings_.registration.orientation.normalize();
  q_ = AxisVector::Zero(kinematics_->num_axes());
  max_sample_age_ns_ = std::llround(std::min(config_.effective_max_sample_age_s(), 1e6) * 1e9);
  latencies_.reserve(std::max<std::size_t>(settings_.latency_capacity, 1));
  if (settings_.registration_wait_ns <= 0)
    throw std::invalid_argument("OpenIGTLink tracker: registration_wait_ns must be > 0");
  if (settings_.max_stamp_gap_ns <= 0)
    throw std::invalid_argument("OpenIGTLink tracker: max_stamp_gap_ns must be > 0");
  if (settings_.resync_after < 2)
    throw std::invalid_argument("OpenIGTLink tracker: resync_after must be >= 2");
  client_ = client ? std::move(client) : make_igtl_tracker_client(settings_);
  if (tool_ >= client_->tool_count())
    throw std::invalid_argument("OpenIGTLink tracker: tool " + std::to_string(tool_) +
                                " of a receiver of " + std::to_string(client_->tool_count()));
  if (!client_->settings().registration_name.empty()) take_registration();
}

void IgtlTrackerBus::take_registration() {
  const IgtlTrackerClientSettings& cs = client_->settings();
  const std::int64_t end = igtl_bus_mono_ns() + settings_.registration_wait_ns;
  std::optional<IgtlTransform> r = client_->registration();
  while (!r && igtl_bus_mono_ns() < end && !(client_->ended() && !client_->connected())) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    r = client_->registration();
  }
  if (!r) r = client_->registration();  // it may have come just before the stream ended
  if (!r) {
    const IgtlClientCounters c = client_->counters();
    std::string names;
    for (const std::string& n : client_->names_seen()) names += (names.empty() ? "'" : ", '") + n + "'";
    char wait[32];
    std::snprintf(wait, sizeof wait, "%g s", static_cast<double>(settings_.registration_wait_ns) * 1e-9);
    const std::string what =
        "no TRANSFORM '" + cs.registration_name + "' (the registration) from " + cs.host + ":" +
        std::to_string(cs.port);
    if (const std::optional<IgtlFaultRecord> refused = client_->registration_refused())
      throw IgtlRegistrationMissing("a " + refused->type + " '" + cs.registration_name +
                                    "' (the registration) from " + cs.host + ":" +
                                    std::to_string(cs.port) +
                                    " arrived and was refused: " + to_string(refused->fault) +
                                    " (" + describe(*refused) + "); none accepted within " + wait);
    if (c.connects == 0)
      throw IgtlRegistrationMissing(what + ": never connected (" +
                                    std::to_string(c.connect_failures) +
                                    " attempts refused or timed out)");
    throw IgtlRegistrationMissing(what + " within " + wait + " (" + std::to_string(c.messages) +
                                  " messages; other device names sent: " +
                                  (names.empty() ? "none" : names) + ")");
  }
  settings_.registration = core::Pose{r->translation * settings_.metres_per_unit,
                                      core::Quat(r->rotation).normalized()};
}

IgtlTrackerBus::~IgtlTrackerBus() = default;

BusState IgtlTrackerBus::state() const noexcept {
  if (client_->connected()) return BusState::kOk;
  const IgtlClientCounters c = client_->counters();
  return c.connects > 0 || c.connect_failures > 0 || client_->ended() ? BusState::kBusOff
                                                                      : BusState::kOk;
}

void IgtlTrackerBus::set_time_ns(std::int64_t t_ns) noexcept {
  now_ns_ = t_ns;
  if (!has_origin_) {
    origin_mono_ns_ = igtl_bus_mono_ns() - t_ns;
    has_origin_ = true;
  }
}

std::int64_t IgtlTrackerBus::bus_time_of(const IgtlPose& p) noexcept {
  if (settings_.wait_for_tracker) {
    if (!has_first_stamp_) {
      first_stamp_ns_ = p.stamp_ns;
      has_first_stamp_ = true;
    }
    return p.stamp_ns - first_stamp_ns_ + shift_ns_;
  }
  // Paced: the sender's clock through the smallest one-way delay seen (an unstamped message,
  // stamp 0, is its receive time).
  if (p.stamp_ns == 0) return p.received_mono_ns - origin_mono_ns_;
  const std::int64_t offset = p.received_mono_ns - p.stamp_ns;
  if (!has_offset_ || offset < offset_ns_) {
    offset_ns_ = offset;
    has_offset_ = true;
  }
  return p.stamp_ns + offset_ns_ - origin_mono_ns_;
}

bool IgtlTrackerBus::stamp_acceptable(const IgtlPose& p) noexcept {
  if (p.stamp_ns == 0) {
    if (!settings_.wait_for_tracker) return true;  // paced: its receive time
    ++tracker_counters_.stamps_unstamped;          // following: no place on the tracker's clock
    return false;
  }
  if (!has_last_stamp_) return true;
  const std::int64_t gap = p.stamp_ns - last_stamp_ns_;
  const bool backwards = gap < 0;
  if (!backwards && gap <= settings_.max_stamp_gap_ns) {
    refused_run_ = 0;
    return true;
  }
  // Going on from the previous refused pose: a clock that jumped, not one bad stamp.
  const std::int64_t on = p.stamp_ns - refused_stamp_ns_;
  refused_run_ =
      refused_run_ > 0 && on >= 0 && on <= settings_.max_stamp_gap_ns ? refused_run_ + 1 : 1;
  refused_stamp_ns_ = p.stamp_ns;
  if (refused_run_ >= settings_.resync_after) {  // re-based on this pose
    ++tracker_counters_.stamp_resyncs;
    refused_run_ = 0;
    rebase_on(p);
    return true;
  }
  ++(backwards ? tracker_counters_.stamps_backwards : tracker_counters_.stamps_ahead);
  return false;
}

void IgtlTrackerBus::rebase_on(const IgtlPose& p) noexcept {
  if (settings_.wait_for_tracker)
    shift_ns_ = now_ns_ - (p.stamp_ns - first_stamp_ns_);  // bus_time_of(p) = now_ns_
  else
    has_offset_ = false;  // the sender's clock offset measured again from this pose
}

void IgtlTrackerBus::take(const IgtlPose& p, std::int64_t now_mono) noexcept {
  std::int64_t t = bus_time_of(p);
  const bool first = tracker_counters_.poses_taken == 0;
  // After a silence, a pose that would arrive stale (a sender that paused and goes on from its
  // old stamps): the stream is re-based on it, taken at this SYNC (the file comment).
  if (!first && now_ns_ - pose_time_ns_ > max_sample_age_ns_ && t < now_ns_ - max_sample_age_ns_) {
    ++tracker_counters_.silence_rebases;
    rebase_on(p);
    t = bus_time_of(p);  // following: now_ns_
  }
  if (p.stamp_ns != 0) {
    last_stamp_ns_ = p.stamp_ns;
    has_last_stamp_ = true;
  }
  ++tracker_counters_.poses_taken;
  if (latencies_.size() < latencies_.capacity()) latencies_.push_back(now_mono - p.received_mono_ns);
  // The tip in the world: registration · marker · calibration
  const core::Quat marker_q(p.rotation);
  const core::Vec3 marker_p = p.translation * settings_.metres_per_unit;
  const core::Pose& reg = settings_.registration;
  const core::Pose& cal = settings_.calibration;
  core::Pose world;
  world.orientation = (reg.orientation * marker_q * cal.orientation).normalized();
  world.position = reg.position + reg.orientation * (marker_p + marker_q * cal.position);
  last_pose_ = world;
  // The controlled frame the kinematics inverts: the tip · tool_offset (as forward() makes it).
  const core::Pose& off = config_.tool_offset;
  const core::Pose controlled{world.position + world.orientation * off.position,
                              (world.orientation * off.orientation).normalized()};
  q_ = kinematics_->inverse(controlled, q_);
  pose_time_ns_ = first ? t : std::max(t, pose_time_ns_);  // a stamp never goes back
  pose_received_mono_ns_ = p.received_mono_ns;
  has_pose_ = true;
}

void IgtlTrackerBus::on_sync() noexcept {
  ++tracker_counters_.syncs;
  int taken = 0;
  bool paced_this_sync = false;
  const std::int64_t wait_until =
      settings_.wait_for_tracker ? igtl_bus_mono_ns() + settings_.wait_timeout_ns : 0;
  for (;;) {
    const IgtlPose* p = client_->front(tool_);
    if (p == nullptr) {
      // Following the tracker: wait for a pose after t unless the receiver has ended.
      if (client_->ended()) {
        if (taken == 0) ++tracker_counters_.syncs_after_end;
        break;
      }
      if (!settings_.wait_for_tracker) break;
      if (starved_) {
        // A wait that ran out is not repeated every period (a silent server holds the run up
        // once, not once a period), but the SYNCs go no faster than the tracker's clock: real
        // time since its newest pose (at once before any).
        if (!has_pose_) break;
        const std::int64_t due = pose_received_mono_ns_ + (now_ns_ - pose_time_ns_);
        if (igtl_bus_mono_ns() >= due) break;
        if (!paced_this_sync) {
          paced_this_sync = true;
          ++tracker_counters_.silent_paced_syncs;
        }
      } else if (igtl_bus_mono_ns() >= wait_until) {
        ++tracker_counters_.wait_timeouts;
        starved_ = true;
        break;
      }
      const timespec ts{0, 20'000};
      nanosleep(&ts, nullptr);
      continue;
    }
    // Following: the time origin is the connection's first pose, of any tool (the buses of
    // one connection share it); set before that pose was queued.
    if (settings_.wait_for_tracker && !has_first_stamp_)
      has_first_stamp_ = client_->first_stamp_ns(first_stamp_ns_);
    if (!stamp_acceptable(*p)) {  // refused and counted: the next pose is looked at
      client_->pop(tool_);
      continue;
    }
    if (settings_.wait_for_tracker && has_first_stamp_ &&
        p->stamp_ns - first_stamp_ns_ + shift_ns_ > now_ns_)
      break;  // due later
    starved_ = false;
    if (taken++ > 0) ++tracker_counters_.poses_superseded;
    take(*p, igtl_bus_mono_ns());
    client_->pop(tool_);
  }
  pending_count_ = 0;
  pending_next_ = 0;
  if (!has_pose_) {
    ++tracker_counters_.syncs_without_pose;
    return;
  }
  for (std::size_t i = 0; i < config_.axes.size(); ++i) {
    const AxisConfig& a = config_.axes[i];
    pending_[static_cast<std::size_t>(pending_count_++)] = encode_position_pdo(
        a.encoder_cob_id, value_to_counts(a, q_(static_cast<Eigen::Index>(i))), pose_time_ns_);
  }
}

IoStatus IgtlTrackerBus::read(CanFrame& frame) noexcept {
  if (pending_next_ >= pending_count_) return IoStatus::kWouldBlock;
  frame = pending_[static_cast<std::size_t>(pending_next_++)];
  ++counters_.frames_rx;
  return IoStatus::kOk;
}

IoStatus IgtlTrackerBus::write(const CanFrame& frame) noexcept {
  if (check_frame(frame) != FrameError::kNone) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  ++counters_.frames_tx;
  if (is_sync(frame)) on_sync();
  return IoStatus::kOk;
}

std::vector<std::int64_t> IgtlTrackerBus::latency_ns() const { return latencies_; }

}  // namespace numen::hal
