/// @file force_sensor.cpp

#include "numen/hal/device/force_sensor.hpp"

#include <cmath>
#include <cstdlib>
#include <span>
#include <stdexcept>

namespace numen::hal {
namespace {

constexpr std::int64_t kSaturated = 32767;

bool positive(double v) noexcept { return std::isfinite(v) && v > 0.0; }

void check_cob_id(std::uint32_t id, const std::string& name, const char* field) {
  if (id < 0x001 || id > 0x7FF || (id >= 0x080 && id <= 0x0FF) || (id >= 0x700 && id <= 0x77F))
    throw std::invalid_argument(name + ": " + field + " " + std::to_string(id) +
                                " is not a free 11-bit PDO COB-ID (0x001–0x7FF outside "
                                "0x080–0x0FF and 0x700–0x77F)");
}

std::int64_t to_counts(double value, double scale) noexcept {
  if (!std::isfinite(value)) return kSaturated;
  const double c = std::round(value / scale);
  if (c >= static_cast<double>(kSaturated)) return kSaturated;
  if (c <= -static_cast<double>(kSaturated)) return -kSaturated;
  return static_cast<std::int64_t>(c);
}

bool saturated(const std::array<std::int64_t, 3>& c) noexcept {
  for (std::int64_t v : c)
    if (v >= kSaturated || v <= -kSaturated) return true;
  return false;
}

}  // namespace

PdoMapping force_tpdo_mapping() {
  return PdoMapping(
      {ForceSensorObject::kForceX, ForceSensorObject::kForceY, ForceSensorObject::kForceZ},
      "force TPDO");
}

PdoMapping torque_tpdo_mapping() {
  return PdoMapping(
      {ForceSensorObject::kTorqueX, ForceSensorObject::kTorqueY, ForceSensorObject::kTorqueZ},
      "torque TPDO");
}

void validate(const ForceSensorConfig& c, const std::string& name) {
  if (c.node_id < 1 || c.node_id > 127)
    throw std::invalid_argument(name + ": node_id " + std::to_string(c.node_id) + " outside 1–127");
  check_cob_id(c.effective_force_cob_id(), name, "force_cob_id");
  check_cob_id(c.effective_torque_cob_id(), name, "torque_cob_id");
  if (c.effective_force_cob_id() == c.effective_torque_cob_id())
    throw std::invalid_argument(name + ": force_cob_id and torque_cob_id are equal");
  if (!positive(c.force_scale)) throw std::invalid_argument(name + ": force_scale must be > 0");
  if (!positive(c.torque_scale)) throw std::invalid_argument(name + ": torque_scale must be > 0");
  if (!positive(c.max_force)) throw std::invalid_argument(name + ": max_force must be > 0");
  if (!positive(c.max_torque)) throw std::invalid_argument(name + ": max_torque must be > 0");
  if (!positive(c.max_age_s)) throw std::invalid_argument(name + ": max_age must be > 0");
  if (!c.sensor_in_tool.position.allFinite() ||
      !c.sensor_in_tool.orientation.coeffs().allFinite() ||
      std::abs(c.sensor_in_tool.orientation.norm() - 1.0) > 1e-6)
    throw std::invalid_argument(name + ": sensor_in_tool must be finite with a unit quaternion");
}

void encode_force_tpdos(const ForceSensorConfig& config, const core::Wrench& wrench,
                        std::int64_t timestamp_ns, CanFrame& force_frame,
                        CanFrame& torque_frame) noexcept {
  // Three INTEGER16 little endian, as force_tpdo_mapping() / torque_tpdo_mapping() lay out.
  const auto put = [&](CanFrame& f, std::uint32_t id, const core::Vec3& v, double scale) {
    f = CanFrame{};
    f.id = id;
    f.len = 6;
    f.timestamp_ns = timestamp_ns;
    for (int i = 0; i < 3; ++i) {
      const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(to_counts(v[i], scale)));
      f.data[static_cast<std::size_t>(2 * i)] = static_cast<std::uint8_t>(u & 0xFF);
      f.data[static_cast<std::size_t>(2 * i + 1)] = static_cast<std::uint8_t>(u >> 8);
    }
  };
  put(force_frame, config.effective_force_cob_id(), wrench.force, config.force_scale);
  put(torque_frame, config.effective_torque_cob_id(), wrench.torque, config.torque_scale);
}

ForceSensor::ForceSensor(const ForceSensorConfig& config)
    : config_(config),
      force_map_(force_tpdo_mapping()),
      torque_map_(torque_tpdo_mapping()),
      force_id_(config.effective_force_cob_id()),
      torque_id_(config.effective_torque_cob_id()) {
  validate(config_);
}

bool ForceSensor::on_frame(const CanFrame& frame) noexcept {
  const bool is_force = has_standard_id(frame, force_id_);
  const bool is_torque = has_standard_id(frame, torque_id_);
  if (!is_force && !is_torque) return false;
  ++counters_.frames;
  std::array<std::int64_t, 3> v{};
  const PdoMapping& map = is_force ? force_map_ : torque_map_;
  if (map.unpack(frame, std::span<std::int64_t>(v.data(), v.size())) != PdoStatus::kOk) {
    ++counters_.malformed;
    malformed_ = true;
    return true;
  }
  if (is_force) {
    force_counts_ = v;
    force_stamp_ns_ = frame.timestamp_ns;
    have_force_ = true;
  } else {
    torque_counts_ = v;
    torque_stamp_ns_ = frame.timestamp_ns;
    have_torque_ = true;
  }
  return true;
}

ForceSample ForceSensor::sample(std::int64_t now_ns) noexcept {
  ForceSample s;
  FaultMask f = malformed_ ? SampleFault::kMalformed : SampleFault::kNone;
  malformed_ = false;
  if (!have_force_ || !have_torque_) {
    f |= SampleFault::kNoData;
  } else {
    const auto max_age = static_cast<std::int64_t>(std::llround(config_.max_age_s * 1e9));
    if (std::llabs(now_ns - force_stamp_ns_) > max_age ||
        std::llabs(now_ns - torque_stamp_ns_) > max_age) {
      f |= SampleFault::kStale;
      ++counters_.stale;
    } else {
      core::Wrench w;
      for (int i = 0; i < 3; ++i) {
        w.force[i] =
            static_cast<double>(force_counts_[static_cast<std::size_t>(i)]) * config_.force_scale;
        w.torque[i] =
            static_cast<double>(torque_counts_[static_cast<std::size_t>(i)]) * config_.torque_scale;
      }
      if (saturated(force_counts_) || saturated(torque_counts_) ||
          !(w.force.norm() <= config_.max_force) || !(w.torque.norm() <= config_.max_torque)) {
        f |= SampleFault::kOutOfRange;
        ++counters_.out_of_range;
      } else if (f == SampleFault::kNone) {
        accepted_ = w;
      }
    }
  }
  s.valid = f == SampleFault::kNone;
  if (s.valid) {
    ++counters_.accepted;
    since_valid_ = 0;
  } else if (since_valid_ < 0xFFFFFFFFu) {
    ++since_valid_;
  }
  s.faults = f;
  s.wrench = accepted_;
  s.periods_since_valid = since_valid_;
  return s;
}

}  // namespace numen::hal
