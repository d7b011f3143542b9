/// @file scene_needle.cpp
/// [[needle]] tables (scene_needle.hpp).

#include "scene_needle.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/needle.hpp"
#include "numen/sim/run/run_summary.hpp"
#include "scene_deformable.hpp"

namespace numen::sim {
namespace {

/// The deepest dip (m) of grasper `g`'s jaws' surface between two neighbouring spheres: for each
/// sphere (radius r) and its nearest one on the same jaw (a distance d away), r − √(r² − d²/4),
/// or r where they do not overlap (d ≥ 2r: the surface dips to their centres' line and below).
double jaw_dip(const core::Model& m, const core::GraspModel& g) {
  double dip = 0.0;
  for (int jaw : g.jaws) {
    const core::BodyModel& b = m.bodies[static_cast<std::size_t>(jaw)];
    for (int i = 0; i < b.sphere_count; ++i) {
      const core::Sphere& a = m.body_spheres[static_cast<std::size_t>(b.sphere_begin + i)];
      double nearest = kInf;
      for (int k = 0; k < b.sphere_count; ++k)
        if (k != i)
          nearest = std::min(nearest, (m.body_spheres[static_cast<std::size_t>(b.sphere_begin + k)].center - a.center).norm());
      if (!std::isfinite(nearest)) continue;  // one sphere: no dip between spheres
      dip = std::max(dip, nearest >= 2.0 * a.radius ? a.radius
                                                    : a.radius - std::sqrt(a.radius * a.radius - 0.25 * nearest * nearest));
    }
  }
  return dip;
}

}  // namespace

void parse_needles(const TomlTable& root, Scene& scene) {
  core::Model& m = scene.model;
  for (const TomlTable& t : root.tables("needle")) {
    t.allow_only({"name", "radius", "arc", "wire_radius", "mass", "material", "position", "orientation",
                  "puncture_force", "puncture_max_angle_deg", "tie_stiffness", "tie_damping", "friction",
                  "entry_mark", "exit_mark"});
    core::NeedleSpec spec;
    spec.name = t.string("name");
    for (const core::BodyModel& b : m.bodies)
      if (b.name == spec.name) t.fail("name", "\"" + spec.name + "\" is already a body's name (a needle is a body)");
    spec.radius = t.number_in("radius", 0.0, 0.1, spec.radius);
    if (!(spec.radius > 0.0)) t.fail("radius", "must be > 0 (m): the radius of the needle's arc");
    spec.arc = t.number_in("arc", 0.0, 1.0, spec.arc);
    if (!(spec.arc > 0.0 && spec.arc < 1.0))
      t.fail("arc", "must be a fraction of a circle in (0, 1), e.g. 0.5 (half circle) or 0.375 (3/8)");
    spec.wire_radius = t.number_in("wire_radius", 0.0, kInf, spec.wire_radius);
    if (!(spec.wire_radius > 0.0)) t.fail("wire_radius", "must be > 0 (m): half the wire's diameter");
    if (!(spec.wire_radius < spec.radius))
      t.fail("wire_radius", "must be below radius (" + format_input_number(spec.radius) + " m)");
    if (t.has("mass")) {
      spec.mass = t.number_in("mass", 0.0, kInf, std::nullopt);
      if (!(spec.mass > 0.0)) t.fail("mass", "must be > 0 (kg)");
    }
    if (t.has("material")) {
      const std::string name = t.string("material");
      const auto at = std::find(m.material_names.begin(), m.material_names.end(), name);
      if (at == m.material_names.end()) t.fail("material", "unknown material \"" + name + "\"");
      spec.material = static_cast<int>(at - m.material_names.begin());
    }
    spec.pose.position = t.vec3_or("position", core::Vec3::Zero());
    spec.pose.orientation = t.quaternion_or("orientation", core::Quat::Identity());
    if (t.has("puncture_force")) {
      spec.puncture_force = t.number_in("puncture_force", 0.0, kInf, std::nullopt);
      if (!(spec.puncture_force > 0.0))
        t.fail("puncture_force", "must be > 0 (N): the force along the needle at which its tip punctures tissue");
    }
    spec.puncture_max_angle = t.number_in("puncture_max_angle_deg", 0.0, 90.0, spec.puncture_max_angle * 180.0 / M_PI) * M_PI / 180.0;
    if (!(spec.puncture_max_angle > 0.0)) t.fail("puncture_max_angle_deg", "must be > 0 (degrees)");
    spec.tie_stiffness = t.number_in("tie_stiffness", 0.0, kInf, spec.tie_stiffness);
    if (!(spec.tie_stiffness > 0.0)) t.fail("tie_stiffness", "must be > 0 (N/m)");
    spec.tie_damping = t.number_in("tie_damping", 0.0, kInf, spec.tie_damping);
    spec.friction = t.number_in("friction", 0.0, kInf, spec.friction);
    NeedleMarks marks;
    if (t.has("entry_mark")) marks.entry = t.points("entry_mark");
    if (t.has("exit_mark")) marks.exit = t.points("exit_mark");
    if (marks.entry.size() > kMaxNeedlePasses || marks.exit.size() > kMaxNeedlePasses)
      t.fail(marks.entry.size() > kMaxNeedlePasses ? "entry_mark" : "exit_mark",
             "at most " + std::to_string(kMaxNeedlePasses) + " marks (one per pass) a needle");
    if ((!marks.entry.empty() || !marks.exit.empty()) && !(spec.puncture_force > 0.0))
      t.fail(!marks.entry.empty() ? "entry_mark" : "exit_mark",
             "a needle without a puncture_force never goes into tissue: give it one, or leave out its marks");
    core::add_needle(m, spec);
    scene.needle_marks.resize(m.needles.size());
    scene.needle_marks.back() = marks;
  }
}

void check_needles(const TomlTable& root, Scene& scene) {
  const core::Model& m = scene.model;
  const std::vector<TomlTable> tables = root.tables("needle");
  for (std::size_t k = 0; k < tables.size() && k < m.needles.size(); ++k) {
    const TomlTable& t = tables[k];
    const core::NeedleModel& n = m.needles[k];
    // Too thick for every grasper of the scene.
    double widest = -kInf;
    std::string widest_by;
    for (int g = 0; g < m.num_grasps(); ++g) {
      const double w = core::grasp_widest_wire(m, g);
      if (w > widest) widest = w, widest_by = m.grasps[static_cast<std::size_t>(g)].name;
    }
    if (m.num_grasps() > 0 && 2.0 * n.wire_radius > widest)
      t.fail("wire_radius",
             "needle \"" + n.name + "\": its wire (" + format_input_number(2e3 * n.wire_radius) +
                 " mm thick) is larger than the jaws can hold: the widest gap of any grasper's jaws at its "
                 "close angle is " + format_input_number(std::max(0.0, widest) * 1e3) + " mm (\"" + widest_by +
                 "\"), so they never close on it below that angle (raise its close_angle_deg or take a "
                 "thinner wire)");
    // Jaws whose surface dips between their spheres deeper than the wire's radius: they may close
    // on the wire between two spheres and never touch it with both (docs/suturing.md, "A thin
    // wire and the jaws' spheres").
    for (const core::GraspModel& g : m.grasps) {
      const double dip = jaw_dip(m, g);
      if (dip > n.wire_radius)
        scene.warnings.push_back("needle \"" + n.name + "\": grasper \"" + g.name + "\"'s jaws dip " +
                                 format_input_number(dip * 1e3) + " mm between their spheres, more than the wire's radius (" +
                                 format_input_number(n.wire_radius * 1e3) +
                                 " mm): the jaws may close on the wire between two spheres without grasping it; "
                                 "give the jaws spheres closer together (r − √(r² − d²/4) < wire_radius)");
    }
    // Through an organ given by its material on a net coarser than about 1 mm: the tip's load
    // on a node dimples the soft net into a funnel, and a face contact that appears in its crease
    // overshoots the puncture (docs/suturing.md, "An organ given by its material").
    for (std::size_t net_k = 0; net_k < m.nets.size() && net_k < scene.net_loads.size(); ++net_k) {
      const NetLoad& load = scene.net_loads[net_k];
      const double edge = load.material_constants.surface_mean_edge;
      if (!std::isfinite(n.puncture_force) || !load.material || !(edge > kNeedleMaterialNetEdge)) continue;
      scene.warnings.push_back(
          "needle \"" + n.name + "\": deformable \"" + m.nets[net_k].name + "\" is given by its material on a net of " +
          format_input_number(edge * 1e3) + " mm mean edge: the needle's puncture there can overshoot its "
          "puncture_force (3.35 N for 1 N on a slab of 2 mm cells, 1.02 N on 1 mm cells; docs/suturing.md, \"An "
          "organ given by its material\"); give the organ a net of about 1 mm where the needle goes in (nodes or "
          "edge_length)");
    }
    // Placed inside tissue.
    if constexpr (core::kWithDeformable) {
      const core::BodyModel& b = m.bodies[static_cast<std::size_t>(n.body)];
      for (std::size_t net_k = 0; net_k < m.nets.size() && net_k < scene.net_triangles.size(); ++net_k) {
        const core::NetModel& net = m.nets[net_k];
        const std::vector<core::Vec3> rest = net_rest_positions(m, net);
        for (int s = b.sphere_begin; s < b.sphere_begin + b.sphere_count; ++s) {
          const core::Sphere& sp = m.body_spheres[static_cast<std::size_t>(s)];
          const core::Vec3 c = b.initial_pose.position + b.initial_pose.orientation * sp.center;
          bool inside = std::abs(winding_number(rest, scene.net_triangles[net_k], c)) > 0.5;
          for (int i = 0; i < net.node_count && !inside; ++i)
            inside = (c - rest[static_cast<std::size_t>(i)]).norm() <
                     sp.radius + m.node_radius[static_cast<std::size_t>(net.node_begin + i)];
          if (inside)
            t.fail("position", "needle \"" + n.name + "\" starts inside the tissue of deformable \"" + net.name +
                                   "\" (its sphere " + std::to_string(s - b.sphere_begin) + " of " +
                                   std::to_string(b.sphere_count) +
                                   ", tail first, in its rest surface or on a node): place it outside; it "
                                   "enters tissue by puncturing it");
        }
      }
    }
  }
}

}  // namespace numen::sim
