/// @file scene_articulation.cpp
/// [[joint]], [baumgarte] and body–link bindings of a scene file.

#include "scene_articulation.hpp"

#include <algorithm>
#include <limits>
#include <memory>
#include <string>

#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/simulated_instrument.hpp"

namespace numen::sim {
namespace {

using core::Pose;
using core::Quat;
using core::Vec3;

/// { position = [..], orientation = [w, x, y, z] } or { position, axis = [..] }
/// (the frame's z axis onto `axis`).
Pose parse_frame(const TomlTable& t) {
  t.allow_only({"position", "orientation", "axis"});
  Pose p;
  p.position = t.vec3_or("position", Vec3::Zero());
  if (t.has("axis")) {
    if (t.has("orientation")) t.fail("axis", "give either orientation or axis, not both");
    const Vec3 axis = t.vec3("axis");
    if (!(axis.norm() > 1e-12)) t.fail("axis", "must be a non-zero vector");
    p.orientation = core::rotation_between(Vec3::UnitZ(), axis.normalized());
  } else {
    p.orientation = t.quaternion_or("orientation", Quat::Identity());
  }
  return p;
}

int body_or_world(const TomlTable& t, std::string_view key, const core::Model& m, bool allow_world) {
  const std::string name = t.string(key);
  if (allow_world && name == "world") return -1;
  for (int i = 0; i < m.num_bodies(); ++i)
    if (m.bodies[static_cast<std::size_t>(i)].name == name) return i;
  t.fail(key, "no body named \"" + name + "\"" + (allow_world ? " (or \"world\")" : ""));
}

core::JointType parse_joint_type(const TomlTable& t) {
  const std::string type = t.choice(
      "type", {"fixed", "revolute", "prismatic", "cylindrical", "spherical", "trocar"}, std::nullopt);
  if (type == "fixed") return core::JointType::kFixed;
  if (type == "revolute") return core::JointType::kRevolute;
  if (type == "prismatic") return core::JointType::kPrismatic;
  if (type == "cylindrical") return core::JointType::kCylindrical;
  if (type == "spherical") return core::JointType::kSpherical;
  return core::JointType::kTrocar;
}

int axis_index(const TomlTable& t, std::string_view key, const hal::DeviceConfig& device) {
  const std::string name = t.string(key);
  std::string list;
  for (std::size_t i = 0; i < device.axes.size(); ++i) {
    if (device.axes[i].name == name) return static_cast<int>(i);
    list += (list.empty() ? "" : ", ") + device.axes[i].name;
  }
  t.fail(key, "the device has no axis \"" + name + "\" (axes: " + list + ")");
}

int link_index(const TomlTable& t, std::string_view key, const hal::Kinematics& kin) {
  const std::string name = t.string(key);
  const int link = kin.find_link(name.c_str());
  if (link >= 0) return link;
  std::string list;
  for (int i = 0; i < kin.num_links(); ++i) list += (list.empty() ? "" : ", ") + std::string(kin.link_name(i));
  t.fail(key, "the device has no link \"" + name + "\" (links: " + list + ")");
}

/// The device named by string key `key` of `t` (0 for scene.device, i for extra_devices[i − 1]).
/// Absent: device 0 in a scene of one device; in a scene of several, an error at `needed_by`
/// (the key that needs a device: "link", "axis").
int device_of(const TomlTable& t, std::string_view key, const Scene& scene, std::string_view needed_by) {
  std::string list = "\"" + scene.device.name + "\"";
  for (const SceneDevice& d : scene.extra_devices) list += ", \"" + d.device.name + "\"";
  if (!t.has(key)) {
    if (scene.extra_devices.empty()) return 0;
    t.fail(needed_by, "the scene has several devices (" + list + "): say whose with " +
                          std::string(key) + " = \"<name>\"");
  }
  const std::string name = t.string(key);
  if (name == scene.device.name) return 0;
  for (std::size_t i = 0; i < scene.extra_devices.size(); ++i)
    if (scene.extra_devices[i].device.name == name) return static_cast<int>(i) + 1;
  t.fail(key, "no device named \"" + name + "\" (devices: " + list + ")");
}

}  // namespace

void parse_articulation(const TomlTable& root, const std::vector<TomlTable>& body_tables,
                        Scene& scene) {
  core::Model& m = scene.model;
  if (auto b = root.table("baumgarte")) {
    b->allow_only({"alpha_dt", "beta_dt2"});
    m.baumgarte.alpha_dt = b->number_in("alpha_dt", 0.0, kInf, m.baumgarte.alpha_dt);
    m.baumgarte.beta_dt2 = b->number_in("beta_dt2", 0.0, kInf, m.baumgarte.beta_dt2);
    if (!(m.baumgarte.alpha_dt + m.baumgarte.beta_dt2 > 0.0))
      b->fail(b->has("beta_dt2") ? "beta_dt2" : "alpha_dt",
              "alpha_dt and beta_dt2 cannot both be 0: the joint error would drift unchecked");
  }

  // Per device (0: scene.device, then scene.extra_devices): its config, trajectory, kinematics,
  // axes at the first sample and binding.
  struct Bound {
    const hal::DeviceConfig* config;
    std::unique_ptr<hal::Kinematics> kin;
    hal::AxisVector q0;
    platform::DeviceBinding* binding;
  };
  std::vector<Bound> devices;
  const auto add = [&](const hal::DeviceConfig& cfg, const Trajectory& trajectory,
                       platform::DeviceBinding& binding) {
    auto kin = hal::make_kinematics(cfg);
    const hal::AxisVector q0 = instrument_axes(cfg, *kin, trajectory.at(0.0));
    binding = platform::DeviceBinding{};
    devices.push_back(Bound{&cfg, std::move(kin), q0, &binding});
  };
  add(scene.device, scene.trajectory, scene.binding);
  for (SceneDevice& d : scene.extra_devices) add(d.device, d.trajectory, d.binding);

  // Body–link bindings and the starting poses they imply.
  std::vector<int> bound_by(body_tables.size(), -1);  // per body: the device binding it
  for (std::size_t i = 0; i < body_tables.size(); ++i) {
    const TomlTable& t = body_tables[i];
    if (t.has("link_offset") && !t.has("link"))
      t.fail("link_offset", "needs a link = \"...\" to be relative to");
    if (t.has("device") && !t.has("link"))
      t.fail("device", "names the device whose link drives the body: needs a link = \"...\"");
    if (!t.has("link")) continue;
    const int dev = device_of(t, "device", scene, "link");
    Bound& d = devices[static_cast<std::size_t>(dev)];
    platform::LinkBinding lb;
    lb.link = link_index(t, "link", *d.kin);
    lb.body = static_cast<int>(i);
    if (auto off = t.table("link_offset")) lb.body_in_link = parse_frame(*off);
    d.binding->links.push_back(lb);
    bound_by[i] = dev;
    if (!t.has("position")) {
      if (t.has("orientation"))
        t.fail("orientation", "a body bound to a link without a position starts at the link's pose; "
                              "give both position and orientation, or neither");
      const Pose link = d.kin->link_pose(lb.link, d.q0);
      core::BodyModel& body = m.bodies[i];
      body.initial_pose.position = link.position + link.orientation * lb.body_in_link.position;
      body.initial_pose.orientation = link.orientation * lb.body_in_link.orientation;
    }
  }
  // Link 0 of device 0 → whichever body is held when that body has no link of its own
  // (the rigid binding; after a tool switch to a body without a link).
  scene.binding.links.push_back(platform::LinkBinding{});
  // The held body of device 0 is driven by device 0: another device's link on it would be a
  // second binding of one body.
  const int held = m.initial_held_body;
  if (held >= 0 && bound_by[static_cast<std::size_t>(held)] > 0) {
    const TomlTable dev0 = root.tables("device").front();
    const std::string other = devices[static_cast<std::size_t>(bound_by[static_cast<std::size_t>(held)])].config->name;
    dev0.fail("attach", "body \"" + m.bodies[static_cast<std::size_t>(held)].name +
                            "\" is bound twice: held by device \"" + scene.device.name +
                            "\" (attach) and driven by device \"" + other + "\" (its link, " +
                            body_tables[static_cast<std::size_t>(held)].key_path("device") +
                            "); a body is driven by one device");
  }

  // Joints.
  for (const TomlTable& t : root.tables("joint")) {
    t.allow_only({"name", "type", "parent", "child", "parent_frame", "child_frame", "prescribed"});
    core::JointModel j;
    j.name = t.string("name");
    for (const auto& other : m.joints)
      if (other.name == j.name) t.fail("name", "joint \"" + j.name + "\" declared twice");
    j.type = parse_joint_type(t);
    j.parent = body_or_world(t, "parent", m, true);
    j.child = body_or_world(t, "child", m, false);
    if (j.child == j.parent) t.fail("child", "a joint needs two different bodies");
    if (const toml::node* n = t.node("parent_frame"); n && n->is_string()) {
      if (n->as_string()->get() != "trocar")
        t.fail("parent_frame", "expected a table { position, orientation | axis } or \"trocar\"");
      // The trocar of the device that drives the child body (device 0 for an unbound child).
      const int by = bound_by[static_cast<std::size_t>(j.child)];
      const hal::DeviceConfig& cfg = *devices[static_cast<std::size_t>(std::max(by, 0))].config;
      if (cfg.kind != hal::DeviceKind::kTrocarInstrument || j.parent != -1)
        t.fail("parent_frame", "\"trocar\" is the trocar point of a trocar instrument (the device "
                               "driving the child body), for a joint to the world");
      j.frame_parent = Pose{cfg.trocar.point, cfg.trocar.orientation};
    } else if (auto f = t.table("parent_frame")) {
      j.frame_parent = parse_frame(*f);
    }
    if (auto f = t.table("child_frame")) j.frame_child = parse_frame(*f);
    if (auto p = t.table("prescribed")) {
      p->allow_only({"axis", "scale", "offset", "device"});
      if (!core::joint_can_be_prescribed(j.type))
        t.fail("prescribed", "only revolute and prismatic joints can be prescribed");
      j.prescribed = true;
      const Bound& d = devices[static_cast<std::size_t>(device_of(*p, "device", scene, "axis"))];
      platform::AxisPrescription ap;
      ap.joint = static_cast<int>(m.joints.size());
      ap.axis = axis_index(*p, "axis", *d.config);
      ap.scale = p->number_in("scale", -kInf, kInf, 1.0);
      ap.offset = p->number_in("offset", -kInf, kInf, 0.0);
      d.binding->prescriptions.push_back(ap);
    }
    m.joints.push_back(std::move(j));
  }

  // A device after the first that neither links a body nor prescribes a joint drives nothing:
  // the control loop would take its empty binding for the rigid one (link 0 → the held body,
  // the first device's) and refuse the run unlocated ("devices 0 and 2 both drive the held
  // body").
  const std::vector<TomlTable> device_tables = root.tables("device");
  for (std::size_t i = 1; i < devices.size() && i < device_tables.size(); ++i) {
    const platform::DeviceBinding& b = *devices[i].binding;
    if (!platform::is_default_rigid(b)) continue;
    const std::string& name = devices[i].config->name;
    device_tables[i].fail_at(nullptr, device_tables[i].path(),
                             "device \"" + name +
                                 "\" drives nothing: no [[body]] has link = "
                                 "\"...\" with device = \"" +
                                 name +
                                 "\" and no [joint.prescribed] "
                                 "has device = \"" +
                                 name + "\" (the held body is the first device's)");
  }
}

}  // namespace numen::sim
