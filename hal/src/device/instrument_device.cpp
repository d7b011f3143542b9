/// @file instrument_device.cpp
/// Controller-side instrument driver: TPDOs -> checked target poses/twists per link;
/// link wrenches -> τ = Σ J_lᵀ w_l.

#include "numen/hal/device/instrument_device.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/device/kinematics_factory.hpp"

namespace numen::hal {
namespace {


}  // namespace

InstrumentDevice::InstrumentDevice(DeviceConfig config)
    : InstrumentDevice(config, make_kinematics(config)) {}

InstrumentDevice::InstrumentDevice(DeviceConfig config,
                                   std::unique_ptr<const Kinematics> kinematics)
    : config_(std::move(config)), kinematics_(std::move(kinematics)) {
  validate(config_);
  if (!kinematics_) {
    throw std::invalid_argument("device '" + config_.name + "': kinematics must not be null");
  }
  n_ = static_cast<int>(config_.axes.size());
  if (kinematics_->num_axes() != n_) {
    throw std::invalid_argument("device '" + config_.name + "': kinematics has " +
                                std::to_string(kinematics_->num_axes()) +
                                " axes but config.axes has " + std::to_string(n_));
  }
  num_links_ = kinematics_->num_links();
  if (num_links_ < 1 || num_links_ > kMaxLinks) {
    throw std::invalid_argument("device '" + config_.name + "': kinematics has " +
                                std::to_string(num_links_) + " links (must be 1.." +
                                std::to_string(kMaxLinks) + ")");
  }
  const double age = config_.effective_max_sample_age_s();
  use_foaw_ = config_.velocity_estimator == VelocityEstimator::kFoaw;
  hold_.resize(n_);
  for (int i = 0; i < n_; ++i) {
    const AxisConfig& a = config_.axes[static_cast<std::size_t>(i)];
    limits_[static_cast<std::size_t>(i)] = make_check_limits(a, age, config_.jump_tolerance_counts);
    hold_[i] = std::clamp(0.0, a.min, a.max);
    const double cutoff = config_.velocity_estimator == VelocityEstimator::kDifference
                              ? std::numeric_limits<double>::infinity()
                              : config_.velocity_cutoff_hz;
    rates_[static_cast<std::size_t>(i)] = RateEstimator(cutoff, a.max_speed, a.wraps);
    foaws_[static_cast<std::size_t>(i)] =
        FoawEstimator(config_.foaw_max_window, config_.foaw_noise_counts / a.counts_per_unit,
                      a.max_speed, a.wraps);
  }
  if (config_.canopen.managed) {
    for (int i = 0; i < n_; ++i) {
      const auto& e = config_.canopen.axes[static_cast<std::size_t>(i)].encoder_tpdo;
      encoder_maps_.emplace_back(std::span<const PdoEntry>(e.data(), e.size()), "encoder TPDO");
      int p = find_mapped(encoder_maps_.back().entries(), PdoObject::kPositionValue);
      if (p < 0) p = find_mapped(encoder_maps_.back().entries(), PdoObject::kPositionActualValue);
      encoder_position_[static_cast<std::size_t>(i)] = p;
    }
  }
  reset();
}

void InstrumentDevice::reset() noexcept {
  axes_ = {};
  for (RateEstimator& r : rates_) r.reset();
  for (FoawEstimator& r : foaws_) r.reset();
  last_sample_ = DeviceSample{};
  last_sample_.q = hold_;
  last_sample_.qdot = AxisVector::Zero(n_);
  last_sample_.dq = AxisVector::Zero(n_);
  last_sample_.pose = kinematics_->forward(hold_);
  for (int i = 0; i < n_; ++i)
    last_sample_.axis_faults[static_cast<std::size_t>(i)] = SampleFault::kNoData;
  last_sample_.faults = n_ > 0 ? SampleFault::kNoData : SampleFault::kNone;
  evaluate_links(last_sample_);
}

void InstrumentDevice::evaluate_links(DeviceSample& s) noexcept {
  s.num_links = num_links_;
  s.pose = kinematics_->forward(s.q);
  link_jacobians_[0] = kinematics_->jacobian(s.q);
  s.twist = twist_from_rates(link_jacobians_[0], s.qdot);
  s.link_poses[0] = s.pose;
  s.link_twists[0] = s.twist;
  for (int l = 1; l < num_links_; ++l) {
    const auto k = static_cast<std::size_t>(l);
    s.link_poses[k] = kinematics_->link_pose(l, s.q);
    link_jacobians_[k] = kinematics_->link_jacobian(l, s.q);
    s.link_twists[k] = twist_from_rates(link_jacobians_[k], s.qdot);
  }
}

bool InstrumentDevice::on_frame(const CanFrame& frame) noexcept {
  if (frame.error_frame()) {  // bus-state information (Bus::state()), not an axis's message
    ++counters_.frames_error;
    return false;
  }
  for (int i = 0; i < n_; ++i) {
    const AxisConfig& a = config_.axes[static_cast<std::size_t>(i)];
    if (!has_standard_id(frame, a.encoder_cob_id)) continue;
    AxisState& st = axes_[static_cast<std::size_t>(i)];
    std::int32_t counts = 0;
    DecodeStatus status = DecodeStatus::kOk;
    if (encoder_maps_.empty()) {
      status = decode_position_pdo(frame, a.encoder_cob_id, counts);
    } else {
      const PdoMapping& m = encoder_maps_[static_cast<std::size_t>(i)];
      PdoValues v{};
      switch (m.unpack(frame, std::span<std::int64_t>(v.data(), m.size()))) {
        case PdoStatus::kOk:
          // 0x6004 read as int32 (an UNSIGNED32 mapping wraps to the same 32 bits).
          counts = static_cast<std::int32_t>(static_cast<std::uint32_t>(
              v[static_cast<std::size_t>(encoder_position_[static_cast<std::size_t>(i)])]));
          break;
        case PdoStatus::kNotDataFrame:
          status = DecodeStatus::kNotDataFrame;
          break;
        default:
          status = DecodeStatus::kWrongLength;
          break;
      }
    }
    switch (status) {
      case DecodeStatus::kOk: {
        ++counters_.frames_decoded;
        // The value and its range check, once, where it is decoded; a value that a newer
        // frame replaces before sample() keeps its range fault (superseded).
        const double q = counts_to_value(a, counts);
        if (st.pending) st.superseded |= st.pending_range;
        st.pending = true;
        st.malformed = false;
        st.pending_q = q;
        st.pending_range = check_range(limits_[static_cast<std::size_t>(i)], q);
        st.pending_stamp_ns = frame.timestamp_ns;
        break;
      }
      case DecodeStatus::kWrongLength:
        ++counters_.frames_wrong_length;
        st.pending = false;
        st.malformed = true;
        break;
      case DecodeStatus::kNotDataFrame:
        ++counters_.frames_not_data;
        if (frame.fd()) ++counters_.frames_fd;
        else if (frame.remote()) ++counters_.frames_remote;
        st.pending = false;
        st.malformed = true;
        break;
      case DecodeStatus::kWrongId:  // cannot happen: the id matched
        break;
    }
    return true;
  }
  ++counters_.frames_unknown_id;
  return false;
}

DeviceSample InstrumentDevice::sample(std::int64_t now_ns) noexcept {
  DeviceSample& s = last_sample_;
  // The displacement's base: the last sample's values, if that sample was valid.
  const bool moved_from_valid = s.valid;
  s.time_ns = now_ns;
  s.faults = SampleFault::kNone;
  s.axis_faults = {};
  bool ready = true;
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const AxisCheckLimits& lim = limits_[k];
    AxisState& st = axes_[k];
    FaultMask f = SampleFault::kNone;
    bool accepted = false;
    if (st.malformed) {
      f |= SampleFault::kMalformed;
    } else if (st.pending) {
      // The range was checked where the value was decoded (on_frame); here its freshness and
      // its jump from the last accepted value (check_sample()'s rule: a non-finite value is
      // checked for nothing else).
      const double q = st.pending_q;
      const FaultMask c =
          ((st.pending_range & SampleFault::kNonFinite) != 0
               ? st.pending_range
               : st.pending_range | check_fresh(lim, st.pending_stamp_ns, now_ns) |
                     check_jump(lim, q, st.pending_stamp_ns, st.has_value ? &st.last : nullptr)) |
          st.superseded;
      if (c == SampleFault::kNone) {
        if (use_foaw_) {
          foaws_[k].update(q, st.pending_stamp_ns);
        } else {
          rates_[k].update(q, st.pending_stamp_ns);
        }
        st.last = AcceptedValue{q, st.pending_stamp_ns};
        st.has_value = true;
        accepted = true;
        ++counters_.values_accepted;
      }
      f |= c;
    }
    // A value that this period's newest frame replaced was out of range: the period's value is
    // rejected with it (the check above saw only the newest).
    f |= st.superseded;
    st.superseded = SampleFault::kNone;
    st.pending = false;
    st.malformed = false;

    // The held value's own freshness: with no new accepted value it may have gone stale. A
    // rejected or missing value holds the rate (the hand has not stopped; the next accepted
    // difference spans the gap at its own Δt); a stale one zeroes it and restarts the filter
    // from the next accepted value: the hand's motion is unknown, and a rate fed forward on a
    // frozen target would drag the tool past it for as long as the encoder is silent.
    bool held_stale = false;
    if (st.has_value) {
      held_stale = check_fresh(lim, st.last.time_ns, now_ns) != SampleFault::kNone;
      if (!accepted && held_stale) {
        f |= SampleFault::kStale;
        rates_[k].reset();
        foaws_[k].reset();
      }
    }

    if (f != SampleFault::kNone) {
      ++counters_.values_rejected;
      if (f & SampleFault::kMalformed) ++counters_.rejected_malformed;
      if (f & SampleFault::kNonFinite) ++counters_.rejected_non_finite;
      if (f & SampleFault::kOutOfRange) ++counters_.rejected_out_of_range;
      if (f & SampleFault::kStale) ++counters_.rejected_stale;
      if (f & SampleFault::kJump) ++counters_.rejected_jump;
    }
    if (!st.has_value) {
      f |= SampleFault::kNoData;
      ready = false;
    }
    const double q = st.has_value ? st.last.q : hold_[i];
    s.dq[i] = moved_from_valid ? axis_difference(q, s.q[i], config_.axes[k].wraps) : 0.0;
    s.q[i] = q;
    s.qdot[i] = use_foaw_ ? foaws_[k].rate() : rates_[k].rate();
    if (accepted) {
      st.periods_since_accepted = 0;
    } else if (st.periods_since_accepted < UINT32_MAX) {
      ++st.periods_since_accepted;
    }
    s.periods_since_accepted[k] = st.periods_since_accepted;
    s.axis_faults[k] = f;
    s.faults |= f;
  }
  s.ready = ready;
  s.valid = ready && s.faults == SampleFault::kNone;
  evaluate_links(s);
  ++counters_.samples;
  if (s.valid) ++counters_.samples_valid;
  return s;
}

void InstrumentDevice::torques_for(std::span<const core::Wrench> link_wrenches,
                                   AxisVector& tau) noexcept {
  ++counters_.commands;
  std::size_t used = link_wrenches.size();
  if (used > static_cast<std::size_t>(num_links_)) {
    ++counters_.extra_link_wrenches;
    used = static_cast<std::size_t>(num_links_);
  }
  if (!all_finite(link_wrenches.first(used))) ++counters_.non_finite_wrenches;
  tau = AxisVector::Zero(n_);
  torques_from_link_wrenches(std::span<const Jacobian>(link_jacobians_.data(), used),
                             link_wrenches.first(used), tau);
}

}  // namespace numen::hal
