/// @file scene_multirate.cpp
/// The [multirate] table of a scene file (scene_multirate.hpp).

#include "scene_multirate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/core/multirate.hpp"

namespace numen::sim {

void parse_multirate(const TomlTable& root, Scene& scene) {
  const auto table = root.table("multirate");
  if (!table) return;
  table->allow_only({"scene_dt", "margin", "fold_step"});
  const double dt = scene.model.dt;
  const double scene_dt = table->number_in("scene_dt", 0.0, 10.0, std::nullopt);
  const double ratio = std::round(scene_dt / dt);
  if (!(ratio >= 1.0) || !(std::abs(ratio * dt - scene_dt) <= 1e-9 * scene_dt) || ratio > 1e6)
    table->fail("scene_dt", "must be a whole multiple of dt = " + format_exact_number(dt) +
                                " s (got " + format_exact_number(scene_dt) + " s, " +
                                format_exact_number(scene_dt / dt) + " dt)");
  MultirateScene m;
  m.ratio = static_cast<int>(ratio);
  m.scene_dt_s = ratio * dt;
  if (m.ratio > 1 && !table->has("margin"))
    table->fail("margin",
                "missing: the proximity margin (m) — how far from a surface the scene loop "
                "starts handing its plane to the device loop; it must cover the tool's travel "
                "towards a surface in one scene period (docs/multirate.md, \"The margin\")");
  m.margin_m = table->number_in("margin", 0.0, 1.0, 0.0);
  m.fold_step_s = table->number_in("fold_step", 1e-6, 10.0, core::MultirateSettings{}.fold_step);
  const core::Model& model = scene.model;
  std::vector<int> bodies;
  if (model.initial_held_body >= 0) bodies.push_back(model.initial_held_body);
  for (const AttachEvent& e : scene.events)
    if (e.body >= 0 && std::find(bodies.begin(), bodies.end(), e.body) == bodies.end())
      bodies.push_back(e.body);
  // Several devices: the first device holds a body throughout (the other instruments ride in
  // its god-object; with none held the scene loop would step them without their targets).
  if (!scene.extra_devices.empty()) {
    if (model.initial_held_body < 0)
      table->fail("scene_dt", "a scene of several devices runs multirate with the first device "
                              "holding a body from the start (its `attach`): the other devices' "
                              "instruments ride in its god-object");
    for (const TomlTable& e : root.tables("event"))
      if (e.has("attach") && e.string("attach") == "none")
        e.fail("attach", "\"none\" in a scene of several devices with [multirate]: the first "
                         "device holds a body throughout (the other devices' instruments ride in "
                         "its god-object)");
  }
  if (bodies.empty()) table->fail("scene_dt", "the device holds no body, now or later: nothing to run at the device rate");
  // Several devices: each other device's first bound body; its articulation joins every
  // god-object (a composite god-object, core::MultirateSettings::other_devices).
  for (const SceneDevice& d : scene.extra_devices) {
    int driven = -1;
    for (const platform::LinkBinding& b : d.binding.links)
      if (b.body >= 0 && driven < 0) driven = b.body;
    if (driven < 0)
      table->fail("scene_dt", "device '" + d.device.name + "' drives no body (no [[body]] has "
                              "device = \"" + d.device.name + "\" and a link): nothing of it to run "
                              "at the device rate");
    m.other_devices.push_back(driven);
  }
  std::vector<char> in_god_object(model.bodies.size(), 0);
  for (int b : bodies)
    for (int g : core::god_object_bodies(model, b, m.other_devices)) in_god_object[static_cast<std::size_t>(g)] = 1;
  // With graspers, what the jaws may hold rides in the device loop: every free body.
  const std::vector<TomlTable> grasp_tables = root.tables("grasp");
  for (std::size_t g = 0; g < model.grasps.size() && g < grasp_tables.size(); ++g)
    for (int jaw : model.grasps[g].jaws)
      if (jaw >= 0 && !in_god_object[static_cast<std::size_t>(jaw)])
        grasp_tables[g].fail("jaws", "jaw '" + model.bodies[static_cast<std::size_t>(jaw)].name +
                                         "' is in no device's instrument: in a scene with "
                                         "[multirate] the device loop grasps, the scene loop "
                                         "does not");
  if (!model.grasps.empty()) {
    if (bodies.size() > 1)
      table->fail("scene_dt", "a scene with [[grasp]] runs multirate with one held body (no "
                              "`attach` event to another): the jaws hold in the device step, and "
                              "a switch of the held body would drop what they hold");
    for (int b = 0; b < model.num_bodies(); ++b) {
      const core::BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
      bool free = !bm.anchored && !in_god_object[static_cast<std::size_t>(b)];
      for (const core::JointModel& j : model.joints) free = free && j.child != b && j.parent != b;
      for (const core::NetModel& n : model.nets) free = free && n.body != b;
      if (free) m.carried.push_back(b);
    }
  }
  std::vector<int> riders = m.other_devices;
  riders.insert(riders.end(), m.carried.begin(), m.carried.end());
  for (int b : bodies) {
    core::Model device;
    const std::string error = core::make_god_object_model(model, b, dt, device, riders);
    if (!error.empty()) table->fail("scene_dt", error);
    m.tools.push_back(b);
  }
  for (int c : m.carried) in_god_object[static_cast<std::size_t>(c)] = 1;
  // The devices drive the god-object's bodies and joints only: the rest is the scene loop's.
  std::vector<const platform::DeviceBinding*> bindings{&scene.binding};
  for (const SceneDevice& d : scene.extra_devices) bindings.push_back(&d.binding);
  for (const platform::DeviceBinding* binding : bindings)
    for (const platform::LinkBinding& b : binding->links)
      if (b.body >= 0 && !in_god_object[static_cast<std::size_t>(b.body)])
        table->fail("scene_dt", "body '" + model.bodies[static_cast<std::size_t>(b.body)].name +
                                    "' is bound to a device link but is not in a held body's "
                                    "articulation: the device loop steps only the god-object");
  // A net is the scene loop's; the device loop feels it only as its god-object's own.
  // An organ (a net on an anchored body) is the scene loop's too, felt through planes on the
  // god-object's spheres.
  for (const core::NetModel& net : model.nets)
    if (!in_god_object[static_cast<std::size_t>(net.body)] &&
        !model.bodies[static_cast<std::size_t>(net.body)].anchored)
      table->fail("scene_dt", "net '" + net.name + "' is on body '" +
                                  model.bodies[static_cast<std::size_t>(net.body)].name +
                                  "', which is in no body's god-object the device holds: the "
                                  "device loop would not feel it");
  for (const platform::DeviceBinding* binding : bindings)
    for (const platform::AxisPrescription& p : binding->prescriptions)
      if (!in_god_object[static_cast<std::size_t>(model.joints[static_cast<std::size_t>(p.joint)].child)])
        table->fail("scene_dt", "joint '" + model.joints[static_cast<std::size_t>(p.joint)].name +
                                    "' is prescribed by the device but is not in a held body's "
                                    "articulation: the device loop steps only the god-object");
  // The margin must cover each hand's travel towards a surface in one scene period: compare it
  // with the target's largest travel over a scene period of each device's trajectory.
  std::vector<std::pair<const Trajectory*, std::string>> trajectories{{&scene.trajectory, ""}};
  for (const SceneDevice& d : scene.extra_devices)
    trajectories.emplace_back(&d.trajectory, " of device '" + d.device.name + "'");
  for (const auto& [trajectory, whose] : trajectories) {
    if (!(m.ratio > 1 && !trajectory->empty())) continue;
    // At most kScanPoints window starts, dt apart or evenly spread over a longer trajectory
    // (a fuzzed scene may last 10^6 s at a microsecond dt: the scan stays bounded).
    constexpr double kScanPoints = 200'000.0;
    double travel = 0.0, at = 0.0;
    const double span = trajectory->duration() - m.scene_dt_s;
    const double stride = std::max(dt, span / kScanPoints);
    const auto starts = span >= 0.0 ? static_cast<std::int64_t>(std::floor(span / stride)) + 1 : 0;
    for (std::int64_t k = 0; k < starts; ++k) {
      const double t = static_cast<double>(k) * stride;
      const double d = (trajectory->at(t + m.scene_dt_s).pose.position -
                        trajectory->at(t).pose.position).norm();
      if (d > travel) {
        travel = d;
        at = t;
      }
    }
    if (travel > m.margin_m) {
      std::ostringstream os;
      os << std::setprecision(3) << "multirate: the hand" << whose << " travels up to " << travel * 1e3
         << " mm in one scene period (" << m.scene_dt_s * 1e3 << " ms, from t = " << at
         << " s) but the margin is " << m.margin_m * 1e3 << " mm: a surface the tool reaches "
         << "between two scene samples has no plane until the next one, and the tool may go "
         << "through it (docs/multirate.md, \"The margin\"); raise [multirate] margin or lower "
         << "scene_dt";
      scene.warnings.push_back(os.str());
    }
  }
  scene.multirate = std::move(m);
}

}  // namespace numen::sim
