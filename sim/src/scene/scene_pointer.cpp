/// @file scene_pointer.cpp
/// `[trajectory] source = "pointer"`: the integrator's settings from the scene file and the
/// evemu recording replayed into a PointerPath (see scene_pointer.hpp).

#include "scene_pointer.hpp"

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>

#include "numen/hal/input/evemu_log.hpp"
#include "numen/hal/input/event_code_name.hpp"
#include "numen/sim/input/pointer_path.hpp"

namespace numen::sim {
namespace {

/// What an event code key holds: the code's type and range, for the messages.
struct CodeKind {
  std::uint16_t type;    // EV_REL, EV_KEY
  unsigned max;          // REL_MAX, KEY_MAX
  const char* name;      // "EV_REL"
  const char* examples;  // "REL_X, REL_Y, REL_WHEEL"
};

constexpr CodeKind kRelCode{EV_REL, REL_MAX, "EV_REL", "REL_X, REL_Y, REL_WHEEL, REL_HWHEEL"};
constexpr CodeKind kKeyCode{EV_KEY, KEY_MAX, "EV_KEY", "BTN_LEFT, BTN_RIGHT, BTN_MIDDLE, KEY_SPACE"};

/// `key` of `t`: a code name libevdev knows for kind.type ("REL_X"), or a number in
/// [0, kind.max]; `fallback` when absent (none: required).
std::uint16_t event_code(const TomlTable& t, std::string_view key, const CodeKind& kind,
                         std::optional<std::uint16_t> fallback) {
  const std::string range = "[0, " + std::to_string(kind.max) + "]";
  const toml::node* n = t.node(key);
  if (n == nullptr) {
    if (fallback) return *fallback;
    t.fail(key, std::string("missing: an ") + kind.name + " code (a name such as " +
                    kind.examples + ", or a number in " + range + ")");
  }
  if (n->is_string()) {
    const std::string name = t.string(key);
    if (!hal::event_code_names_available()) {
      t.fail(key, "\"" + name + "\": code names are resolved by libevdev, which this build leaves out "
                  "(NUMEN_WITH_EVDEV=OFF); give the " + kind.name + " code as a number in " + range);
    }
    const std::optional<std::uint16_t> code = hal::event_code_from_name(kind.type, name);
    if (!code || *code > kind.max) {
      t.fail(key, "\"" + name + "\" is not the name of an " + kind.name +
                      " code (libevdev_event_code_from_name; names as in <linux/input-event-codes.h>, "
                      "e.g. " + kind.examples + ")");
    }
    return *code;
  }
  if (n->is_integer()) {
    const std::int64_t v = t.integer(key);
    if (v < 0 || v > static_cast<std::int64_t>(kind.max)) {
      t.fail(key, std::string("must be an ") + kind.name + " code in " + range + ", got " +
                      std::to_string(v));
    }
    return static_cast<std::uint16_t>(v);
  }
  t.fail(key, std::string("expected an ") + kind.name + " code: a name such as " + kind.examples +
                  " or a number in " + range);
}

hal::PoseDof parse_dof(const TomlTable& a) {
  const std::string d = a.choice("dof", {"x", "y", "z", "roll", "pitch", "yaw"}, std::nullopt);
  if (d == "x") return hal::PoseDof::kX;
  if (d == "y") return hal::PoseDof::kY;
  if (d == "z") return hal::PoseDof::kZ;
  if (d == "roll") return hal::PoseDof::kRoll;
  if (d == "pitch") return hal::PoseDof::kPitch;
  return hal::PoseDof::kYaw;
}

}  // namespace

hal::RelativePoseIntegratorSettings parse_pointer_settings(const TomlTable& traj,
                                                           const core::Pose& start) {
  hal::RelativePoseIntegratorSettings s;  // the integrator's defaults: a desk mouse
  s.initial_pose = start;
  if (auto p = traj.table("pointer")) {
    p->allow_only({"axis", "clutch_key", "clutch_mode", "frame", "workspace_min", "workspace_max"});
    const std::vector<TomlTable> axes = p->tables("axis");
    if (p->has("axis") && axes.empty())
      p->fail("axis", "expected [[trajectory.pointer.axis]] tables (code, dof, scale), at least one");
    if (axes.size() > hal::kMaxRelAxisMappings) {
      p->fail("axis", std::to_string(axes.size()) + " axis mappings, at most " +
                          std::to_string(hal::kMaxRelAxisMappings));
    }
    if (!axes.empty()) s.axes.clear();
    for (const TomlTable& a : axes) {
      a.allow_only({"code", "dof", "scale"});
      hal::RelAxisMapping m;
      m.code = event_code(a, "code", kRelCode, std::nullopt);
      m.dof = parse_dof(a);
      m.scale = a.number("scale");
      if (m.scale == 0.0)
        a.fail("scale", "must not be 0 (m or rad per count; the sign sets the direction)");
      s.axes.push_back(m);
    }
    s.clutch_key = event_code(*p, "clutch_key", kKeyCode, s.clutch_key);
    const std::string mode = p->choice("clutch_mode", {"hold", "toggle", "none"}, "hold");
    s.clutch_mode = mode == "hold"     ? hal::ClutchMode::kHold
                    : mode == "toggle" ? hal::ClutchMode::kToggle
                                       : hal::ClutchMode::kNone;
    s.frame = p->choice("frame", {"world", "tool"}, "world") == "world" ? hal::MotionFrame::kWorld
                                                                        : hal::MotionFrame::kTool;
    s.workspace_min = p->vec3_or("workspace_min", s.workspace_min);
    s.workspace_max = p->vec3_or("workspace_max", s.workspace_max);
    for (int i = 0; i < 3; ++i) {
      if (s.workspace_min[i] > s.workspace_max[i]) {
        p->fail(p->has("workspace_min") ? "workspace_min" : "workspace_max",
                std::string("the ") + "xyz"[i] + " bound " + format_input_number(s.workspace_min[i]) +
                    " m of workspace_min is above workspace_max's " +
                    format_input_number(s.workspace_max[i]) + " m");
      }
    }
  }
  for (int i = 0; i < 3; ++i) {
    const double x = start.position[i];
    if (x < s.workspace_min[i] || x > s.workspace_max[i]) {
      const std::string why = "the start position's " + std::string(1, "xyz"[i]) + " = " +
                              format_input_number(x) + " m is outside the pointer workspace [" +
                              format_input_number(s.workspace_min[i]) + ", " +
                              format_input_number(s.workspace_max[i]) + "] m";
      if (auto st = traj.table("start"); st && st->has("position")) st->fail("position", why);
      if (auto p = traj.table("pointer")) p->fail(p->has("workspace_min") ? "workspace_min" : "workspace_max", why);
      traj.fail("start", why);
    }
  }
  return s;
}

Trajectory parse_pointer_trajectory(const TomlTable& traj, double dt,
                                    const std::filesystem::path& scene_dir,
                                    const TrajectorySample& start,
                                    std::vector<std::string>& warnings) {
  traj.allow_only({"source", "file", "start", "pointer"});
  std::filesystem::path file = traj.string("file");
  if (file.is_relative()) file = scene_dir / file;
  if (!std::filesystem::exists(file)) traj.fail("file", "pointer recording not found: " + file.string());
  if (std::filesystem::is_directory(file))
    traj.fail("file", "is a directory, not an evemu recording: " + file.string());
  const hal::RelativePoseIntegratorSettings settings = parse_pointer_settings(traj, start.pose);

  std::vector<hal::InputEvent> events;
  try {
    events = hal::load_evemu_recording(file.string());  // "path:line:column: what"
  } catch (const std::runtime_error& e) {
    traj.fail("file", e.what());
  }
  if (events.empty())
    traj.fail("file", file.string() + ": no event line (E:): nothing to replay");
  std::optional<PointerPath> path;
  try {
    path.emplace(events, settings, start.jaw);
  } catch (const std::invalid_argument& e) {  // checked above; kept as a located error
    traj.fail("pointer", e.what());
  }
  const hal::RelativePoseCounters& c = path->counters();
  if (c.reports == 0) {
    traj.fail("file", file.string() + ": " + std::to_string(events.size()) +
                          " events and no SYN_REPORT: motion is applied at reports, nothing to replay");
  }
  const ComputedMotion::FarthestPoint far = path->farthest_point(Placement{});
  if (!(far.distance <= kMaxTargetDistance)) {
    traj.fail("file", "the recording drives the target " + format_input_number(far.distance) +
                          " m from the world origin at " + format_input_number(far.time) +
                          " s; a target beyond " + format_input_number(kMaxTargetDistance) +
                          " m is not instrument motion (narrow [trajectory.pointer] workspace_min / "
                          "workspace_max, or the axis scales)");
  }
  if (c.moving_reports == 0) {
    warnings.push_back(
        "trajectory: the pointer recording " + file.filename().string() +
        " never moves the target (" + std::to_string(c.reports) + " reports, " +
        std::to_string(c.ignored_reports) +
        " with motion ignored: the clutch was released or changed within them; " +
        std::to_string(c.unmapped_events) + " events of unmapped axes)");
  }
  try {
    return path->sample(dt);
  } catch (const InputError& e) {
    traj.fail("file", e.message());
  }
}

}  // namespace numen::sim
