/// @file scene_grasp.cpp
/// [[grasp]] tables (scene_grasp.hpp).

#include "scene_grasp.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "scene_device.hpp"

namespace numen::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// The body named by element `k` of the `jaws` array.
int jaw_body(const TomlTable& t, const toml::array& jaws, std::size_t k, const core::Model& m) {
  const auto* name = jaws.get(k) != nullptr ? jaws.get(k)->as_string() : nullptr;
  if (name == nullptr) t.fail("jaws", "expected two body names, e.g. jaws = [\"jaw_1\", \"jaw_2\"]");
  for (int i = 0; i < m.num_bodies(); ++i) {
    const core::BodyModel& b = m.bodies[static_cast<std::size_t>(i)];
    if (b.name != name->get()) continue;
    if (b.anchored) t.fail("jaws", "body \"" + b.name + "\" is anchored: a jaw moves with its instrument");
    if (b.sphere_count <= 0)
      t.fail("jaws", "body \"" + b.name + "\" has no spheres: a jaw grasps what its spheres touch");
    return i;
  }
  t.fail("jaws", "no body named \"" + name->get() + "\"");
}

/// Whether `binding` drives a jaw of `g` (prescribes its joint or links its body).
bool drives_jaws(const platform::DeviceBinding& binding, const core::GraspModel& g) noexcept {
  for (const platform::AxisPrescription& p : binding.prescriptions)
    if (p.joint == g.jaw_joints[0] || p.joint == g.jaw_joints[1]) return true;
  for (const platform::LinkBinding& l : binding.links)
    if (l.body >= 0 && (l.body == g.jaws[0] || l.body == g.jaws[1])) return true;
  return false;
}

}  // namespace

int grasper_device(const Scene& scene, int grasper) noexcept {
  const core::GraspModel& g = scene.model.grasps[static_cast<std::size_t>(grasper)];
  if (drives_jaws(scene.binding, g)) return 0;
  for (std::size_t i = 0; i < scene.extra_devices.size(); ++i)
    if (drives_jaws(scene.extra_devices[i].binding, g)) return static_cast<int>(i + 1);
  return -1;
}

void parse_grasps(const TomlTable& root, Scene& scene) {
  core::Model& m = scene.model;
  for (const TomlTable& t : root.tables("grasp")) {
    t.allow_only({"name", "jaws", "close_angle_deg", "open_angle_deg", "stiffness", "damping",
                  "grip_radius", "max_force", "tissue", "thread"});
    core::GraspModel g;
    g.name = t.string("name");
    for (const core::GraspModel& other : m.grasps)
      if (other.name == g.name) t.fail("name", "grasp \"" + g.name + "\" declared twice");
    const toml::node* jaws = t.node("jaws");
    if (jaws == nullptr) t.fail("jaws", "missing: the grasper's two jaw bodies, e.g. jaws = [\"jaw_1\", \"jaw_2\"]");
    const toml::array* list = jaws->as_array();
    if (list == nullptr || list->size() != 2)
      t.fail("jaws", "expected two body names, e.g. jaws = [\"jaw_1\", \"jaw_2\"]");
    g.jaws = {jaw_body(t, *list, 0, m), jaw_body(t, *list, 1, m)};
    if (g.jaws[0] == g.jaws[1]) t.fail("jaws", "both jaws are one body");
    const double close = t.number_in("close_angle_deg", 0.0, 180.0, 10.0);
    const double open = t.number_in("open_angle_deg", 0.0, 180.0, 15.0);
    if (!(open > close))
      t.fail(t.has("open_angle_deg") ? "open_angle_deg" : "close_angle_deg",
             "open_angle_deg (" + std::to_string(open) + ") must exceed close_angle_deg (" +
                 std::to_string(close) + "): otherwise a grasp could never start, or never end");
    g.close_angle = close * kDeg;
    g.open_angle = open * kDeg;
    g.stiffness = t.number_in("stiffness", 0.0, kInf, g.stiffness);
    if (!(g.stiffness > 0.0)) t.fail("stiffness", "must be > 0 (N/m)");
    g.damping = t.number_in("damping", 0.0, kInf, g.damping);
    g.grip_radius = t.number_in("grip_radius", 0.0, 0.1, g.grip_radius);
    if (!(g.grip_radius > 0.0)) t.fail("grip_radius", "must be > 0 (m)");
    g.max_force = t.number_in("max_force", 0.0, kInf, g.max_force);
    g.tissue = t.boolean_or("tissue", true);
    g.thread = t.boolean_or("thread", true);
    if (!(g.max_force > 0.0)) t.fail("max_force", "must be > 0 (N)");
    // A body the grip cannot hold against gravity: said at load, with the numbers. Not the
    // grasper's own instrument: its jaws and every body joined to them (its tube, its sleeve).
    std::vector<char> own(m.bodies.size(), 0);
    own[static_cast<std::size_t>(g.jaws[0])] = own[static_cast<std::size_t>(g.jaws[1])] = 1;
    for (bool grew = true; grew;) {
      grew = false;
      for (const core::JointModel& j : m.joints) {
        if (j.parent < 0) continue;
        char& p = own[static_cast<std::size_t>(j.parent)];
        char& c = own[static_cast<std::size_t>(j.child)];
        if (p != c) {
          p = c = 1;
          grew = true;
        }
      }
    }
    const double gravity = m.gravity.norm();
    for (std::size_t i = 0; i < m.bodies.size(); ++i) {
      const core::BodyModel& b = m.bodies[i];
      if (b.anchored || b.sphere_count == 0 || own[i] || !(b.mass * gravity > g.max_force))
        continue;
      std::ostringstream os;
      os << "grasp \"" << g.name << "\": body \"" << b.name << "\" weighs " << b.mass * gravity
         << " N (" << b.mass << " kg), more than the grip's max_force " << g.max_force
         << " N: grasped, it slips out";
      scene.warnings.push_back(os.str());
    }
    m.grasps.push_back(g);
  }
}

}  // namespace numen::sim
