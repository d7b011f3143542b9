/// @file scene_deformable.cpp
/// [[deformable]] tables of a scene file → core::add_net() (paper §4.2).

#include "scene_deformable.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <numeric>
#include <string>
#include <vector>

#include "net_simplify.hpp"
#include "net_tetrahedralize.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/net_tissue_contact.hpp"
#include "numen/sim/scene/mesh_cache.hpp"
#include "numen/sim/study/study_common.hpp"  // thread_cpu_seconds()
#include "scene_mesh.hpp"

namespace numen::sim {
namespace {

using core::Quat;
using core::Vec3;

/// Keys every [[deformable]] accepts, whatever its mesh.
#define NUMEN_DEFORMABLE_COMMON_KEYS                                                          \
  "name", "body", "mesh", "scale", "position", "orientation", "mass", "stiffness", "damping", \
      "bending_stiffness", "bending_damping", "tie_stiffness", "tie_damping", "node_radius",  \
      "material", "rest_speed", "youngs_modulus_kpa", "poisson_ratio", "density",              \
      "rayleigh_stiffness", "support_length", "load_patch_radius", "strain_stiffening"

/// The keys of a net given by its constants per spring and per node (docs/scenes.md,
/// "Deformables"), which a net given by its material derives (docs/tissue.md).
constexpr const char* kSpringNetKeys[] = {"mass",           "stiffness",       "damping",
                                          "bending_stiffness", "bending_damping", "tie_stiffness",
                                          "tie_damping"};
/// The keys of a net given by its material, beside `youngs_modulus_kpa`.
constexpr const char* kMaterialKeys[] = {"poisson_ratio",  "density",           "rayleigh_stiffness",
                                         "support_length", "load_patch_radius", "strain_stiffening"};

/// An integer key in [lo, hi], or `fallback` when absent.
int integer_in(const TomlTable& t, std::string_view key, int lo, int hi, int fallback) {
  const std::int64_t v = t.integer_or(key, fallback);
  if (v < lo || v > hi)
    t.fail(key, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                    "], got " + std::to_string(v));
  return static_cast<int>(v);
}

/// A box's `subdivisions`: one integer for every axis, or [x, y, z], each in [0, 256]
/// (default 2). Fails at the key otherwise.
std::array<int, 3> box_subdivisions(const TomlTable& t) {
  constexpr int kMax = 256;
  const toml::node* node = t.node("subdivisions");
  if (node == nullptr || !node->is_array()) {
    const int n = integer_in(t, "subdivisions", 0, kMax, 2);
    return {n, n, n};
  }
  const std::vector<double> v = t.numbers("subdivisions", 3);
  std::array<int, 3> n{};
  for (std::size_t d = 0; d < 3; ++d) {
    if (!(v[d] >= 0.0 && v[d] <= kMax && v[d] == std::floor(v[d]))) {
      char value[32];
      std::snprintf(value, sizeof value, "%g", v[d]);
      t.fail("subdivisions", "must be an integer in [0, " + std::to_string(kMax) +
                                 "] or three of them [x, y, z]; entry " + std::to_string(d) +
                                 " is " + value);
    }
    n[d] = static_cast<int>(v[d]);
  }
  return n;
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

/// Fails at `key` when a net would have more than kMaxNetNodes nodes (a built-in mesh, a mesh
/// file used as it is, or the size a mesh file is simplified to).
void check_node_count(const TomlTable& t, std::string_view key, double nodes) {
  if (nodes > kMaxNetNodes)
    t.fail(key, "this mesh would have " + std::to_string(static_cast<long long>(nodes)) +
                    " nodes, more than the " + std::to_string(static_cast<int>(kMaxNetNodes)) +
                    " a net may have");
}

/// Fails when a built-in mesh's table sets the size of a net made from a mesh file: a built-in
/// shape is its own net, sized by its own keys (`own_keys`).
void refuse_net_size_keys(const TomlTable& t, const std::string& kind, const char* own_keys) {
  for (const char* key : {"nodes", "edge_length"})
    if (t.has(key))
      t.fail(key, std::string("sets the size of a net simplified from a mesh file (mesh = \"file\"); "
                              "the built-in ") + kind + " is its own net, sized by " + own_keys);
}

/// The mesh of one [[deformable]] in its own frame (before scale and placement).
core::TriangleMesh parse_mesh(const TomlTable& t, const std::filesystem::path& scene_dir) {
  const std::string kind =
      t.choice("mesh", {"icosphere", "capsule", "box", "obj", "file"}, std::nullopt);
  if (kind == "icosphere") {
    refuse_net_size_keys(t, kind, "radius and subdivisions");
    t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "radius", "subdivisions"});
    const double r = t.number_in("radius", 1e-6, kInf, std::nullopt);
    return core::make_icosphere(r, integer_in(t, "subdivisions", 0, 6, 2));
  }
  if (kind == "capsule") {
    refuse_net_size_keys(t, kind, "segments, rings and cylinder_rings");
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
    refuse_net_size_keys(t, kind, "subdivisions");
    t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "half_extents", "subdivisions"});
    const Vec3 h = t.vec3("half_extents");
    if (!(h.minCoeff() > 0.0)) t.fail("half_extents", "must all be > 0");
    const std::array<int, 3> n = box_subdivisions(t);
    check_node_count(t, "subdivisions",
                     (n[0] + 2.0) * (n[1] + 2.0) * (n[2] + 2.0) - 1.0 * n[0] * n[1] * n[2]);
    return core::make_box(h, n);
  }
  // "obj" (the key's first name) and "file": any format the mesh reader takes.
  // Its node count is checked once the net's size is known (net_size()).
  t.allow_only({NUMEN_DEFORMABLE_COMMON_KEYS, "file", "units", "nodes", "edge_length", "cache"});
  return read_scene_mesh_file(t, scene_dir).mesh;
}

/// The fewest nodes of a closed surface: a tetrahedron's.
constexpr int kMinClosedNodes = 4;

/// Node count of the net made from mesh file `mesh` (scaled and placed, m): `nodes`, or the count
/// `edge_length` gives (a closed surface of area A tiled by equilateral triangles of side L has
/// F = A / (√3 L² / 4) triangles and F / 2 + 2 vertices), or kDefaultNetNodes for a mesh of more
/// vertices than that; `load` records which. A count at or above the mesh's own is the mesh as it
/// is. Fails, located at the key: both keys, a count below kMinClosedNodes or above the mesh's
/// vertices, a length that is not > 0.
int net_size(const TomlTable& t, const core::TriangleMesh& mesh, NetLoad& load) {
  const int vertices = mesh.num_vertices();
  const std::string file = t.string("file");
  if (t.has("nodes") && t.has("edge_length"))
    t.fail("edge_length", "give nodes or edge_length, not both (both size the net of " + file + ")");
  if (t.has("nodes")) {
    const std::int64_t n = t.integer("nodes");
    if (n < kMinClosedNodes)
      t.fail("nodes", "a closed net needs at least " + std::to_string(kMinClosedNodes) +
                          " nodes (a tetrahedron), got " + std::to_string(n));
    const bool capped = vertices > kMaxNetNodes;  // the cap, not the mesh, bounds the count
    const std::string most =
        capped ? std::to_string(static_cast<int>(kMaxNetNodes)) + ", the most a net may have"
               : std::to_string(vertices) + ", which is the mesh itself";
    if (n > vertices)
      t.fail("nodes", std::to_string(n) + " nodes is more than the " + std::to_string(vertices) +
                          " vertices of " + file +
                          ": the net is made by simplifying the mesh, "
                          "never by refining it (at most " +
                          most + ")");
    if (n > kMaxNetNodes)
      t.fail("nodes", std::to_string(n) + " nodes is more than the " +
                          std::to_string(static_cast<int>(kMaxNetNodes)) +
                          " a net may have (at most " + most + ")");
    load.nodes_from = "nodes";
    return static_cast<int>(n);
  }
  if (t.has("edge_length")) {
    const double length = t.number("edge_length");
    if (!(length > 0.0) || !std::isfinite(length))
      t.fail("edge_length", "must be a length > 0 (m, in the frame of the scaled mesh), got " +
                                format_input_number(length));
    const std::vector<double> areas = core::vertex_areas(mesh);
    const double area = std::accumulate(areas.begin(), areas.end(), 0.0);
    const double nodes = 2.0 * area / (std::sqrt(3.0) * length * length) + 2.0;
    if (!(nodes >= kMinClosedNodes - 0.5))
      t.fail("edge_length", format_input_number(length) + " m edges on the " +
                                format_input_number(area * 1e4) + " cm² surface of " + file +
                                " make " + format_input_number(std::round(nodes)) +
                                " nodes, fewer than the " + std::to_string(kMinClosedNodes) +
                                " of a closed net (a tetrahedron): give a shorter length");
    load.nodes_from = "edge_length";
    return nodes >= vertices ? vertices : static_cast<int>(std::lround(nodes));
  }
  if (vertices > kDefaultNetNodes) {
    load.nodes_from = "default";
    return kDefaultNetNodes;
  }
  load.nodes_from = "mesh";
  return vertices;
}

/// Simplifies mesh file `mesh` (scaled and placed, m) to a net of about `nodes` nodes
/// (simplify_to_net()), or reads that net from the cache file `cache` names (mesh_cache.hpp,
/// simplify_net_cached(); `load` records which, `source` says "the net simplified from it" or
/// "the net read from cache file <path>"). Fails, located at `key` (the key that asked for it)
/// and naming the file: a mesh that is not closed (a hole: the net would be open where the organ
/// is closed), a simplification that fails or gives a net that is not a valid, closed surface;
/// at `cache`: a path that is not nothing or a numen net cache (simplify_net_cached()), before
/// the simplification. Appends a warning when the net keeps more nodes than asked, at `cache`
/// when a cache file is stale, damaged or cannot be written, and at `key` when the
/// simplification took kSlowNetSimplifySeconds or more of wall-clock time without a cache
/// (slow_net_simplification_hint()).
core::TriangleMesh simplify_mesh_file(const TomlTable& t, const std::filesystem::path& scene_dir,
                                      std::string_view key, const core::TriangleMesh& mesh,
                                      int nodes, NetLoad& load, std::string& source,
                                      std::vector<std::string>& warnings) {
  const std::string file = t.string("file");
  const int boundary = core::build_mesh_topology(mesh).boundary_edges;
  if (boundary > 0)
    t.fail(key, file + ": the mesh has " + std::to_string(boundary) + " edge" +
                    (boundary == 1 ? "" : "s") +
                    " on one triangle only (holes): a net is simplified from a closed surface "
                    "only (every edge in two triangles); close the mesh, or give nodes = " +
                    std::to_string(mesh.num_vertices()) + " to make the mesh itself the net");
  const std::filesystem::path cache = scene_cache_path(
      t, scene_dir, file,
      [&] {
        return net_cache_file_name(std::filesystem::path(file).stem().string(),
                                   net_cache_key(mesh, nodes, net_simplifier_version()));
      },
      "the net is simplified at every load", warnings);
  core::TriangleMesh net;
  MeshCacheOutcome outcome;
  double simplify_wall_s = 0.0;  // of simplify_to_net() alone
  const auto simplify = [&](core::TriangleMesh& out) {
    const auto t0 = std::chrono::steady_clock::now();
    std::string e = simplify_to_net(mesh, nodes, out);
    simplify_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return e;
  };
  const std::string err =
      cache.empty() ? simplify(net)
                    : simplify_net_cached(mesh, nodes, net_simplifier_version(), cache, simplify,
                                          net, outcome);
  if (outcome.cache_refused) t.fail("cache", err);
  if (!err.empty()) t.fail(key, file + ": simplifying the mesh to " + std::to_string(nodes) +
                                    " nodes failed: " + err);
  if (!outcome.note.empty()) warnings.push_back(mesh_warning(t, "cache", file, outcome.note));
  if (const auto hint = slow_net_simplification_hint(simplify_wall_s, nodes, !cache.empty()))
    warnings.push_back(mesh_warning(t, key, file, *hint));
  load.cache_loaded = outcome.loaded;
  source = outcome.loaded ? "the net read from cache file " + cache.string()
                          : std::string("the net simplified from it");
  std::string invalid = core::validate_mesh(net);
  if (invalid.empty() && core::build_mesh_topology(net).boundary_edges > 0)
    invalid = "it has edges on one triangle only";
  if (!invalid.empty())
    t.fail(key, file + ": " + source + " to " + std::to_string(nodes) +
                    " nodes is not a closed, valid surface: " + invalid);
  if (net.num_vertices() != nodes)
    warnings.push_back(
        mesh_warning(t, key, file,
                     source + " keeps " + std::to_string(net.num_vertices()) + " nodes, not the " +
                         std::to_string(nodes) +
                         " asked: further edge collapses would have made it non-manifold"));
  return net;
}

/// The longest side of `mesh`'s bounding box (m).
double mesh_size(const core::TriangleMesh& mesh) {
  if (mesh.vertices.empty()) return 0.0;
  Vec3 lo = mesh.vertices.front(), hi = lo;
  for (const Vec3& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return (hi - lo).maxCoeff();
}

/// Maps fine surface `fine` on net `net` of `m` (made from `coarse`, in the same frame: the net's
/// rigid component's body frame; `source` says where the net came from, simplify_mesh_file())
/// with core::add_net_surface(), each fine vertex on its nearest net triangle at rest. Appends a
/// warning when a fine vertex stands off the net by more than net_surface_offset_bound(): beyond
/// half the net's mean edge the fine surface lies outside the band the net's node spheres cover
/// (radius edge / √3 by default, core::add_net()), so the net's contacts and its fine surface
/// disagree, and the offset carried in a bent triangle's frame distorts the surface; beyond
/// kMaxFineOffsetShare of the organ's size the net simulates another shape than the organ's,
/// however coarse its edges.
void map_fine_surface(const TomlTable& t, core::Model& m, int net, const core::TriangleMesh& coarse,
                      const core::TriangleMesh& fine, const std::string& source,
                      std::vector<std::string>& warnings) {
  const std::vector<int> nearest = nearest_net_triangles(coarse, fine.vertices);
  const std::string err = core::add_net_surface(m, net, fine.vertices, fine.triangles, nearest);
  if (!err.empty()) t.fail_at(nullptr, t.path(), source + ": " + err);
  const double offset = core::net_surface_max_offset(m, net);
  const double half_edge = 0.5 * mean_edge_length(coarse);
  const double size = mesh_size(fine);
  const double bound = net_surface_offset_bound(half_edge, size);
  if (offset > bound)
    warnings.push_back(mesh_warning(
        t, "file", t.string("file"),
        "the fine surface stands up to " + format_input_number(offset * 1e3) + " mm off " + source +
            ", more than " + format_input_number(bound * 1e3) +
            " mm (the smaller of half the net's mean edge, " +
            format_input_number(half_edge * 1e3) + " mm, and " +
            format_input_number(kMaxFineOffsetShare * 100.0) + " % of the organ's " +
            format_input_number(size * 1e3) +
            " mm size): the net is not the organ's shape there, its node spheres may not cover "
            "the surface and a bent net triangle distorts it; ask for more nodes"));
}

/// The constants of a net given per spring and per node (docs/scenes.md, "Deformables").
void read_spring_constants(const TomlTable& t, core::NetSettings& settings) {
  settings.mass = t.number_in("mass", 1e-12, kInf, std::nullopt);
  settings.stiffness = t.number_in("stiffness", 0.0, kInf, std::nullopt);
  settings.damping = t.number_in("damping", 0.0, kInf, 0.0);
  settings.bending_stiffness = t.number_in("bending_stiffness", 0.0, kInf, 0.0);
  settings.bending_damping = t.number_in("bending_damping", 0.0, kInf, 0.0);
  settings.tie_stiffness = t.number_in("tie_stiffness", 1e-12, kInf, std::nullopt);
  settings.tie_damping = t.number_in("tie_damping", 0.0, kInf, 0.0);
  settings.node_radius = t.number_in("node_radius", 1e-9, kInf, 0.0);
  settings.rest_speed = t.number_in("rest_speed", 0.0, kInf, core::NetSettings{}.rest_speed);
}

/// The tissue of a [[deformable]] given by its material (`youngs_modulus_kpa` present): fails at a
/// per-spring key beside it (what replaces it: the material), at a material key without it, and at
/// the first bad material value (core::validate_material()). Returns whether the net is a material
/// net (`settings` then filled but for the name and body).
bool parse_tissue(const TomlTable& t, core::MaterialNetSettings& settings) {
  if (!t.has("youngs_modulus_kpa")) {
    for (const char* key : kMaterialKeys)
      if (t.has(key))
        t.fail(key, "belongs to an organ given by its material: set youngs_modulus_kpa as well "
                    "(docs/tissue.md), or remove it for a net given per spring");
    return false;
  }
  for (const char* key : kSpringNetKeys)
    if (t.has(key))
      t.fail(key, std::string("a net given by its material (youngs_modulus_kpa) derives its ") +
                      "masses, springs and ties from youngs_modulus_kpa, poisson_ratio, density, "
                      "rayleigh_stiffness and support_length (docs/tissue.md): remove " + key +
                      ", or remove youngs_modulus_kpa for a net given per spring");
  core::NetMaterial& mat = settings.tissue;
  mat.youngs_modulus = 1e3 * t.number("youngs_modulus_kpa");
  mat.poisson_ratio = t.number("poisson_ratio");
  mat.density = t.number_or("density", 1000.0);
  mat.rayleigh_stiffness = t.number_or("rayleigh_stiffness", 0.0);
  mat.support_length = t.number("support_length");
  mat.strain_stiffening = t.number_or("strain_stiffening", 0.0);
  const char* key = "";
  if (const std::string err = core::validate_material(mat, &key); !err.empty()) t.fail(key, err);
  settings.node_radius = t.number_in("node_radius", 1e-9, kInf, 0.0);
  settings.rest_speed = t.number_in("rest_speed", 0.0, kInf, core::NetSettings{}.rest_speed);
  settings.load_patch_radius = t.number_in("load_patch_radius", 1e-6, kInf, 0.0);
  return true;
}

/// A material net whose surface's mean edge is above this many load patch radii is warned: it
/// resolves the patch poorly (docs/tissue.md, "The contact"; the default patch is two edges of
/// a 500-node net, whose simplified nets' mean edge is about 0.55 ρ).
constexpr double kPatchEdgeWarning = 0.6;

/// Appends the material net of closed surface `surface` (the net's triangles) to `m`: its volume
/// tetrahedralised with interior nodes kInteriorSpacingEdges mean edges apart
/// (tetrahedralize_net()), the constants derived
/// (core::add_material_net()). Fails at `key` (the key that made the surface) naming `file` when
/// the surface cannot be tetrahedralised, at the table for what add_material_net() refuses.
/// Records the mesh and the constants in `load`; warns when the symplectic Euler integrator's
/// step limit for the net is below the scene's dt.
void add_tissue_net(const TomlTable& t, core::Model& m, const core::TriangleMesh& surface,
                    const core::MaterialNetSettings& settings, std::string_view key,
                    const std::string& file, NetLoad& load, std::vector<std::string>& warnings) {
  core::TetrahedralMesh volume;
  const double spacing = kInteriorSpacingEdges * mean_edge_length(surface);
  if (const std::string err = tetrahedralize_net(surface, spacing, volume); !err.empty())
    t.fail(key, file + ": the organ's volume cannot be tetrahedralised for its material: " + err);
  core::MaterialNetConstants c;
  if (const std::string err = core::add_material_net(m, volume, settings, &c); !err.empty())
    t.fail_at(nullptr, t.path(), err);
  load.material = true;
  load.interior_nodes = static_cast<int>(volume.interior.size());
  load.tetrahedra = static_cast<int>(volume.tetrahedra.size());
  load.material_constants = c;
  load.tissue = settings;
  if (c.surface_mean_edge > kPatchEdgeWarning * c.load_patch_radius)
    warnings.push_back(mesh_warning(
        t, t.has("load_patch_radius") ? "load_patch_radius" : "youngs_modulus_kpa", file,
        "the net's mean edge " + format_input_number(c.surface_mean_edge) +
            " m is above 0.6 times the contact's load patch radius " +
            format_input_number(c.load_patch_radius) +
            " m: the net resolves the patch poorly and the organ feels stiffer or softer than "
            "its material (docs/tissue.md, \"The contact\"); give it more nodes or a larger "
            "load_patch_radius"));
  if (const core::TissueLawPoissonRange rows = core::tissue_law_poisson_range();
      settings.tissue.poisson_ratio < rows.min)
    warnings.push_back(mesh_warning(
        t, "poisson_ratio", file,
        "the contact law's neo-Hookean half-space is tabulated for Poisson's ratios " +
            format_input_number(rows.min) + " to " + format_input_number(rows.max) + ": " +
            format_input_number(settings.tissue.poisson_ratio) +
            " takes the " + format_input_number(rows.min) +
            " row under a tool's sphere (docs/tissue.md, \"The contact\"); the net's springs "
            "and ties keep the material's"));
  if (m.integrator == core::Integrator::kSymplecticEuler && m.dt > c.explicit_step_limit)
    warnings.push_back(mesh_warning(
        t, "youngs_modulus_kpa", file,
        "the material's stiffest spring, with its damping, needs a step of at most " +
            format_input_number(c.explicit_step_limit) + " s with the symplectic Euler integrator, "
            "above the scene's dt = " + format_input_number(m.dt) +
            " s: the net will blow up; use implicit-euler or tr-bdf2, a smaller dt, or fewer nodes"));
}

void parse_deformable(const TomlTable& t, const std::filesystem::path& scene_dir, core::Model& m,
                      std::vector<NetTriangles>& triangles, std::vector<NetLoad>& loads,
                      std::vector<std::string>& warnings) {
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
  NetLoad load;
  load.mesh_vertices = mesh.num_vertices();
  load.mesh_triangles = mesh.num_triangles();
  load.nodes_asked = mesh.num_vertices();
  load.nodes_from = "mesh";
  if (file) load.nodes_asked = net_size(t, mesh, load);
  const bool simplify = load.nodes_asked < mesh.num_vertices();
  warn_self_intersections(t, file ? "file" : "mesh", t.string(file ? "file" : "mesh"), mesh,
                          core::find_self_intersections(mesh),
                          simplify ? "the organ's fine surface passes through itself"
                                   : "the net's rest surface passes through itself",
                          warnings);

  settings.material = net_material(t, m, settings.body);
  core::MaterialNetSettings tissue;
  const bool material = parse_tissue(t, tissue);
  if (material && !m.bodies[static_cast<std::size_t>(settings.body)].anchored)
    t.fail("youngs_modulus_kpa",
           "a net given by its material is an organ's: its rigid component (body \"" +
               m.bodies[static_cast<std::size_t>(settings.body)].name +
               "\") must be anchored = true (a moving deformable's node spheres collide, and its "
               "interior nodes' spheres would reach through its surface; docs/tissue.md)");
  tissue.name = settings.name;
  tissue.body = settings.body;
  tissue.material = settings.material;
  // A net given per spring: every constant of its own (docs/scenes.md, "Deformables").
  const auto add = [&](const core::TriangleMesh& surface, std::string_view key) {
    if (material) {
      add_tissue_net(t, m, surface, tissue, key, t.string(t.has("file") ? "file" : "mesh"), load,
                     warnings);
      return std::string();
    }
    return core::add_net(m, surface, settings);
  };
  if (!material) read_spring_constants(t, settings);

  if (simplify) {  // a coarser net, the file's surface on it
    const std::string key = load.nodes_from == "default" ? std::string("file") : load.nodes_from;
    check_node_count(t, key, load.nodes_asked);  // before the simplification's time is spent
    const double t0 = study::thread_cpu_seconds();
    std::string source;
    core::TriangleMesh net =
        simplify_mesh_file(t, scene_dir, key, mesh, load.nodes_asked, load, source, warnings);
    warn_self_intersections(t, key, t.string("file"), net, core::find_self_intersections(net),
                            source + " passes through itself: ask for more nodes", warnings);
    const std::string err = add(net, key);
    if (!err.empty()) t.fail_at(nullptr, t.path(), load.cache_loaded ? source + ": " + err : err);
    map_fine_surface(t, m, m.num_nets() - 1, net, mesh, source, warnings);
    load.simplified = true;
    load.simplify_seconds = study::thread_cpu_seconds() - t0;
    triangles.push_back(std::move(net.triangles));  // node i of the net is vertex i of `net`
  } else {
    if (file)  // at the key that made the mesh its own net
      check_node_count(t, load.nodes_from == "edge_length" ? "edge_length" : "file",
                       mesh.num_vertices());
    if (t.has("cache"))
      warnings.push_back(mesh_warning(t, "cache", t.string("file"),
                                      "the mesh is its own net (not simplified): nothing to cache"));
    const std::string err = add(mesh, file ? "file" : "mesh");
    if (!err.empty()) t.fail_at(nullptr, t.path(), err);
    triangles.push_back(std::move(mesh.triangles));  // node i of the net is vertex i of the mesh
  }
  loads.push_back(std::move(load));
}

#undef NUMEN_DEFORMABLE_COMMON_KEYS

}  // namespace

double net_surface_offset_bound(double half_edge, double organ_size) {
  return std::min(half_edge, kMaxFineOffsetShare * organ_size);
}

void parse_deformables(const TomlTable& root, const std::filesystem::path& scene_dir,
                       core::Model& model, std::vector<NetTriangles>& triangles,
                       std::vector<NetLoad>& loads, std::vector<std::string>& warnings) {
  for (const TomlTable& t : root.tables("deformable"))
    parse_deformable(t, scene_dir, model, triangles, loads, warnings);
}

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

std::vector<Vec3> net_rest_positions(const core::Model& m, const core::NetModel& net) {
  const core::BodyModel& anchor = m.bodies[static_cast<std::size_t>(net.body)];
  std::vector<Vec3> rest(static_cast<std::size_t>(net.node_count));
  for (int i = 0; i < net.node_count; ++i)
    rest[static_cast<std::size_t>(i)] =
        anchor.initial_pose.position +
        anchor.initial_pose.orientation * m.node_rest[static_cast<std::size_t>(net.node_begin + i)];
  return rest;
}

void warn_organs_inside_tools(const core::Model& m, const std::vector<NetTriangles>& triangles,
                              std::vector<std::string>& warnings) {
  for (std::size_t k = 0; k < m.nets.size() && k < triangles.size(); ++k) {
    const core::NetModel& net = m.nets[k];
    const core::BodyModel& anchor = m.bodies[static_cast<std::size_t>(net.body)];
    if (!anchor.anchored) continue;
    const std::vector<Vec3> rest = net_rest_positions(m, net);
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
