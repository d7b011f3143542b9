/// @file scene_device.cpp
/// Scene file → the device: `[device]`, its axes, CANopen nodes and DCFs, feedback and
/// admittance (scene_device.hpp, docs/scenes.md "Device").

#include "scene_device.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "numen/platform/period_stages.hpp"
#include "numen/sim/scene/trocar_placement.hpp"
#include "toml_reader.hpp"

namespace numen::sim {
namespace {

using core::Quat;
using core::Vec3;

/// The start of the load warning of a scene whose device has neither drives nor
/// [device.feedback] (docs/scenes.md "[device.feedback]").
constexpr char kNoFeedbackNonHaptic[] = "no feedback: non-haptic device";

/// The hand's keys present in `h` (each finite and >= 0; absent: `hand` keeps its value).
void read_hand(const TomlTable& h, HandSettings& hand) {
  hand.mass = h.number_in("mass", 0.0, kInf, hand.mass);
  hand.stiffness = h.number_in("stiffness", 0.0, kInf, hand.stiffness);
  hand.damping = h.number_in("damping", 0.0, kInf, hand.damping);
  hand.rotational_inertia = h.number_in("rotational_inertia", 0.0, kInf, hand.rotational_inertia);
  hand.rotational_stiffness = h.number_in("rotational_stiffness", 0.0, kInf, hand.rotational_stiffness);
  hand.rotational_damping = h.number_in("rotational_damping", 0.0, kInf, hand.rotational_damping);
}

hal::AxisConfig parse_axis(const TomlTable& a, hal::AxisConfig axis) {
  a.allow_only({"name", "encoder_cob_id", "drive_cob_id", "counts_per_unit", "offset_counts", "sign",
                "min", "max", "max_speed", "wraps", "rated_torque", "max_torque"});
  axis.name = a.string_or("name", axis.name);
  auto cob = [&](std::string_view key, std::uint32_t fallback) {
    const auto v = a.integer_or(key, fallback);
    if (v < 0 || v > 0x7FF) a.fail(key, "must be an 11-bit COB-ID in [0, 0x7FF]");
    return static_cast<std::uint32_t>(v);
  };
  axis.encoder_cob_id = cob("encoder_cob_id", axis.encoder_cob_id);
  axis.drive_cob_id = cob("drive_cob_id", axis.drive_cob_id);
  axis.counts_per_unit = a.number_in("counts_per_unit", 1e-12, kInf, axis.counts_per_unit);
  const auto off = a.integer_or("offset_counts", axis.offset_counts);
  if (off < INT32_MIN || off > INT32_MAX) a.fail("offset_counts", "must fit in int32");
  axis.offset_counts = static_cast<std::int32_t>(off);
  const auto sign = a.integer_or("sign", axis.sign);
  if (sign != 1 && sign != -1) a.fail("sign", "must be 1 or -1");
  axis.sign = static_cast<int>(sign);
  axis.min = a.number_or("min", axis.min);
  axis.max = a.number_or("max", axis.max);
  if (!(axis.min < axis.max)) a.fail("max", "must be greater than min");
  if (a.has("max_speed")) axis.max_speed = a.number_in("max_speed", 1e-12, kInf, std::nullopt);
  axis.wraps = a.boolean_or("wraps", axis.wraps);
  axis.rated_torque = a.number_in("rated_torque", 1e-12, kInf, axis.rated_torque);
  axis.max_torque = a.number_in("max_torque", 0.0, kInf, axis.max_torque);
  return axis;
}

/// A static PDO mapping: a list of CiA 301 mapping entries (index << 16 | subindex << 8 | bits,
/// e.g. 0x60710010), each one of the objects numen knows (find_known_pdo_object).
std::vector<hal::PdoEntry> parse_mapping(const TomlTable& t, std::string_view key,
                                         std::vector<hal::PdoEntry> fallback) {
  const toml::node* n = t.node(key);
  if (!n) return fallback;
  const toml::array* arr = n->as_array();
  if (!arr || arr->empty() || arr->size() > hal::kMaxPdoEntries)
    t.fail(key, "expected a list of 1 to 8 mapping entries such as 0x60710010 (index:sub:bits)");
  std::vector<hal::PdoEntry> out;
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const std::string k = t.key_path(key) + "[" + std::to_string(i) + "]";
    const auto* v = arr->get(i)->as_integer();
    if (!v || v->get() < 0 || v->get() > 0xFFFFFFFF)
      t.fail_at(arr->get(i), k, "expected a 32-bit mapping entry such as 0x60710010");
    hal::PdoEntry e;
    if (!hal::find_known_pdo_object(static_cast<std::uint32_t>(v->get()), e)) {
      char buf[16];
      std::snprintf(buf, sizeof buf, "0x%08llX", static_cast<unsigned long long>(v->get()));
      t.fail_at(arr->get(i), k,
                std::string(buf) +
                    " is not an object numen maps (0x60040020 position value, 0x60640020 position "
                    "actual value, 0x60400010 controlword, 0x60410010 statusword, 0x60710010 "
                    "target torque, 0x60770010 torque actual value, 0x60600008 modes of "
                    "operation, 0x60610008 modes of operation display)");
    }
    out.push_back(e);
  }
  return out;
}

std::uint16_t parse_ms(const TomlTable& t, std::string_view key, std::uint16_t fallback) {
  const auto v = t.integer_or(key, fallback);
  if (v < 1 || v > 65535) t.fail(key, "must be an integer number of ms in [1, 65535]");
  return static_cast<std::uint16_t>(v);
}

/// A DCF error as the scene's error: located in the DCF (file, line, "[section] key"), naming
/// the scene key that referenced the file.
InputError dcf_input_error(const hal::DcfError& e, const std::string& scene_key) {
  const hal::DcfLocation& l = e.location();
  std::string key = l.section.empty() ? "" : "[" + l.section + "]";
  if (!l.key.empty()) key += (key.empty() ? "" : " ") + l.key;
  return InputError(l.file, l.line, 0, key, e.message() + " (the DCF of " + scene_key + ")");
}

/// `dcf` of [device.canopen] (every node) and of each [[device.canopen.axis]] (its node):
/// read relative to the scene file, resolved for the node id, checked against the axis's
/// COB-IDs, mappings and heartbeat (hal::check_dcfs). Axes of one node share the parsed file.
void parse_dcfs(const TomlTable& c, const std::vector<TomlTable>& axes, hal::DeviceConfig& cfg) {
  const std::filesystem::path dir = std::filesystem::path(c.file()).parent_path();
  std::map<std::pair<std::string, int>, std::shared_ptr<const hal::Dcf>> parsed;
  std::vector<std::string> keys(cfg.axes.size());
  for (std::size_t i = 0; i < cfg.axes.size(); ++i) {
    const TomlTable* t = i < axes.size() && axes[i].has("dcf") ? &axes[i] : c.has("dcf") ? &c : nullptr;
    if (t == nullptr) continue;
    keys[i] = t->key_path("dcf");
    if (!cfg.canopen.managed)
      t->fail("dcf", "a DCF configures a node of the managed stack: set managed = true or remove it");
    std::filesystem::path file = t->string("dcf");
    if (file.empty()) t->fail("dcf", "is empty: give the path of the node's DCF (CiA 306)");
    if (file.is_relative()) file = dir / file;
    if (!std::filesystem::is_regular_file(file)) t->fail("dcf", "DCF file not found: " + file.string());
    hal::CanopenAxisConfig& x = cfg.canopen.axes[i];
    auto& slot = parsed[{file.string(), x.node_id}];
    try {
      if (!slot) slot = std::make_shared<const hal::Dcf>(hal::parse_dcf_file(file.string(), x.node_id));
    } catch (const hal::DcfError& e) {
      throw dcf_input_error(e, keys[i]);
    }
    x.dcf = slot;
  }
  try {
    hal::check_dcfs(cfg);
  } catch (const hal::DcfError& e) {
    std::string key;
    for (std::size_t i = 0; i < keys.size() && key.empty(); ++i)
      if (cfg.canopen.axes[i].dcf && cfg.canopen.axes[i].dcf->path == e.location().file) key = keys[i];
    throw dcf_input_error(e, key);
  } catch (const std::invalid_argument& e) {
    c.fail_at(nullptr, c.path(), e.what());
  }
}

/// [device.canopen] and its [[device.canopen.axis]] entries (docs/scenes.md).
void parse_canopen(const TomlTable& dev, hal::DeviceConfig& cfg) {
  hal::CanopenConfig& co = cfg.canopen;
  // Reconcile the defaults with the [[device.axis]] drive COB-IDs (0 = no motor).
  for (std::size_t i = 0; i < cfg.axes.size(); ++i) {
    hal::CanopenAxisConfig& x = co.axes[i];
    if (cfg.axes[i].has_drive() != (x.drive_tpdo_cob_id != 0)) {
      const hal::CanopenAxisConfig d = hal::make_canopen_axis(x.node_id, cfg.axes[i].has_drive());
      x.drive_tpdo_cob_id = d.drive_tpdo_cob_id;
      x.drive_rpdo = d.drive_rpdo;
      x.drive_tpdo = d.drive_tpdo;
    }
  }
  auto c = dev.table("canopen");
  if (!c) return;
  c->allow_only({"managed", "controller_node_id", "controller_heartbeat_period",
                 "drive_heartbeat_timeout", "node_heartbeat_period", "heartbeat_timeout",
                 "startup_timeout", "startup_retry", "sdo_timeout", "sdo_poll_period", "dcf", "axis"});
  co.managed = c->boolean_or("managed", co.managed);
  const auto ctrl = c->integer_or("controller_node_id", co.controller_node_id);
  if (ctrl < 1 || ctrl > 127) c->fail("controller_node_id", "must be a CANopen node id in [1, 127]");
  co.controller_node_id = static_cast<std::uint8_t>(ctrl);
  co.controller_heartbeat_period_ms =
      parse_ms(*c, "controller_heartbeat_period", co.controller_heartbeat_period_ms);
  if (c->has("drive_heartbeat_timeout"))
    co.drive_heartbeat_timeout_ms = parse_ms(*c, "drive_heartbeat_timeout", 1);
  // A time in ms within [lo, 600000] ("what" the message adds).
  const auto ms_in = [&](const char* key, std::uint32_t fallback, std::int64_t lo, const char* what) {
    const auto v = c->integer_or(key, fallback);
    if (v < lo || v > 600'000)
      c->fail(key, "must be in [" + std::to_string(lo) + ", 600000] ms" + what);
    return static_cast<std::uint32_t>(v);
  };
  co.startup_timeout_ms = ms_in("startup_timeout", co.startup_timeout_ms, 1, "");
  co.startup_retry_ms = ms_in("startup_retry", co.startup_retry_ms, 1, "");
  co.sdo_timeout_ms = ms_in("sdo_timeout", co.sdo_timeout_ms, 1, "");
  co.sdo_poll_period_ms = ms_in("sdo_poll_period", co.sdo_poll_period_ms, 0, " (0: no reads)");
  const std::uint16_t period = parse_ms(*c, "node_heartbeat_period", 10);
  const std::uint16_t timeout = c->has("heartbeat_timeout") ? parse_ms(*c, "heartbeat_timeout", 1) : 0;
  for (hal::CanopenAxisConfig& x : co.axes) {
    x.heartbeat_period_ms = period;
    x.heartbeat_timeout_ms = timeout;
  }
  const std::vector<TomlTable> axes = c->tables("axis");
  if (!axes.empty() && axes.size() != cfg.axes.size())
    c->fail("axis", "the device has " + std::to_string(cfg.axes.size()) + " axes, " +
                        std::to_string(axes.size()) + " given (give all or none)");
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const TomlTable& a = axes[i];
    hal::CanopenAxisConfig& x = co.axes[i];
    a.allow_only({"node_id", "heartbeat_period", "heartbeat_timeout", "drive_tpdo_cob_id",
                  "encoder_tpdo", "drive_rpdo", "drive_tpdo", "dcf"});
    const auto node = a.integer_or("node_id", x.node_id);
    if (node < 1 || node > 127) a.fail("node_id", "must be a CANopen node id in [1, 127]");
    x.node_id = static_cast<std::uint8_t>(node);
    x.heartbeat_period_ms = parse_ms(a, "heartbeat_period", x.heartbeat_period_ms);
    if (a.has("heartbeat_timeout")) x.heartbeat_timeout_ms = parse_ms(a, "heartbeat_timeout", 1);
    const auto tpdo = a.integer_or("drive_tpdo_cob_id", x.drive_tpdo_cob_id);
    if (tpdo < 0 || tpdo > 0x7FF) a.fail("drive_tpdo_cob_id", "must be an 11-bit COB-ID in [0, 0x7FF]");
    x.drive_tpdo_cob_id = static_cast<std::uint32_t>(tpdo);
    x.encoder_tpdo = parse_mapping(a, "encoder_tpdo", x.encoder_tpdo);
    x.drive_rpdo = parse_mapping(a, "drive_rpdo", x.drive_rpdo);
    x.drive_tpdo = parse_mapping(a, "drive_tpdo", x.drive_tpdo);
    // Point a validation error of this axis at its table.
    try {
      hal::validate(cfg);
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      if (what.find("canopen.axes[" + std::to_string(i) + "]") != std::string::npos) {
        for (const char* key : {"drive_tpdo_cob_id", "drive_rpdo", "drive_tpdo", "encoder_tpdo",
                                "heartbeat_timeout", "heartbeat_period", "node_id"}) {
          if (what.find(key) != std::string::npos && a.has(key)) a.fail(key, what);
        }
        a.fail_at(nullptr, a.path(), what);
      }
    }
  }
  try {
    hal::validate(cfg);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    if (what.find("canopen") != std::string::npos) c->fail_at(nullptr, c->path(), what);
  }
  parse_dcfs(*c, axes, cfg);
}

/// A device without [device.feedback] sends no force to the hand (Model::feedback all zero): said
/// at load in Scene::warnings, as the motors it has or not (docs/scenes.md "[device.feedback]").
/// An admittance device has no feedback spring (its drives are position controlled): nothing.
void warn_no_feedback(const TomlTable& dev, const hal::DeviceConfig& cfg, Scene& scene) {
  if (dev.has("feedback") || scene.model.coupling_mode == core::CouplingMode::kAdmittance) return;
  std::string driven;
  for (const hal::AxisConfig& a : cfg.axes)
    if (a.has_drive()) driven += (driven.empty() ? "" : ", ") + a.name;
  if (driven.empty()) {
    scene.warnings.push_back(kNoFeedbackNonHaptic + (" (device \"" + cfg.name +
                             "\" has no drives and no [device.feedback]): feedback_wrench stays 0"));
    return;
  }
  scene.warnings.push_back("no feedback: device \"" + cfg.name + "\" has motors (drives on " +
                           driven + ") but no [device.feedback]: feedback_wrench stays 0 and the "
                           "drives are sent no torque; give [device.feedback] stiffness and "
                           "damping (docs/scenes.md)");
}

void parse_feedback(const TomlTable& dev, core::FeedbackGains& f) {
  auto fb = dev.table("feedback");
  if (!fb) return;  // non-haptic: all zero
  fb->allow_only({"stiffness", "damping", "rotational_stiffness", "rotational_damping", "max_force",
                  "max_torque"});
  f.k_t = fb->number_in("stiffness", 0.0, kInf, 0.0);
  f.gamma_t = fb->number_in("damping", 0.0, kInf, 0.0);
  f.k_r = fb->number_in("rotational_stiffness", 0.0, kInf, 0.0);
  f.gamma_r = fb->number_in("rotational_damping", 0.0, kInf, 0.0);
  f.max_force = fb->number_in("max_force", 0.0, kInf, kInf);
  f.max_torque = fb->number_in("max_torque", 0.0, kInf, kInf);
}

/// `[device.admittance]` (docs/scenes.md): required with coupling = "admittance", refused
/// otherwise.
void parse_admittance(const TomlTable& dev, Scene& scene, const hal::DeviceConfig& cfg) {
  const bool admittance = scene.model.coupling_mode == core::CouplingMode::kAdmittance;
  auto ad = dev.table("admittance");
  if (!ad) {
    if (admittance)
      dev.fail("admittance", "missing: coupling = \"admittance\" needs [device.admittance] (force sensor, hand)");
    return;
  }
  if (!admittance)
    ad->fail_at(nullptr, ad->path(), "[device.admittance] needs coupling = \"admittance\"");
  ad->allow_only({"drive_lag", "rpdo_cob_ids", "force_sensor", "hand"});
  AdmittanceScene a;
  a.config = hal::make_admittance_config(cfg);
  if (ad->has("rpdo_cob_ids")) {
    const std::vector<double> ids = ad->numbers("rpdo_cob_ids", static_cast<int>(cfg.axes.size()));
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (!(ids[i] >= 1 && ids[i] <= 0x7FF && ids[i] == std::floor(ids[i])))
        ad->fail("rpdo_cob_ids", "entries must be 11-bit COB-IDs");
      a.config.rpdo_cob_ids[i] = static_cast<std::uint32_t>(ids[i]);
    }
  }
  a.drive_lag_s = ad->number_in("drive_lag", 0.0, 1.0, a.drive_lag_s);
  if (auto fs = ad->table("force_sensor")) {
    fs->allow_only({"node_id", "force_cob_id", "torque_cob_id", "force_scale", "torque_scale",
                    "max_force", "max_torque", "max_age", "position", "orientation"});
    hal::ForceSensorConfig& c = a.config.sensor;
    const auto node = fs->integer_or("node_id", c.node_id);
    if (node < 1 || node > 127) fs->fail("node_id", "must be a CANopen node id in [1, 127]");
    c.node_id = static_cast<std::uint8_t>(node);
    c.force_cob_id = static_cast<std::uint32_t>(fs->number_in("force_cob_id", 1, 0x7FF, 0.0));
    c.torque_cob_id = static_cast<std::uint32_t>(fs->number_in("torque_cob_id", 1, 0x7FF, 0.0));
    c.force_scale = fs->number_in("force_scale", 1e-9, kInf, c.force_scale);
    c.torque_scale = fs->number_in("torque_scale", 1e-9, kInf, c.torque_scale);
    c.max_force = fs->number_in("max_force", 1e-9, kInf, c.max_force);
    c.max_torque = fs->number_in("max_torque", 1e-9, kInf, c.max_torque);
    c.max_age_s = fs->number_in("max_age", 1e-9, kInf, 3.0 * cfg.control_period_s);
    c.sensor_in_tool.position = fs->vec3_or("position", Vec3::Zero());
    c.sensor_in_tool.orientation = fs->quaternion_or("orientation", Quat::Identity());
  } else {
    a.config.sensor.max_age_s = 3.0 * cfg.control_period_s;
  }
  if (auto h = ad->table("hand")) {
    // The hand's former place (before [device.hand] served both kinds of device): still read.
    if (dev.has("hand"))
      h->fail_at(nullptr, h->path(), "give the hand once, in [device.hand] (this table is its former place)");
    h->allow_only({"stiffness", "damping", "rotational_stiffness", "rotational_damping"});
    read_hand(*h, scene.hand);
  }
  try {
    hal::validate(cfg, a.config);
  } catch (const std::invalid_argument& e) {
    ad->fail_at(nullptr, ad->path(), e.what());
  }
  scene.admittance = std::move(a);
}

/// `[device.hand]` (docs/scenes.md): the simulated hand of both kinds of device (hand.hpp).
void parse_hand(const TomlTable& dev, HandSettings& hand) {
  auto h = dev.table("hand");
  if (!h) return;
  h->allow_only({"mass", "stiffness", "damping", "rotational_inertia", "rotational_stiffness",
                 "rotational_damping"});
  read_hand(*h, hand);
}

/// A list of one entry per axis, or one number for every axis, each finite and in [lo, hi];
/// absent: `fallback` for every axis, or refused when there is none. `range` words the bound in
/// the refusal ("must be in [0, 1]" by default): an entry of the list out of it is refused as
/// "entries " + range, the one number as range + ", got V".
std::vector<double> per_axis(const TomlTable& t, std::string_view key, int n, double lo, double hi,
                             std::optional<double> fallback, std::string range = {}) {
  if (range.empty())
    range = "must be in [" + format_input_number(lo) + ", " + format_input_number(hi) + "]";
  if (!t.has(key)) {
    if (!fallback)
      t.fail(key, "missing (one number for every axis, or a list of " + std::to_string(n) +
                      ", one per axis, is required)");
    return std::vector<double>(static_cast<std::size_t>(n), *fallback);
  }
  if (t.node(key)->is_array()) {
    const std::vector<double> v = t.numbers(key, n);
    for (double x : v)
      if (!(x >= lo && x <= hi)) t.fail(key, "entries " + range);
    return v;
  }
  const double x = t.number_or(key, 0.0);  // a number, finite (else refused with its type)
  if (!(x >= lo && x <= hi)) t.fail(key, range + ", got " + format_input_number(x));
  return std::vector<double>(static_cast<std::size_t>(n), x);
}

/// `[device.plant]` (docs/scenes.md, docs/device_plant.md): the impedance device's mechanics;
/// the emulated device then moves under the drives' torques (closed loop).
void parse_plant(const TomlTable& dev, const Scene& scene, const hal::DeviceConfig& cfg,
                 std::optional<DevicePlantSettings>& out) {
  auto p = dev.table("plant");
  if (!p) return;
  if (scene.model.coupling_mode == core::CouplingMode::kAdmittance)
    p->fail_at(nullptr, p->path(),
               "[device.plant] is an impedance device's mechanics; an admittance device's drives "
               "are position controlled ([device.admittance] drive_lag)");
  p->allow_only({"inertia", "damping", "coulomb", "current_lag", "delay_periods", "substeps"});
  const int n = static_cast<int>(cfg.axes.size());
  const std::vector<double> inertia =
      per_axis(*p, "inertia", n, 0.0, kInf, std::nullopt,
               "must be finite and >= 0 (kg or kg·m²; 0: the axis follows the hand)");
  const std::vector<double> damping = per_axis(*p, "damping", n, 0.0, kInf, 0.0);
  const std::vector<double> coulomb = per_axis(*p, "coulomb", n, 0.0, kInf, 0.0);
  const std::vector<double> lag = per_axis(*p, "current_lag", n, 0.0, 1.0, 0.0);
  const auto delay = p->integer_or("delay_periods", 0);
  if (delay < 0 || delay > kMaxPlantDelayPeriods)
    p->fail("delay_periods", "must be in [0, " + std::to_string(kMaxPlantDelayPeriods) + "]");
  const auto substeps = p->integer_or("substeps", DevicePlantSettings{}.substeps);
  if (substeps < 1 || substeps > kMaxPlantSubsteps)
    p->fail("substeps", "must be in [1, " + std::to_string(kMaxPlantSubsteps) + "]");
  DevicePlantSettings plant;
  plant.substeps = static_cast<int>(substeps);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    AxisPlantSettings a;
    a.inertia = inertia[k];
    a.damping = damping[k];
    a.coulomb = coulomb[k];
    a.current_lag_s = lag[k];
    a.delay_periods = static_cast<int>(delay);
    // The drive saturates at the axis's max_torque (0 there: no drive limit given).
    a.max_torque = cfg.axes[k].max_torque > 0.0 ? cfg.axes[k].max_torque : kInf;
    plant.axes.push_back(a);
  }
  out = std::move(plant);
}

/// `[device.passivity]` (docs/scenes.md, docs/passivity.md "Passivity controller"): the
/// time-domain passivity controller of ImpedanceDevice::write() on the named driven axes.
void parse_passivity(const TomlTable& dev, const Scene& scene, hal::DeviceConfig& cfg) {
  auto p = dev.table("passivity");
  if (!p) return;
  p->allow_only({"enabled", "axes", "velocity_threshold", "energy_limit"});
  if (scene.model.coupling_mode == core::CouplingMode::kAdmittance)
    p->fail_at(nullptr, p->path(),
               "[device.passivity] controls an impedance device's torques; an admittance "
               "device's drives are position controlled");
  hal::PassivitySettings s;
  s.enabled = p->boolean_or("enabled", true);
  s.velocity_threshold =
      p->number_in("velocity_threshold", 0.0, 1e3, hal::kDefaultPassivityVelocityThreshold);
  s.energy_limit = p->number_in("energy_limit", 1e-12, kInf, s.energy_limit);
  const auto driven_names = [&] {
    std::string list;
    for (const hal::AxisConfig& a : cfg.axes)
      if (a.has_drive()) list += (list.empty() ? "\"" : ", \"") + a.name + "\"";
    return list;
  };
  if (const toml::node* n = p->node("axes")) {
    const toml::array* arr = n->as_array();
    if (!arr || arr->empty())
      p->fail("axes", "expected a list of driven axis names, e.g. [" + driven_names() + "]");
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string k = p->key_path("axes") + "[" + std::to_string(i) + "]";
      const auto* name = arr->get(i)->as_string();
      if (!name) p->fail_at(arr->get(i), k, "expected an axis name (a string)");
      int found = -1;
      for (std::size_t a = 0; a < cfg.axes.size(); ++a)
        if (cfg.axes[a].name == name->get()) found = static_cast<int>(a);
      if (found < 0 || !cfg.axes[static_cast<std::size_t>(found)].has_drive())
        p->fail_at(arr->get(i), k,
                   (found < 0 ? "no axis named \"" : "axis without a drive \"") + name->get() +
                       "\" (driven axes: " + driven_names() + ")");
      s.axis_mask |= 1u << static_cast<unsigned>(found);
    }
  } else {
    for (std::size_t a = 0; a < cfg.axes.size(); ++a)
      if (cfg.axes[a].has_drive()) s.axis_mask |= 1u << static_cast<unsigned>(a);
  }
  cfg.passivity = s;
}

}  // namespace

int body_index(const TomlTable& t, std::string_view key, const core::Model& m) {
  const std::string name = t.string(key);
  if (name == "none") return -1;
  for (int i = 0; i < m.num_bodies(); ++i)
    if (m.bodies[static_cast<std::size_t>(i)].name == name) {
      if (m.bodies[static_cast<std::size_t>(i)].anchored)
        t.fail(key, "body \"" + name + "\" is anchored (a static body, e.g. an organ's rigid "
                    "component): no device holds it");
      return i;
    }
  t.fail(key, "no body named \"" + name + "\" (use a [[body]] name or \"none\")");
}

/// A pose of a fixed transform table (`position` m, `orientation` [w, x, y, z]; identity absent).
core::Pose igtl_fixed_pose(const TomlTable& t, std::string_view key) {
  core::Pose p;
  if (auto f = t.table(key)) {
    f->allow_only({"position", "orientation"});
    p.position = f->vec3_or("position", Vec3::Zero());
    p.orientation = f->quaternion_or("orientation", Quat::Identity());
  }
  return p;
}

/// `[device.igtl]` (docs/openigtlink.md, docs/scenes.md): the OpenIGTLink tracker of a pose
/// tracker.
void parse_igtl(const TomlTable& dev, Scene& scene, const hal::DeviceConfig& cfg) {
  auto g = dev.table("igtl");
  if (!g) return;
  if (cfg.kind != hal::DeviceKind::kPoseTracker)
    dev.fail("igtl", "an OpenIGTLink tracker is a pose tracker's: needs kind = \"pose-tracker\"");
  g->allow_only({"host", "port", "device_name", "units", "calibration", "registration",
                 "registration_wait"});
  IgtlTrackerScene t;
  t.host = g->string_or("host", t.host);
  if (t.host.empty()) g->fail("host", "must not be empty");
  const std::int64_t port = g->integer_or("port", t.port);
  if (port < 1 || port > 65535) g->fail("port", "must be a TCP port in [1, 65535]");
  t.port = static_cast<std::uint16_t>(port);
  t.device_name = g->string("device_name");
  if (t.device_name.empty() || t.device_name.size() > 20)
    g->fail("device_name", "must have 1 to 20 characters (an OpenIGTLink device name)");
  t.units = g->choice("units", {"mm", "cm", "m"}, "mm");
  t.metres_per_unit = t.units == "mm" ? 1e-3 : t.units == "cm" ? 1e-2 : 1.0;
  t.calibration = igtl_fixed_pose(*g, "calibration");
  if (const toml::node* r = g->node("registration"); r != nullptr && r->is_string()) {
    t.registration_name = g->string("registration");
    if (t.registration_name.empty() || t.registration_name.size() > 20 ||
        t.registration_name == t.device_name)
      g->fail("registration", "a registration read from a TRANSFORM names it: 1 to 20 "
                              "characters, not the tool's device_name");
    t.registration_file = g->file();
    t.registration_line = static_cast<int>(r->source().begin.line);
    t.registration_column = static_cast<int>(r->source().begin.column);
    t.registration_wait_s = g->number_in("registration_wait", 1e-3, 600.0, 5.0);
  } else {
    if (g->has("registration_wait"))
      g->fail("registration_wait", "waits for a registration read from a TRANSFORM; "
                                   "registration is a fixed transform here");
    t.registration = igtl_fixed_pose(*g, "registration");
  }
  scene.igtl = std::move(t);
}

namespace {

void check_cob_ids_apart(const TomlTable& tb, const hal::DeviceConfig& b,
                         const hal::DeviceConfig& a, bool given_only);

/// One device table `dev` (`[device]`, or an entry of `[[device]]`) into `out` (its trajectory
/// already set) and `feedback` (its Eq. 8 gains): kinematics, axes, CANopen nodes and DCFs,
/// feedback, hand, plant, passivity.
/// `first`: device 0, which alone may hold the held body (`attach`, into
/// scene.model.initial_held_body), be an admittance device or read an OpenIGTLink tracker
/// (into scene.admittance and scene.igtl; its hand is scene.hand).
/// `earlier`: the devices before it on the bus (its COB-IDs must not be theirs).
void parse_device_table(const TomlTable& dev, Scene& scene, SceneDevice& out,
                        core::FeedbackGains& feedback, bool first,
                        const std::vector<const hal::DeviceConfig*>& earlier) {
  dev.allow_only({"kind", "name", "attach", "max_sample_age", "jump_tolerance_counts",
                  "velocity_cutoff", "velocity_estimator", "foaw_max_window", "foaw_noise_counts",
                  "soft_start", "first_node_id", "tool_offset", "trocar", "tracker", "phantom",
                  "feedback", "axis", "canopen", "admittance", "hand", "plant", "passivity", "igtl",
                  "trajectory"});
  if (!first) {
    // Device 0 alone holds the held body and may be of the scene-wide kinds of one device.
    if (dev.has("attach"))
      dev.fail("attach", "the held body is the first device's (tool switching, [[event]] attach): "
                         "bind this device's bodies with their link and device = \"<name>\" keys");
    for (const char* one : {"admittance", "igtl"})
      if (dev.has(one))
        dev.fail(one, std::string("[device.") + one + "] is a scene of one device's; this scene has "
                      "several ([[device]] entries)");
  }
  const std::string kind =
      dev.choice("kind", {"trocar-instrument", "pose-tracker", "phantom"}, std::nullopt);
  const auto node = dev.integer_or("first_node_id", 1);
  if (node < 1 || node > 120) dev.fail("first_node_id", "must be a CANopen node id in [1, 120]");
  hal::DeviceConfig cfg;
  try {
    const auto id = static_cast<std::uint8_t>(node);
    cfg = kind == "trocar-instrument" ? hal::make_default_trocar_config(id)
          : kind == "phantom"         ? hal::make_default_phantom_config(id)
                                      : hal::make_default_pose_tracker_config(id);
  } catch (const std::invalid_argument& e) {
    dev.fail("first_node_id", e.what());
  }
  cfg.name = dev.string_or("name", cfg.name);
  cfg.control_period_s = scene.model.dt;
  if (dev.has("max_sample_age"))
    cfg.max_sample_age_s = dev.number_in("max_sample_age", 1e-9, kInf, std::nullopt);
  cfg.jump_tolerance_counts = dev.number_in("jump_tolerance_counts", 0.0, kInf, cfg.jump_tolerance_counts);
  cfg.velocity_cutoff_hz = dev.number_in("velocity_cutoff", 1e-6, kInf, cfg.velocity_cutoff_hz);
  {
    const std::string est = dev.choice("velocity_estimator", {"difference", "filter", "foaw"},
                                        hal::to_string(cfg.velocity_estimator));
    cfg.velocity_estimator = est == "difference" ? hal::VelocityEstimator::kDifference
                             : est == "foaw"     ? hal::VelocityEstimator::kFoaw
                                                 : hal::VelocityEstimator::kFilter;
  }
  const auto window = dev.integer_or("foaw_max_window", cfg.foaw_max_window);
  if (window < 1 || window > hal::kFoawMaxWindow)
    dev.fail("foaw_max_window", "must be in [1, " + std::to_string(hal::kFoawMaxWindow) +
                                     "] sample intervals");
  cfg.foaw_max_window = static_cast<int>(window);
  cfg.foaw_noise_counts = dev.number_in("foaw_noise_counts", 0.0, 1e6, cfg.foaw_noise_counts);
  cfg.soft_start_s =
      dev.number_in("soft_start", 0.0, hal::kMaxSoftStartS, hal::kDefaultSceneSoftStartS);
  if (auto off = dev.table("tool_offset")) {
    off->allow_only({"position", "orientation"});
    cfg.tool_offset.position = off->vec3_or("position", Vec3::Zero());
    cfg.tool_offset.orientation = off->quaternion_or("orientation", Quat::Identity());
  }
  const std::vector<TomlTable> axes = dev.tables("axis");
  if (!axes.empty()) {
    if (axes.size() != cfg.axes.size())
      dev.fail("axis", "a " + kind + " has " + std::to_string(cfg.axes.size()) + " axes, " +
                            std::to_string(axes.size()) + " given (give all or none)");
    for (std::size_t i = 0; i < axes.size(); ++i) cfg.axes[i] = parse_axis(axes[i], cfg.axes[i]);
  }
  if (kind == "trocar-instrument") {
    cfg.kind = hal::DeviceKind::kTrocarInstrument;
    auto tr = dev.table("trocar");
    if (!tr) dev.fail("trocar", "missing: give point = [x, y, z] or placement = \"approach\"");
    tr->allow_only({"point", "orientation", "placement", "standoff"});
    const std::string placement = tr->choice("placement", {"explicit", "approach"},
                                             tr->has("point") ? "explicit" : "approach");
    Vec3 centroid = Vec3::Zero();
    for (std::size_t i = 0; i < out.trajectory.size(); ++i) centroid += out.trajectory[i].pose.position;
    centroid /= static_cast<double>(std::max<std::size_t>(1, out.trajectory.size()));
    if (placement == "approach") {
      if (tr->has("point")) tr->fail("point", "give either point or placement = \"approach\"");
      const double standoff = tr->number_in("standoff", 1e-6, kInf, 0.12);
      ApproachTrocar a;
      try {
        a = trocar_from_approach(out.trajectory, standoff);
      } catch (const InputError& e) {
        tr->fail("standoff", e.message());
      }
      cfg.trocar.point = a.point;
      cfg.trocar.orientation = core::rotation_between(Vec3::UnitZ(), a.approach);
      std::ostringstream os;
      os << std::fixed << std::setprecision(1)
         << "trocar placed behind the recorded tip centroid along the mean approach axis, standoff "
         << standoff * 1e3 << " mm (recorded tip " << a.min_depth * 1e3 << "–" << a.max_depth * 1e3
         << " mm from the trocar point)";
      out.trocar_note = os.str();
    } else {
      cfg.trocar.point = tr->vec3("point");
      const Vec3 toward = centroid - cfg.trocar.point;
      cfg.trocar.orientation = tr->quaternion_or(
          "orientation",
          toward.norm() > 1e-9 ? core::rotation_between(Vec3::UnitZ(), toward) : Quat::Identity());
      out.trocar_note = "trocar point given in the scene";
    }
    if (tr->has("orientation") && placement == "approach") tr->fail("orientation", "set by placement = \"approach\"");
  } else if (kind == "phantom") {
    cfg.kind = hal::DeviceKind::kPhantom;
    if (auto ph = dev.table("phantom")) {
      ph->allow_only({"position", "orientation", "upper_arm", "forearm"});
      cfg.phantom.base.position = ph->vec3_or("position", Vec3::Zero());
      cfg.phantom.base.orientation = ph->quaternion_or("orientation", Quat::Identity());
      cfg.phantom.l1 = ph->number_in("upper_arm", 1e-3, 10.0, cfg.phantom.l1);
      cfg.phantom.l2 = ph->number_in("forearm", 1e-3, 10.0, cfg.phantom.l2);
    }
  } else {
    cfg.kind = hal::DeviceKind::kPoseTracker;
    if (auto tk = dev.table("tracker")) {
      tk->allow_only({"position", "orientation"});
      cfg.tracker.base.position = tk->vec3_or("position", Vec3::Zero());
      cfg.tracker.base.orientation = tk->quaternion_or("orientation", Quat::Identity());
    }
  }
  // A COB-ID of an earlier device's, at this device's key: before the DCFs are checked against
  // the axes (where it would read as a DCF mismatch at the DCF's line).
  for (const hal::DeviceConfig* a : earlier) check_cob_ids_apart(dev, cfg, *a, true);
  parse_canopen(dev, cfg);
  try {
    hal::validate(cfg);
  } catch (const std::invalid_argument& e) {
    dev.fail("axis", e.what());
  }
  parse_feedback(dev, feedback);
  warn_no_feedback(dev, cfg, scene);
  parse_hand(dev, out.hand);
  if (first) {
    scene.hand = out.hand;  // an admittance device's force sensor reads the hand
    parse_admittance(dev, scene, cfg);
    out.hand = scene.hand;
  } else if (scene.model.coupling_mode == core::CouplingMode::kAdmittance) {
    dev.fail_at(nullptr, dev.path(), "an admittance scene (coupling = \"admittance\") has one device");
  }
  parse_plant(dev, scene, cfg, out.plant);
  parse_passivity(dev, scene, cfg);
  if (first) {
    parse_igtl(dev, scene, cfg);
    scene.model.initial_held_body = dev.has("attach") ? body_index(dev, "attach", scene.model) : -1;
  }
  out.device = std::move(cfg);
}

/// Where device `d`'s CANopen node `node` (or its axis `axis`) is set in its table, for a
/// located error: the node id of its [[device.canopen.axis]], else `first_node_id`, else the
/// device table itself.
void fail_at_node(const TomlTable& d, std::size_t axis, const std::string& message) {
  if (auto c = d.table("canopen")) {
    const std::vector<TomlTable> axes = c->tables("axis");
    if (axis < axes.size() && axes[axis].has("node_id")) axes[axis].fail("node_id", message);
  }
  if (d.has("first_node_id")) d.fail("first_node_id", message);
  d.fail_at(nullptr, d.path(), message);
}

/// Device `b` (its table `tb`) against an earlier device `a` on the same bus: each axis's encoder
/// and drive COB-ID belongs to one device. Throws InputError at b's axis key naming a's axis.
/// `given_only`: only the COB-IDs given in b's [[device.axis]] tables (a default one follows
/// the node id, whose clash check_devices_apart() reports as such).
void check_cob_ids_apart(const TomlTable& tb, const hal::DeviceConfig& b,
                         const hal::DeviceConfig& a, bool given_only) {
  const std::vector<TomlTable> axes = tb.tables("axis");
  for (std::size_t y = 0; y < b.axes.size(); ++y)
    for (const std::uint32_t cob : {b.axes[y].encoder_cob_id, b.axes[y].drive_cob_id}) {
      if (cob == 0) continue;
      const char* key = cob == b.axes[y].encoder_cob_id ? "encoder_cob_id" : "drive_cob_id";
      const bool given = y < axes.size() && axes[y].has(key);
      if (given_only && !given) continue;
      for (std::size_t x = 0; x < a.axes.size(); ++x)
        if (cob == a.axes[x].encoder_cob_id || cob == a.axes[x].drive_cob_id) {
          char buf[16];
          std::snprintf(buf, sizeof buf, "0x%03X", cob);
          const std::string m = std::string("COB-ID ") + buf + " of axis \"" + b.axes[y].name +
                                "\" of device \"" + b.name + "\" is device \"" + a.name +
                                "\"'s too (axis \"" + a.axes[x].name +
                                "\"): the devices share one bus, one COB-ID per frame";
          if (given) axes[y].fail(key, m);
          fail_at_node(tb, y, m);
        }
    }
}

/// The devices of `tables` (one per device, `configs` in the same order) share one bus: each
/// name, CANopen node id and COB-ID belongs to one device. Throws InputError at the later
/// device's key (name, node id, COB-ID) naming the earlier device.
void check_devices_apart(const std::vector<TomlTable>& tables,
                         const std::vector<const hal::DeviceConfig*>& configs) {
  for (std::size_t j = 1; j < configs.size(); ++j) {
    const hal::DeviceConfig& b = *configs[j];
    for (std::size_t i = 0; i < j; ++i) {
      const hal::DeviceConfig& a = *configs[i];
      if (a.name == b.name) {
        const std::string m = "device name \"" + b.name + "\" is used twice (" + tables[i].path() +
                              " has it): give each device its own name";
        if (tables[j].has("name")) tables[j].fail("name", m);
        tables[j].fail_at(nullptr, tables[j].path(), m + " (name = \"...\")");
      }
      for (std::size_t y = 0; y < b.canopen.axes.size(); ++y)
        for (std::size_t x = 0; x < a.canopen.axes.size(); ++x)
          if (a.canopen.axes[x].node_id == b.canopen.axes[y].node_id)
            fail_at_node(tables[j], y,
                         "CANopen node id " + std::to_string(b.canopen.axes[y].node_id) + " of axis \"" +
                             b.axes[y].name + "\" of device \"" + b.name + "\" is device \"" +
                             a.name + "\"'s too (axis \"" + a.axes[x].name +
                             "\"): the devices share one bus, one node id per node (set first_node_id "
                             "past the other device's nodes)");
      check_cob_ids_apart(tables[j], b, a, false);
    }
  }
}

}  // namespace

void parse_device(const TomlTable& root, Scene& scene, const TomlTable*& held_body_table,
                  const std::vector<TomlTable>& body_tables,
                  std::vector<Trajectory> trajectories) {
  const std::vector<TomlTable> devs = root.tables("device");
  if (devs.empty()) {  // a scene stepped by the caller (load_scene() checked SceneOverrides::caller_steps)
    scene.device = hal::make_default_pose_tracker_config();
    scene.device.control_period_s = scene.model.dt;
    scene.model.initial_held_body = -1;
    for (int b = 0; b < scene.model.num_bodies() && scene.model.initial_held_body < 0; ++b)
      if (!scene.model.bodies[static_cast<std::size_t>(b)].anchored)
        scene.model.initial_held_body = b;
    held_body_table = nullptr;
    // The advice is what loads: [device.feedback] alone is refused (device.kind: missing).
    const int held = scene.model.initial_held_body;
    const std::string body =
        held >= 0 ? scene.model.bodies[static_cast<std::size_t>(held)].name : std::string("BODY");
    scene.warnings.push_back(kNoFeedbackNonHaptic + std::string(" (the scene has no [device]): "
                             "feedback_wrench stays 0; a [device] table with kind = \"pose-tracker\" "
                             "and attach = \"") + body + "\", and under it a [device.feedback] "
                             "table with stiffness (N/m) and damping (N·s/m), give it (as "
                             "sim/scenes/probe.toml)");
    return;
  }
  constexpr auto kMax = static_cast<std::size_t>(platform::kMaxLoopDevices);
  if (devs.size() > kMax)
    devs[kMax].fail_at(nullptr, devs[kMax].path(),
                       "a scene drives at most " + std::to_string(kMax) + " devices (one control loop)");
  std::vector<SceneDevice> parsed(devs.size());
  scene.model.extra_feedback.assign(devs.size() - 1, core::FeedbackGains{});
  std::vector<const hal::DeviceConfig*> earlier;
  for (std::size_t i = 0; i < devs.size(); ++i) {
    parsed[i].trajectory = std::move(trajectories[i]);
    parse_device_table(devs[i], scene, parsed[i],
                       i == 0 ? scene.model.feedback : scene.model.extra_feedback[i - 1], i == 0,
                       earlier);
    earlier.push_back(&parsed[i].device);
  }
  std::vector<const hal::DeviceConfig*> configs;
  for (const SceneDevice& d : parsed) configs.push_back(&d.device);
  check_devices_apart(devs, configs);
  SceneDevice& first = parsed.front();
  scene.device = std::move(first.device);
  scene.trajectory = std::move(first.trajectory);
  scene.hand = first.hand;
  scene.plant = std::move(first.plant);
  scene.trocar_note = std::move(first.trocar_note);
  scene.extra_devices.assign(std::make_move_iterator(parsed.begin() + 1),
                             std::make_move_iterator(parsed.end()));
  held_body_table = nullptr;
  if (scene.model.initial_held_body >= 0)
    held_body_table = &body_tables[static_cast<std::size_t>(scene.model.initial_held_body)];
}

}  // namespace numen::sim
