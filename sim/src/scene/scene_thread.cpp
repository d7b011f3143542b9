/// @file scene_thread.cpp
/// The [[thread]] tables of a scene file (scene_thread.hpp).

#include "scene_thread.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/thread.hpp"
#include "scene_deformable.hpp"

namespace numen::sim {
namespace {

/// A number above `lo` (strictly when `strict`), else a located error naming the key.
double thread_number(const TomlTable& t, const char* key, double fallback, double lo, bool strict) {
  const double v = t.number_or(key, fallback);
  if (!std::isfinite(v) || (strict ? !(v > lo) : !(v >= lo))) {
    std::ostringstream msg;
    msg << "must be " << (strict ? "> " : ">= ") << lo << " (got " << v << ")";
    t.fail(key, msg.str());
  }
  return v;
}

int thread_body(const TomlTable& t, const core::Model& m) {
  const std::string name = t.string("attach_body");
  for (int i = 0; i < m.num_bodies(); ++i)
    if (m.bodies[static_cast<std::size_t>(i)].name == name) return i;
  t.fail("attach_body", "no body named \"" + name + "\"");
}

int thread_material(const TomlTable& t, const core::Model& m) {
  if (!t.has("material")) return 0;
  const std::string name = t.string("material");
  for (int i = 0; i < m.num_materials(); ++i)
    if (m.material_names[static_cast<std::size_t>(i)] == name) return i;
  t.fail("material", "unknown material \"" + name + "\"");
}

}  // namespace

void parse_threads(const TomlTable& root, Scene& scene) {
  core::Model& m = scene.model;
  for (const TomlTable& t : root.tables("thread")) {
    t.allow_only({"name", "length", "segments", "radius", "youngs_modulus_kpa", "density",
                  "damping", "break_strain", "material", "start", "direction", "attach_body",
                  "attach_point", "attach_direction", "self_contact", "tissue_friction",
                  "self_friction"});
    core::ThreadModel th;
    th.name = t.string_or("name", "thread" + std::to_string(m.threads.size()));
    th.length = thread_number(t, "length", th.length, 0.0, true);
    const std::int64_t segments = t.integer_or("segments", th.segments);
    if (segments < 1 || segments > 100000)
      t.fail("segments", "must be 1 … 100000 (got " + std::to_string(segments) + ")");
    th.segments = static_cast<int>(segments);
    th.radius = thread_number(t, "radius", th.radius, 0.0, true);
    th.young_modulus = 1e3 * thread_number(t, "youngs_modulus_kpa", 1e-3 * th.young_modulus, 0.0, true);
    th.density = thread_number(t, "density", th.density, 0.0, true);
    th.damping = thread_number(t, "damping", th.damping, 0.0, false);
    th.break_strain = thread_number(t, "break_strain", th.break_strain, 0.0, true);
    th.tissue_friction = thread_number(t, "tissue_friction", th.tissue_friction, 0.0, false);
    th.self_friction = thread_number(t, "self_friction", th.self_friction, 0.0, false);
    th.material = thread_material(t, m);
    th.start = t.vec3_or("start", th.start);
    th.direction = t.vec3_or("direction", th.direction);
    if (!(th.direction.norm() > 0.0)) t.fail("direction", "must be non-zero");
    th.tie_start.body = -2;  // free
    if (t.has("attach_body")) {
      th.tie_start.body = thread_body(t, m);
      th.tie_start.point = t.vec3_or("attach_point", core::Vec3::Zero());
      if (t.has("attach_direction")) {
        th.tie_start.clamped = true;
        th.tie_start.direction = t.vec3("attach_direction");
        if (!(th.tie_start.direction.norm() > 0.0)) t.fail("attach_direction", "must be non-zero");
      }
      // The thread starts at its tie (a tie away from it would snap it there in one step).
      const core::BodyModel& b = m.bodies[static_cast<std::size_t>(th.tie_start.body)];
      const core::Vec3 at = b.initial_pose.position + b.initial_pose.orientation * th.tie_start.point;
      if (t.has("start") && (th.start - at).norm() > 1e-6)
        t.fail("start", "must be the attach point's starting position (world) or left out");
      th.start = at;
    } else if (t.has("attach_point") || t.has("attach_direction")) {
      t.fail(t.has("attach_point") ? "attach_point" : "attach_direction", "needs attach_body");
    }
    th.self_contact = t.boolean_or("self_contact", true);
    // A thread tied to a needle that punctures tissue follows it through: shorter than the
    // needle's arc (the longest path the needle makes through the tissue, entry to exit), it
    // cannot come out of the far side while its tie is still in the near one.
    for (const core::NeedleModel& n : m.needles)
      if (n.body == th.tie_start.body && n.puncture_force > 0.0 && !m.nets.empty() && th.length < n.length())
        scene.warnings.push_back(
            t.error("length", "thread \"" + th.name + "\" (" + format_input_number(th.length) +
                                  " m) is shorter than the arc of needle \"" + n.name + "\" it is tied to (" +
                                  format_input_number(n.length()) +
                                  " m), the longest path the needle makes through tissue: pulled through, the "
                                  "thread would end inside it; give it a length of at least the needle's arc")
                .what());
    // Placed inside tissue: a thread touches the nets' surfaces from outside (docs/thread.md,
    // "The thread on tissue") and goes into tissue only behind a needle.
    if constexpr (core::kWithDeformable) {
      const core::Vec3 dir = th.direction.normalized();
      for (std::size_t net_k = 0; net_k < m.nets.size() && net_k < scene.net_triangles.size(); ++net_k) {
        const core::NetModel& net = m.nets[net_k];
        const std::vector<core::Vec3> rest = net_rest_positions(m, net);
        for (int i = 0; i <= th.segments; ++i) {
          const core::Vec3 x = th.start + (th.length * i / th.segments) * dir;
          if (std::abs(winding_number(rest, scene.net_triangles[net_k], x)) > 0.5)
            t.fail(t.has("direction") ? "direction" : "start",
                   "thread \"" + th.name + "\" starts inside the tissue of deformable \"" + net.name + "\" (its node " +
                       std::to_string(i) + " of " + std::to_string(th.segments + 1) + ", " +
                       format_input_number(th.length * i / th.segments * 1e3) +
                       " mm along it, in the net's rest surface): give it a start and direction that keep it out; "
                       "it goes into tissue behind a needle");
        }
      }
    }
    m.threads.push_back(th);
  }
}

}  // namespace numen::sim
