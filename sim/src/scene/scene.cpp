/// @file scene.cpp
/// Scene file → Scene: physics (scene_model.cpp), trajectory, device (scene_device.cpp), bus,
/// events, articulations (scene_articulation.cpp), deformables (scene_deformable.cpp).

#include "numen/sim/scene/scene.hpp"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

#include "numen/core/contact_force.hpp"
#include "numen/core/features.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/input/jigsaws.hpp"
#include "numen/sim/input/scripted_path.hpp"
#include "numen/sim/input/shipped_files.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "scene_articulation.hpp"
#include "scene_grasp.hpp"
#include "scene_needle.hpp"
#include "scene_thread.hpp"
#include "scene_task.hpp"
#include "scene_multirate.hpp"
#include "scene_deformable.hpp"
#include "scene_device.hpp"
#include "scene_model.hpp"
#include "scene_pointer.hpp"
#include "toml_reader.hpp"

namespace numen::sim {
namespace {

using core::Quat;
using core::Vec3;

// ---------- trajectory ----------

Placement parse_placement(const TomlTable& t) {
  Placement p;
  auto pl = t.table("placement");
  if (!pl) return p;
  pl->allow_only({"origin", "position", "orientation", "scale"});
  p.origin = pl->vec3_or("origin", Vec3::Zero());
  p.pose.position = pl->vec3_or("position", Vec3::Zero());
  p.pose.orientation = pl->quaternion_or("orientation", Quat::Identity());
  p.scale = pl->number_in("scale", 1e-9, kInf, 1.0);
  return p;
}

std::optional<Quat> optional_quat(const TomlTable& t, std::string_view key) {
  if (!t.has(key)) return std::nullopt;
  return t.quaternion_or(key, Quat::Identity());
}
std::optional<Vec3> optional_vec3(const TomlTable& t, std::string_view key) {
  if (!t.has(key)) return std::nullopt;
  return t.vec3(key);
}

PathSegment parse_segment(const TomlTable& s) {
  PathSegment seg;
  const std::string type = s.choice("type", {"line", "circle", "hold", "step"}, std::nullopt);
  seg.orientation = optional_quat(s, "orientation");
  seg.angular_velocity = s.vec3_or("angular_velocity", Vec3::Zero());
  if (s.has("jaw")) seg.jaw = s.number("jaw");
  seg.jaw_time = s.number_or("jaw_time", 0.0);
  if (type == "line") {
    s.allow_only({"type", "orientation", "angular_velocity", "jaw", "jaw_time", "servo_target", "servo_from",
                  "servo_body", "servo_point", "from", "to", "duration"});
    LineSegment l;
    l.from = optional_vec3(s, "from");
    l.to = s.vec3("to");
    l.duration = s.number("duration");
    seg.shape = l;
  } else if (type == "circle") {
    s.allow_only({"type", "orientation", "angular_velocity", "jaw", "jaw_time", "servo_target", "servo_from",
                  "servo_body", "servo_point", "centre", "radius", "axis", "period", "start_phase", "duration"});
    CircleSegment c;
    c.centre = optional_vec3(s, "centre");
    c.radius = s.number("radius");
    c.axis = s.vec3_or("axis", Vec3::UnitZ());
    c.period = s.number("period");
    c.start_phase = s.number_or("start_phase", 0.0);
    c.duration = s.number("duration");
    seg.shape = c;
  } else if (type == "hold") {
    s.allow_only({"type", "orientation", "angular_velocity", "jaw", "jaw_time", "servo_target", "servo_from",
                  "servo_body", "servo_point", "position", "duration"});
    HoldSegment h;
    h.position = optional_vec3(s, "position");
    h.duration = s.number("duration");
    seg.shape = h;
  } else {
    s.allow_only({"type", "orientation", "angular_velocity", "jaw", "jaw_time", "servo_target", "servo_from",
                  "servo_body", "servo_point", "from", "to", "to_orientation", "step_time", "duration"});
    StepSegment st;
    st.from = optional_vec3(s, "from");
    st.to = s.vec3("to");
    st.to_orientation = optional_quat(s, "to_orientation");
    st.step_time = s.number("step_time");
    st.duration = s.number("duration");
    seg.shape = st;
  }
  return seg;
}

/// `[trajectory.start]` (scripted and pointer): the pose and jaw before the motion.
TrajectorySample parse_start(const TomlTable& t) {
  TrajectorySample start;
  if (auto s = t.table("start")) {
    s->allow_only({"position", "orientation", "jaw"});
    start.pose.position = s->vec3_or("position", Vec3::Zero());
    if (start.pose.position.stableNorm() > kMaxTargetDistance)
      s->fail("position", "is " + format_input_number(start.pose.position.stableNorm()) +
                              " m from the world origin; a target beyond " +
                              format_input_number(kMaxTargetDistance) + " m is not instrument motion (a wrong unit?)");
    start.pose.orientation = s->quaternion_or("orientation", Quat::Identity());
    start.jaw = s->number_or("jaw", 0.0);
  }
  return start;
}

/// Re-throws an InputError of the trajectory code (which has no file/line) at
/// the place in the scene its key points to.
[[noreturn]] void relocate(const InputError& e, const TomlTable& traj,
                           const std::vector<TomlTable>& segments) {
  const std::string prefix = traj.key_path("segment") + "[";
  if (e.key().rfind(prefix, 0) == 0) {
    const std::size_t i = std::stoul(e.key().substr(prefix.size()));
    if (i < segments.size()) {
      const std::string field = e.key().substr(e.key().find(']') + 1);
      const std::string leaf = field.empty() ? "" : field.substr(1);
      if (!leaf.empty() && segments[i].has(leaf)) segments[i].fail(leaf, e.message());
      segments[i].fail_at(nullptr, e.key(), e.message());
    }
  }
  traj.fail_at(nullptr, e.key().empty() ? traj.path() : e.key(), e.message());
}

/// The located error of a scene without its [trajectory] or [device] (`part`), which a run
/// through the control loop needs and a scene stepped by the caller may leave out.
InputError missing_part(const TomlTable& root, const std::string& part) {
  return root.error(part, "missing: `numen run` needs a [" + part + "] (" +
                              (part == "trajectory"
                                   ? "source = \"jigsaws\", \"scripted\" or \"pointer\""
                                   : "the tracked instrument: kind = \"trocar-instrument\", "
                                     "\"pose-tracker\" or \"phantom\"") +
                              "); a scene stepped by your own program (Python load_scene, "
                              "SceneOverrides::caller_steps) may leave it out (docs/scenes.md, "
                              "\"Drive it from your own program\")");
}

/// A scripted trajectory's servo (`[trajectory.servo]`) before its bodies are known: the spec,
/// its spans' bodies not yet resolved, and where each span's body was named (its errors' place).
struct ServoDraft {
  TomlTable table;
  HandServoSpec spec;
  std::vector<std::string> span_bodies;   // per span: the watched body's name
  std::vector<TomlTable> span_body_from;  // per span: the table whose `servo_body` or `body` named it
};

/// The servo of scripted trajectory `t` whose segments `segs` start at path.segment_start(i):
/// its gains and default body and point from `[trajectory.servo]`, a span per segment with a
/// `servo_target` (its own `servo_body`, `servo_point` if given; from its `servo_from` if given,
/// else from the previous segment's target if that one had one on the same point and ended where
/// this one starts, else from its own). None without the table; a `servo_target` without it, a
/// `servo_from`, `servo_body` or `servo_point` without a `servo_target`, or the table without any
/// target, is an error at the key.
std::optional<ServoDraft> parse_servo(const TomlTable& t, const std::vector<TomlTable>& segs,
                                      const ScriptedPath& path) {
  const std::optional<TomlTable> table = t.table("servo");
  for (const TomlTable& s : segs)
    for (const char* key : {"servo_from", "servo_body", "servo_point"})
      if (s.has(key) && !s.has("servo_target"))
        s.fail(key, std::string(key) + " names what a servo_target aims: give the segment one");
  if (!table) {
    for (const TomlTable& s : segs)
      if (s.has("servo_target"))
        s.fail("servo_target", "a servo target needs the trajectory's [" + t.key_path("servo") +
                                   "] (its body and gains; docs/scenes.md)");
    return std::nullopt;
  }
  table->allow_only({"body", "point", "latency", "time_constant", "max_offset", "predict"});
  ServoDraft d{*table, {}, {}, {}};
  const std::string body = table->string("body");
  const Vec3 point = table->vec3_or("point", Vec3::Zero());
  d.spec.settings.latency_s = table->number_in("latency", 0.0, kMaxServoLatency, d.spec.settings.latency_s);
  d.spec.settings.time_constant_s = table->number_in("time_constant", 1e-6, kInf, d.spec.settings.time_constant_s);
  d.spec.settings.max_offset_m = table->number_in("max_offset", 1e-9, 1.0, d.spec.settings.max_offset_m);
  d.spec.settings.predict = table->boolean_or("predict", false);
  for (std::size_t i = 0; i < segs.size(); ++i) {
    if (!segs[i].has("servo_target")) continue;
    HandServoSpan span;
    span.t0_s = path.segment_start(i);
    span.t1_s = i + 1 < segs.size() ? path.segment_start(i + 1) : path.duration();
    span.target_end = segs[i].vec3("servo_target");
    span.point = segs[i].vec3_or("servo_point", point);
    const bool own_body = segs[i].has("servo_body");
    const std::string name = own_body ? segs[i].string("servo_body") : body;
    const bool follows = !d.spec.spans.empty() && std::abs(d.spec.spans.back().t1_s - span.t0_s) < 1e-9 &&
                         d.span_bodies.back() == name && d.spec.spans.back().point == span.point;
    span.target_start = segs[i].has("servo_from") ? segs[i].vec3("servo_from")
                        : follows                     ? d.spec.spans.back().target_end
                                                      : span.target_end;
    d.spec.spans.push_back(span);
    d.span_bodies.push_back(name);
    d.span_body_from.push_back(own_body ? segs[i] : *table);
  }
  if (d.spec.spans.empty())
    table->fail("body", "no segment of " + t.key_path("segment") + " gives a servo_target: the servo would "
                        "never look (give the segments it should correct a servo_target, or drop the table)");
  return d;
}

/// A trajectory table (`[trajectory]`, or a device's `[device.trajectory]`) sampled for the
/// period `dt`; a scripted one's servo into `servo` (none otherwise).
Trajectory parse_trajectory(const TomlTable& t, double dt, const std::filesystem::path& scene_dir,
                            std::vector<std::string>& warnings, std::optional<ServoDraft>& servo) {
  servo.reset();
  const std::string source = t.choice("source", {"jigsaws", "scripted", "pointer"}, std::nullopt);
  Trajectory recorded;
  if (source == "pointer") {
    // The recording replayed through the relative-pose integrator (scene_pointer.cpp); the
    // integrator's settings place it in the world, so there is no [trajectory.placement].
    recorded = parse_pointer_trajectory(t, dt, scene_dir, parse_start(t), warnings);
  } else if (source == "jigsaws") {
    t.allow_only({"source", "file", "manipulator", "start_time", "end_time", "placement"});
    std::filesystem::path file = t.string("file");
    if (file.is_relative()) file = scene_dir / file;
    if (!std::filesystem::exists(file))
      t.fail("file", "trajectory file not found: " + file.string());
    if (std::filesystem::is_directory(file))
      t.fail("file", "is a directory, not a JIGSAWS kinematics file: " + file.string());
    JigsawsManipulator arm;
    try {
      arm = parse_jigsaws_manipulator(t.string_or("manipulator", "slave_right"), t.key_path("manipulator"));
    } catch (const InputError& e) {
      t.fail("manipulator", e.message());
    }
    JigsawsOptions opt;
    if (t.has("start_time")) opt.start_time = t.number_in("start_time", 0.0, kInf, std::nullopt);
    if (t.has("end_time")) opt.end_time = t.number_in("end_time", 0.0, kInf, std::nullopt);
    recorded = load_jigsaws(file, arm, opt).trajectory;  // errors name the data file and line
    if (recorded.size() < 2) {  // no motion and no duration: the run would have no step
      const std::string why = " holds one row of " + file.filename().string() +
                              "; a trajectory needs at least two (1/30 s)";
      if (t.has("end_time")) t.fail("end_time", "the window from start_time to end_time" + why);
      t.fail("file", "the recording" + why);
    }
  } else {
    t.allow_only({"source", "start", "segment", "placement", "servo"});
    const TrajectorySample start = parse_start(t);
    const std::vector<TomlTable> segs = t.tables("segment");
    if (segs.empty()) t.fail("segment", "a scripted trajectory needs at least one [[trajectory.segment]]");
    try {
      std::vector<PathSegment> segments;
      for (const TomlTable& s : segs) segments.push_back(parse_segment(s));
      ScriptedPath path(std::move(segments), start, t.key_path("segment"));
      recorded = path.sample(dt);
      servo = parse_servo(t, segs, path);
    } catch (const InputError& e) {
      if (e.line() > 0) throw;
      relocate(e, t, segs);
    }
  }
  try {
    // No resampling at dt: the loop interpolates the knots at each period's time
    // (memory independent of dt and of the run's duration).
    const Placement placement = parse_placement(t);
    if (servo)  // its targets are points of the path's frame, placed as the path is
      for (HandServoSpan& span : servo->spec.spans)
        for (Vec3* p : {&span.target_start, &span.target_end})
          *p = placement.pose.position + placement.pose.orientation * (placement.scale * (*p - placement.origin));
    return transformed(recorded, placement);
  } catch (const InputError& e) {
    if (e.line() > 0) throw;
    t.fail("placement", e.message());
  }
}

/// Controlled-frame pose the device reports for the trajectory's first sample.
core::Pose first_device_pose(const Scene& scene) {
  const auto kin = hal::make_kinematics(scene.device);
  return kin->forward(instrument_axes(scene.device, *kin, scene.trajectory.at(0.0)));
}

}  // namespace

core::CouplingMode parse_coupling_mode(const std::string& name) {
  if (name == "god-object") return core::CouplingMode::kGodObject;
  if (name == "first-order") return core::CouplingMode::kFirstOrder;
  if (name == "direct") return core::CouplingMode::kDirect;
  if (name == "admittance") return core::CouplingMode::kAdmittance;
  throw InputError("", 0, 0, "coupling",
                   "unknown coupling mode \"" + name + "\" (god-object, first-order, direct, admittance)");
}

const char* to_string(core::CouplingMode mode) noexcept {
  switch (mode) {
    case core::CouplingMode::kGodObject: return "god-object";
    case core::CouplingMode::kFirstOrder: return "first-order";
    case core::CouplingMode::kDirect: return "direct";
    case core::CouplingMode::kAdmittance: return "admittance";
  }
  return "?";
}

const char* to_string(core::Integrator integrator) noexcept {
  switch (integrator) {
    case core::Integrator::kSymplecticEuler: return "symplectic-euler";
    case core::Integrator::kTrapezoidal: return "trapezoidal";
    case core::Integrator::kTrBdf2: return "tr-bdf2";
    case core::Integrator::kLinearlyImplicitEuler:
    default: return "implicit-euler";
  }
}

void require_runnable(const Scene& scene) {
  if (!scene.run_missing.empty()) throw scene.run_missing.front();
}

std::string default_scene_path() { return (shipped_data_dir() / "scenes" / "default.toml").string(); }


namespace {

/// Load-time note of the contact time-constant floor (core::SolverSettings::contact_max_omega_dt):
/// one warning per body whose stiffest material pair is above the smallest stiffness a contact of
/// it can act with at this dt (core::body_contact_stiffness_limit()).
void warn_clamped_contacts(const core::Model& m, std::vector<std::string>& warnings) {
  for (int b = 0; b < m.num_bodies(); ++b) {
    const core::BodyModel& body = m.bodies[static_cast<std::size_t>(b)];
    if (body.sphere_count == 0) continue;
    int stiffest = 0;
    for (int j = 1; j < m.num_materials(); ++j)
      if (m.material_pair(body.material, j).stiffness >
          m.material_pair(body.material, stiffest).stiffness)
        stiffest = j;
    const double k = m.material_pair(body.material, stiffest).stiffness;
    const double limit = core::body_contact_stiffness_limit(m, b);
    if (!(k > limit)) continue;
    std::ostringstream os;
    os << std::setprecision(3) << "body \"" << body.name << "\": contact stiffness " << k
       << " N/m (materials \"" << m.material_names[static_cast<std::size_t>(body.material)]
       << "\"/\"" << m.material_names[static_cast<std::size_t>(stiffest)]
       << "\") is above what dt = " << m.dt << " s resolves on its effective mass: its contacts will be clamped, "
       << "down to about " << limit << " N/m (time-constant "
       << "floor omega h <= " << m.solver.contact_max_omega_dt
       << ", [solver] contact_max_omega_dt; docs/dynamics.md, \"Stiff contacts\"), so they "
       << "penetrate more; the run counts the clamped contacts";
    warnings.push_back(os.str());
  }
}

/// Coupling stiffness at or above this fraction of the contact stiffness it yields to draws a
/// load-time warning: pressed into that contact, the god-object goes k_c / (k_c + k_n) ≥ 20 %
/// as deep as the hand (docs/dynamics.md, "Coupling against contacts").
constexpr double kCouplingYieldRatio = 0.25;

/// Load-time lint of the god-object's premise (paper §3): the coupling springs must yield to the
/// contacts. For every body with a coupling stiffness k_c, the softest contact its tool (the
/// bodies of its articulation with spheres) can meet — material pairs with the obstacles, the
/// other bodies and the nets of other bodies, each clamped by the dt floor
/// (core::body_contact_stiffness_limit()) — is k_n; k_c ≥ kCouplingYieldRatio × k_n is warned
/// with both keys and the ratio. With k_c ≫ k_n the tool follows the hand into the obstacle
/// and the feedback vanishes: there is no god-object any more.
void warn_yielding_coupling(const core::Model& m, std::vector<std::string>& warnings) {
  const std::vector<int>& tree_of = m.articulation.body_tree;
  auto tree = [&](int b) { return b < static_cast<int>(tree_of.size()) ? tree_of[static_cast<std::size_t>(b)] : b; };
  for (int b = 0; b < m.num_bodies(); ++b) {
    const core::BodyModel& coupled = m.bodies[static_cast<std::size_t>(b)];
    const double k_c = coupled.coupling.k_t;
    if (!(k_c > 0.0)) continue;
    double k_n = std::numeric_limits<double>::infinity();
    std::string softest;
    auto consider = [&](int tool, int material, const std::string& what) {
      const core::BodyModel& t = m.bodies[static_cast<std::size_t>(tool)];
      const double k = std::min(m.material_pair(t.material, material).stiffness,
                                core::body_contact_stiffness_limit(m, tool));
      if (!(k < k_n)) return;
      k_n = k;
      softest = "body \"" + t.name + "\" on " + what + " (materials \"" +
                m.material_names[static_cast<std::size_t>(t.material)] + "\"/\"" +
                m.material_names[static_cast<std::size_t>(material)] + "\")";
    };
    for (int t = 0; t < m.num_bodies(); ++t) {
      if (tree(t) != tree(b) || m.bodies[static_cast<std::size_t>(t)].sphere_count == 0) continue;
      for (const core::Obstacle& o : m.obstacles) consider(t, o.material, "obstacle \"" + o.name + "\"");
      for (int o = 0; o < m.num_bodies(); ++o) {
        const core::BodyModel& other = m.bodies[static_cast<std::size_t>(o)];
        if (tree(o) == tree(b) || other.sphere_count == 0) continue;
        consider(t, other.material, "body \"" + other.name + "\"");
      }
      for (const core::NetModel& net : m.nets)
        if (tree(net.body) != tree(b)) consider(t, net.material, "net \"" + net.name + "\"");
    }
    if (!(k_c >= kCouplingYieldRatio * k_n)) continue;
    std::ostringstream os;
    os << std::setprecision(3) << "body \"" << coupled.name << "\": coupling stiffness " << k_c
       << " N/m ([body.coupling] stiffness) is " << k_c / k_n << "x the contact stiffness " << k_n
       << " N/m of " << softest << " ([contact_default] / [[contact]] stiffness, or the dt floor)"
       << ": pressed into it, the tool goes k_c/(k_c + k_n) = " << 100.0 * k_c / (k_c + k_n)
       << " % as deep as the hand and the feedback nearly vanishes; the coupling must yield to "
          "the contacts (keep it below " << kCouplingYieldRatio
       << "x; docs/dynamics.md, \"Coupling against contacts\")";
    warnings.push_back(os.str());
  }
}

}  // namespace

Scene load_scene(const std::string& path, const SceneOverrides& overrides) {
  Scene scene;
  scene.file = path;
  const toml::table doc = parse_toml_file(path);
  const TomlTable root(doc, "", scene.file);
  root.allow_only({"name",       "description", "dt",       "duration",  "gravity",
                   "integrator", "coupling",    "solver",   "material",  "contact_default",
                   "contact",    "body",        "obstacle", "device",    "bus",
                   "trajectory", "event",       "joint",    "baumgarte", "deformable",
                   "multirate",  "grasp",       "task",     "needle",    "thread"});
  scene.name = root.string_or("name", std::filesystem::path(path).stem().string());
  scene.description = root.string_or("description", "");
  // Parts this build left out (features.hpp): refused before anything else is read.
  if (!core::kWithArticulation && root.has("joint"))
    root.fail("joint", "scene \"" + scene.name +
                           "\" needs joints: this build has NUMEN_WITH_ARTICULATION=OFF");
  if (!core::kWithDeformable && root.has("deformable"))
    root.fail("deformable", "scene \"" + scene.name +
                                "\" needs deformable nets: this build has NUMEN_WITH_DEFORMABLE=OFF");
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  scene.model = parse_scene_model(root, dir, scene.warnings);
  if (overrides.coupling) {
    // An admittance device is position controlled (its own protocol, [device.admittance]):
    // no override turns a scene into one or out of one.
    const bool file_admittance = scene.model.coupling_mode == core::CouplingMode::kAdmittance;
    if (file_admittance != (*overrides.coupling == core::CouplingMode::kAdmittance))
      throw InputError(path, 0, 0, "--coupling",
                       file_admittance
                           ? "scene \"" + scene.name + "\" has an admittance device (coupling = "
                             "\"admittance\"): its coupling cannot be overridden"
                           : "an impedance scene cannot be overridden to the admittance coupling");
    scene.model.coupling_mode = *overrides.coupling;
  }
  // Each device's trajectory: its [device.trajectory], else the scene's [trajectory].
  const std::vector<TomlTable> device_tables = root.tables("device");
  const auto own = [](const TomlTable& d) { return d.has("trajectory"); };
  const bool every_device_has_one =
      !device_tables.empty() && std::all_of(device_tables.begin(), device_tables.end(), own);
  const bool some_device_has_one = std::any_of(device_tables.begin(), device_tables.end(), own);
  for (const char* part : {"trajectory", "device"}) {
    // (A device without one, beside others with theirs, is named below.)
    if (root.has(part) || (part == std::string("trajectory") && some_device_has_one)) continue;
    if (!overrides.caller_steps) throw missing_part(root, part);
    scene.run_missing.push_back(missing_part(root, part));
  }
  scene.has_device = root.has("device");
  Trajectory shared;
  std::optional<ServoDraft> shared_servo;
  if (auto t = root.table("trajectory"))
    shared = parse_trajectory(*t, scene.model.dt, dir, scene.warnings, shared_servo);
  // (A recording may be large: the last device on the scene's [trajectory] takes it, the others
  // copy it.)
  const auto users = static_cast<std::size_t>(std::count_if(
      device_tables.begin(), device_tables.end(), [&](const TomlTable& d) { return !own(d); }));
  std::size_t used = 0;
  std::vector<Trajectory> trajectories;
  std::vector<std::optional<ServoDraft>> servos;  // per device: its hand's sight, unresolved
  for (const TomlTable& d : device_tables) {
    servos.push_back(shared_servo);  // the scene's [trajectory]'s, unless its own
    if (auto t = d.table("trajectory"))
      trajectories.push_back(parse_trajectory(*t, scene.model.dt, dir, scene.warnings, servos.back()));
    else if (root.has("trajectory") || !some_device_has_one)  // (none at all: a scene the caller
      trajectories.push_back(++used < users ? shared : std::move(shared));  // steps: run_missing)
    else
      d.fail_at(nullptr, d.path(), "device \"" + d.string_or("name", d.path()) +
                                       "\" has no trajectory: give it a [device.trajectory] or "
                                       "give the scene a [trajectory]");
  }
  scene.has_trajectory = root.has("trajectory") || every_device_has_one;
  if (device_tables.empty()) scene.trajectory = std::move(shared);  // else device 0's (parse_device)

  const std::vector<TomlTable> body_tables = root.tables("body");
  const TomlTable* held_table = nullptr;
  parse_device(root, scene, held_table, body_tables, std::move(trajectories));
  if (held_table && scene.has_trajectory && !held_table->has("position") &&
      !held_table->has("link")) {
    core::BodyModel& b = scene.model.bodies[static_cast<std::size_t>(scene.model.initial_held_body)];
    b.initial_pose = first_device_pose(scene);
  }
  parse_articulation(root, body_tables, scene);
  parse_grasps(root, scene);
  parse_task(root, scene);
  // Nets after the bodies' starting poses are known (their nodes start there).
  if constexpr (core::kWithDeformable)
    parse_deformables(root, dir, scene.model, scene.net_triangles, scene.net_loads, scene.warnings);
  parse_needles(root, scene);  // bodies of their own, after every other body and the nets
  parse_threads(root, scene);  // scene_thread.hpp; after the needles, whose tails they may tie to
  // The hands' sight: the bodies they watch are known now (a needle's among them).
  for (std::size_t i = 0; i < servos.size(); ++i) {
    if (!servos[i]) continue;
    ServoDraft& d = *servos[i];
    std::vector<std::string> names;  // the watched bodies, in first-watched order
    for (std::size_t k = 0; k < d.spec.spans.size(); ++k) {
      const std::string& name = d.span_bodies[k];
      for (int b = 0; b < scene.model.num_bodies() && d.spec.spans[k].body < 0; ++b)
        if (scene.model.bodies[static_cast<std::size_t>(b)].name == name) d.spec.spans[k].body = b;
      const TomlTable& from = d.span_body_from[k];
      if (d.spec.spans[k].body < 0)
        from.fail(from.has("servo_body") ? "servo_body" : "body",
                  "no body named \"" + name + "\" (a [[body]] or [[needle]] name)");
      if (std::find(names.begin(), names.end(), name) == names.end()) {
        d.spec.body_name += (names.empty() ? "" : ", ") + name;
        names.push_back(name);
      }
    }
    (i == 0 ? scene.servo : scene.extra_devices[i - 1].servo) = std::move(d.spec);
  }

  // Bus between controller and instrument.
  double latency = 100e-6;
  if (auto bus = root.table("bus")) {
    bus->allow_only({"latency", "drop_probability", "corruption_probability", "seed", "capacity",
                     "compute_phase"});
    latency = bus->number_in("latency", 0.0, 1.0, latency);
    scene.bus.drop_probability = bus->number_in("drop_probability", 0.0, 1.0, 0.0);
    scene.bus.corruption_probability = bus->number_in("corruption_probability", 0.0, 1.0, 0.0);
    const auto seed = bus->integer_or("seed", 1);
    scene.bus.seed = static_cast<std::uint64_t>(seed);
    const auto cap = bus->integer_or("capacity", 256);
    if (cap < 1 || cap > 1 << 20) bus->fail("capacity", "must be in [1, 2^20]");
    scene.bus.capacity = static_cast<std::size_t>(cap);
    scene.compute_phase_s = bus->number_or("compute_phase", 2.0 * latency + 50e-6);
    // Only a compute_phase the file sets is blamed; the default's misfit is dt's (below).
    if (bus->has("compute_phase") &&
        !(scene.compute_phase_s >= 2.0 * latency && scene.compute_phase_s < scene.model.dt))
      bus->fail("compute_phase",
                "must be in [2·latency, dt) = [" + format_input_number(2.0 * latency) + ", " +
                    format_input_number(scene.model.dt) + ") s: one SYNC round trip must fit in "
                    "the period (got " + format_input_number(scene.compute_phase_s) + " s)");
  } else {
    scene.compute_phase_s = 2.0 * latency + 50e-6;
  }
  scene.bus.latency_ns = static_cast<std::int64_t>(std::llround(latency * 1e9));
  if (std::llround(scene.compute_phase_s * 1e9) < 2 * scene.bus.latency_ns)  // after rounding to ns
    scene.compute_phase_s = 2.0 * static_cast<double>(scene.bus.latency_ns) * 1e-9;
  if (scene.plant) scene.plant->torque_phase_s = scene.compute_phase_s;
  for (SceneDevice& d : scene.extra_devices)
    if (d.plant) d.plant->torque_phase_s = scene.compute_phase_s;
  if (!(scene.compute_phase_s < scene.model.dt))
    root.fail("dt", "the period " + format_input_number(scene.model.dt) +
                        " s is not longer than the compute phase " +
                        format_input_number(scene.compute_phase_s) +
                        " s (one SYNC round trip, 2·[bus] latency = " +
                        format_input_number(2.0 * latency) +
                        " s, plus 50 µs unless [bus] compute_phase is set): one round trip must "
                        "fit in the period");

  for (const TomlTable& e : root.tables("event")) {
    e.allow_only({"time", "attach"});
    const int body = body_index(e, "attach", scene.model);
    for (const SceneDevice& d : scene.extra_devices)  // the held body is device 0's
      for (const platform::LinkBinding& l : d.binding.links)
        if (body >= 0 && l.body == body)
          e.fail("attach", "body \"" + scene.model.bodies[static_cast<std::size_t>(body)].name +
                               "\" is driven by device \"" + d.device.name +
                               "\" (its link): the held body is the first device's, a body is "
                               "driven by one device");
    scene.events.push_back(AttachEvent{e.number_in("time", 0.0, kInf, std::nullopt), body});
  }
  std::stable_sort(scene.events.begin(), scene.events.end(),
                   [](const AttachEvent& a, const AttachEvent& b) { return a.time_s < b.time_s; });

  double longest = scene.trajectory.duration();  // the longest of the devices' trajectories
  for (const SceneDevice& d : scene.extra_devices) longest = std::max(longest, d.trajectory.duration());
  scene.duration_s = root.number_in("duration", 1e-9, kMaxRunDuration, longest);
  if (std::llround(scene.duration_s / scene.model.dt) < 1 &&
      (scene.has_trajectory || root.has("duration"))) {  // a run of this scene has no step
    const std::string why = format_input_number(scene.duration_s) +
                            " s is shorter than one period (dt = " +
                            format_input_number(scene.model.dt) + " s): a run would have no step";
    if (root.has("duration")) root.fail("duration", why);
    root.fail("trajectory", "the trajectory lasts " + why);
  }
  const std::string err = core::finalize_model(scene.model);
  if (!err.empty()) {
    // Errors of the joint tree name the joint: point at its table.
    for (const TomlTable& j : root.tables("joint"))
      if (j.has("name") && err.rfind("joint '" + j.string("name") + "'", 0) == 0) j.fail("child", err);
    // Errors of a grasper name it: point at its jaws.
    for (const TomlTable& g : root.tables("grasp"))
      if (g.has("name") && err.rfind("grasp '" + g.string("name") + "'", 0) == 0) g.fail("jaws", err);
    // Errors of a needle name it: point at its table.
    for (const TomlTable& n : root.tables("needle"))
      if (n.has("name") && err.rfind("needle '" + n.string("name") + "'", 0) == 0) n.fail("name", err);
    // An integrator that cannot run the coupling mode: point at the integrator key.
    if (err.rfind("integrator ", 0) == 0 && root.has("integrator")) root.fail("integrator", err);
    root.fail_at(nullptr, "", err);
  }
  check_needles(root, scene);
  if (scene.model.integrator == core::Integrator::kTrapezoidal && !scene.model.nets.empty())
    scene.warnings.push_back(
        "integrator trapezoidal with deformable nets: the rule is not L-stable, so the stiff node "
        "modes (light nodes on penalty contacts and ties) ring instead of being damped; at 1 ms "
        "the shipped probe's nodes went 2.1 mm into the post instead of 0.2 mm "
        "(docs/accuracy.md). implicit-euler or tr-bdf2 (L-stable) are the integrators for nets");
  if constexpr (core::kWithDeformable)
    warn_organs_inside_tools(scene.model, scene.net_triangles, scene.warnings);
  warn_clamped_contacts(scene.model, scene.warnings);
  warn_yielding_coupling(scene.model, scene.warnings);
  parse_multirate(root, scene);
  if (scene.multirate) {
    // The device step grasps bodies only: a net's tissue is the scene loop's.
    const std::vector<TomlTable> grasp_tables = root.tables("grasp");
    for (std::size_t g = 0; g < scene.model.grasps.size() && g < grasp_tables.size(); ++g)
      if (scene.model.grasps[g].tissue && !scene.model.nets.empty())
        scene.warnings.push_back(
            grasp_tables[g]
                .error("tissue", "grasper '" + scene.model.grasps[g].name +
                                     "' holds bodies only in a scene with [multirate]: the jaws "
                                     "are the device loop's and the tissue the scene loop's, and "
                                     "a grip across the two is not built (docs/multirate-suturing.md, "
                                     "\"Grasping in the device loop\")")
                .what());
    // The threads live in the scene loop, which has no grasper (the jaws are the device loop's).
    const std::vector<TomlTable> thread_tables = root.tables("thread");
    if (!scene.model.grasps.empty())
      for (std::size_t i = 0; i < scene.model.threads.size() && i < thread_tables.size(); ++i)
        scene.warnings.push_back(
            thread_tables[i]
                .error("name", "thread '" + scene.model.threads[i].name +
                                   "' is not grasped by the jaws in a scene with [multirate]: the thread "
                                   "lives in the scene loop and the graspers in the device loop "
                                   "(docs/multirate-suturing.md, \"A thread in the scene loop\")")
                .what());
  }
  if (overrides.replay) {
    scene.plant.reset();
    for (SceneDevice& d : scene.extra_devices) d.plant.reset();
  }
  scene.passivity_lint = passivity_lint(scene);
  for (const PassivityLintRow& row : scene.passivity_lint) {
    if (row.passes) continue;
    if (overrides.strict) {
      const TomlTable plant = *root.table("device")->table("plant");
      plant.fail(plant.has("damping") ? "damping" : "inertia",
                 passivity_lint_warning(row) + " (--strict)");
    }
    scene.warnings.push_back(passivity_lint_warning(row));
  }
  return scene;
}

}  // namespace numen::sim
