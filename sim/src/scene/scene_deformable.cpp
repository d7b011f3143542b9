/// @file scene_deformable.cpp
/// [[deformable]] tables of a scene file → core::add_net() (paper §4.2).

#include "scene_deformable.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/net_model.hpp"
#include "scene_mesh.hpp"

namespace numen::sim {
namespace {

using core::Quat;
using core::Vec3;

/// Keys every [[deformable]] accepts, whatever its mesh.
#define NUMEN_DEFORMABLE_COMMON_KEYS                                                          \
  "name", "body", "mesh", "scale", "position", "orientation", "mass", "stiffness", "damping", \
      "bending_stiffness", "bending_damping", "tie_stiffness", "tie_damping", "node_radius",  \
      "material"

/// An integer key in [lo, hi], or `fallback` when absent.
int integer_in(const TomlTable& t, std::string_view key, int lo, int hi, int fallback) {
  const std::int64_t v = t.integer_or(key, fallback);
  if (v < lo || v > hi)
    t.fail(key, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                    "], got " + std::to_string(v));
  return static_cast<int>(v);
}

/// Index of the rigid component named by `body`: a [[body]] without spheres.
int rigid_component(const TomlTable& t, const core::Model& m) {
  const std::string name = t.string("body");
  for (int i = 0; i < m.num_bodies(); ++i) {
    const core::BodyModel& b = m.bodies[static_cast<std::size_t>(i)];
    if (b.name != name) continue;
    if (b.sphere_count > 0)
      t.fail("body", "body \"" + name + "\" has " + std::to_string(b.sphere_count) +
                         (b.sphere_count == 1 ? " sphere" : " spheres") +
                         (b.anchored ? ": the anchored rigid component of a deformable organ "
                                       "holds the net's rest shape but does not collide; "
                                     : ": the rigid component of a deformable is the paper's hidden "
                                       "rigid god-object (§4.2), it follows the device but does not "
                                       "collide; ") +
                         "give it no spheres (the net's nodes collide)");
    return i;
  }
  std::string list;
  for (const auto& b : m.bodies) list += (list.empty() ? "" : ", ") + b.name;
  t.fail("body", "no body named \"" + name + "\" (bodies: " + (list.empty() ? "none" : list) + ")");
}

/// Material by name; the rigid component's when the key is absent.
int net_material(const TomlTable& t, const core::Model& m, int body) {
  if (!t.has("material")) return m.bodies[static_cast<std::size_t>(body)].material;
  const std::string name = t.string("material");
  for (int i = 0; i < m.num_materials(); ++i)
    if (m.material_names[static_cast<std::size_t>(i)] == name) return i;
  std::string list;
  for (const auto& n : m.material_names) list += (list.empty() ? "" : ", ") + n;
  t.fail("material", "unknown material \"" + name + "\" (declared: " + list + ")");
}

/// Cylinder rings of a capsule whose spacing along z matches the arc spacing
/// π r / (2 rings) of its hemispheres (near-equilateral triangles).
int default_cylinder_rings(double radius, double half_length, int rings) {
  const double spacing = std::numbers::pi * radius / (2.0 * rings);
  const double n = std::min(2.0 * half_length / spacing, 1e6);  // clamped before the cast
  return std::max(0, static_cast<int>(std::lround(n)) - 1);
}

/// Largest net a scene may declare (nodes): far above the 2562-node
/// benchmark, far below what would exhaust memory at load.
constexpr double kMaxNetNodes = 65536.0;

/// Fails at `key` when a built-in mesh would have more than kMaxNetNodes nodes.
void check_node_count(const TomlTable& t, const char* key, double nodes) {
  if (nodes > kMaxNetNodes)
    t.fail(key, "this mesh would have " + std::to_string(static_cast<long long>(nodes)) +
                    " nodes, more than the " + std::to_string(static_cast<int>(kMaxNetNodes)) +
                    " a net may have");
}

/// The mesh of one [[deformable]] in its own frame (before scale and placement).
core::TriangleMesh parse_mesh(const TomlTable& t, const std::filesystem::path& scene_dir) {
  const std::string kind =
      t.choice("mesh", {"icosphere", "capsule", "box", "obj", "file"}, std::nullopt);
  if (kind == "icosphere") {
    t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "radius", "subdivisions"});
    const double r = t.number_in("radius", 1e-6, kInf, std::nullopt);
    return core::make_icosphere(r, integer_in(t, "subdivisions", 0, 6, 2));
  }
  if (kind == "capsule") {
    t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "radius", "half_length", "segments", "rings",
                  "cylinder_rings"});
    const double r = t.number_in("radius", 1e-6, kInf, std::nullopt);
    const double h = t.number_in("half_length", 0.0, kInf, std::nullopt);
    const int segments = integer_in(t, "segments", 3, 1024, 16);
    const int rings = integer_in(t, "rings", 1, 256, 4);
    const int cylinder_rings =
        integer_in(t, "cylinder_rings", 0, 100000, default_cylinder_rings(r, h, rings));
    check_node_count(t, "mesh", 2.0 + segments * (2.0 * rings + cylinder_rings));
    return core::make_capsule(r, h, segments, rings, cylinder_rings);
  }
  if (kind == "box") {
    t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "half_extents", "subdivisions"});
    const Vec3 h = t.vec3("half_extents");
    if (!(h.minCoeff() > 0.0)) t.fail("half_extents", "must all be > 0");
    const int n = integer_in(t, "subdivisions", 0, 256, 2);
    const double side = n + 2.0;
    check_node_count(t, "subdivisions", 6.0 * side * side - 12.0 * side + 8.0);
    return core::make_box(h, n);
  }
  // "obj" (the key's first name) and "file": any format the mesh reader takes.
  t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "file", "units"});
  core::TriangleMesh mesh = read_scene_mesh_file(t, scene_dir).mesh;
  check_node_count(t, "file", mesh.num_vertices());
  return mesh;
}

void parse_deformable(const TomlTable& t, const std::filesystem::path& scene_dir, core::Model& m,
                      std::vector<NetTriangles>& triangles, std::vector<std::string>& warnings) {
  core::NetSettings settings;
  settings.name = t.string("name");
  for (const core::NetModel& other : m.nets)
    if (other.name == settings.name)
      t.fail("name", "deformable \"" + settings.name + "\" declared twice");
  settings.body = rigid_component(t, m);
  core::TriangleMesh mesh = parse_mesh(t, scene_dir);  // checks the keys for its kind
  const Vec3 scale = read_mesh_scale(t);
  core::Pose placement;
  placement.position = t.vec3_or("position", Vec3::Zero());
  placement.orientation = t.quaternion_or("orientation", Quat::Identity());
  core::transform_mesh(mesh, scale, placement);
  const bool file = t.has("file");
  check_mesh_size(t, mesh, file ? "file" : "mesh", t.string(file ? "file" : "mesh"));
  if (file) check_scaled_mesh(t, mesh, t.string("file"));
  warn_self_intersections(t, file ? "file" : "mesh", t.string(file ? "file" : "mesh"), mesh,
                          core::find_self_intersections(mesh),
                          "the net's rest surface passes through itself", warnings);

  settings.material = net_material(t, m, settings.body);
  settings.mass = t.number_in("mass", 1e-12, kInf, std::nullopt);
  settings.stiffness = t.number_in("stiffness", 0.0, kInf, std::nullopt);
  settings.damping = t.number_in("damping", 0.0, kInf, 0.0);
  settings.bending_stiffness = t.number_in("bending_stiffness", 0.0, kInf, 0.0);
  settings.bending_damping = t.number_in("bending_damping", 0.0, kInf, 0.0);
  settings.tie_stiffness = t.number_in("tie_stiffness", 1e-12, kInf, std::nullopt);
  settings.tie_damping = t.number_in("tie_damping", 0.0, kInf, 0.0);
  settings.node_radius = t.number_in("node_radius", 1e-9, kInf, 0.0);

  const std::string err = core::add_net(m, mesh, settings);
  if (!err.empty()) t.fail_at(nullptr, t.path(), err);
  triangles.push_back(std::move(mesh.triangles));  // node i of the net is vertex i of the mesh
}

#undef NUMEN_DEFORMABLE_COMMON_KEYS

}  // namespace

void parse_deformables(const TomlTable& root, const std::filesystem::path& scene_dir,
                       core::Model& model, std::vector<NetTriangles>& triangles,
                       std::vector<std::string>& warnings) {
  for (const TomlTable& t : root.tables("deformable"))
    parse_deformable(t, scene_dir, model, triangles, warnings);
}

namespace {

/// Winding number of the closed triangle surface `tris` (vertices `verts`) about `p`: ±1 inside,
/// 0 outside (Van Oosterom & Strackee 1983's solid angle of each triangle, summed over 4π).
double winding_number(const std::vector<Vec3>& verts, const NetTriangles& tris, const Vec3& p) {
  double omega = 0.0;
  for (const auto& t : tris) {
    const Vec3 a = verts[static_cast<std::size_t>(t[0])] - p;
    const Vec3 b = verts[static_cast<std::size_t>(t[1])] - p;
    const Vec3 c = verts[static_cast<std::size_t>(t[2])] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    omega += 2.0 * std::atan2(num, den);
  }
  return omega / (4.0 * std::numbers::pi);
}

}  // namespace

void warn_organs_inside_tools(const core::Model& m, const std::vector<NetTriangles>& triangles,
                              std::vector<std::string>& warnings) {
  for (std::size_t k = 0; k < m.nets.size() && k < triangles.size(); ++k) {
    const core::NetModel& net = m.nets[k];
    const core::BodyModel& anchor = m.bodies[static_cast<std::size_t>(net.body)];
    if (!anchor.anchored) continue;
    std::vector<Vec3> rest(static_cast<std::size_t>(net.node_count));
    for (int i = 0; i < net.node_count; ++i)
      rest[static_cast<std::size_t>(i)] =
          anchor.initial_pose.position +
          anchor.initial_pose.orientation * m.node_rest[static_cast<std::size_t>(net.node_begin + i)];
    for (const core::BodyModel& tool : m.bodies) {
      if (tool.anchored || tool.sphere_count == 0) continue;
      double overlap = 0.0;  // deepest node-sphere overlap (m)
      int inside = 0;        // sphere centres inside the closed rest surface
      for (int s = tool.sphere_begin; s < tool.sphere_begin + tool.sphere_count; ++s) {
        const core::Sphere& sp = m.body_spheres[static_cast<std::size_t>(s)];
        const Vec3 c = tool.initial_pose.position + tool.initial_pose.orientation * sp.center;
        for (int i = 0; i < net.node_count; ++i)
          overlap = std::max(overlap, sp.radius + m.node_radius[static_cast<std::size_t>(net.node_begin + i)] -
                                          (c - rest[static_cast<std::size_t>(i)]).norm());
        if (std::abs(winding_number(rest, triangles[k], c)) > 0.5) ++inside;
      }
      if (!(overlap > 0.0) && inside == 0) continue;
      warnings.push_back(
          "deformable \"" + net.name + "\" starts inside body \"" + tool.name + "\": " +
          (inside > 0 ? std::to_string(inside) + " of its " + std::to_string(tool.sphere_count) +
                            " spheres' centres lie inside the organ's rest surface"
                      : std::string("its spheres overlap the organ's node spheres")) +
          " (deepest node overlap " + format_input_number(overlap * 1e3) +
          " mm) at the starting poses: the first steps push the tool out of the organ, or it "
          "stays inside the hollow net; move the organ (its [[body]] position) or start the "
          "trajectory elsewhere");
    }
  }
}

}  // namespace numen::sim
