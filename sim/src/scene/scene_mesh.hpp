#pragma once
/// @file scene_mesh.hpp
/// The keys of a mesh file in a scene table — `file`, `units`, `scale` — shared by the
/// [[deformable]] nets, the mesh obstacles and the bodies' meshes (docs/meshes.md), and the
/// collision shape built from such a table. Private to numen::sim.
/// Load time only (allocates, throws InputError located at the key, naming the mesh file).

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "numen/core/mesh.hpp"
#include "numen/core/mesh_shape_intersect.hpp"
#include "numen/core/model.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// A mesh read from a scene table's `file` key, with the path it was read from.
struct SceneMeshFile {
  core::TriangleMesh mesh;  ///< In the file's frame and units.
  std::string path;         ///< `file` resolved against the scene's folder.
};

/// Reads `file` (a path relative to `scene_dir`, or absolute) with load_mesh_file(). Any
/// InputError of the mesh file is raised again at the table's `file` key, its message naming the
/// mesh file (and the mesh file's line, for an OBJ line).
SceneMeshFile read_scene_mesh_file(const TomlTable& t, const std::filesystem::path& scene_dir);

/// The factor of `units` ("m" 1, "cm" 0.01, "mm" 0.001; "m" when absent) times `scale` (one
/// number or [x, y, z], each finite and non-zero; a negative product mirrors the mesh; 1 when
/// absent), per axis.
core::Vec3 read_mesh_scale(const TomlTable& t);

/// Smallest and largest size a scaled mesh may have (m, the longest side of its bounding box).
/// A scene is an instrument's reach (kMaxTargetDistance, 10 m, from its origin) and the organs,
/// tools and fixtures in it, from a fraction of a millimetre to a metre or two: 1 km is a hundred
/// reaches and 1 µm is below every sphere and contact depth a scene measures. Outside, the
/// `units` or `scale` is wrong: `scale = 1e30` made every step non-finite (penetrations of
/// 2.5·10^31 mm), `scale = 1e-30` estimated its narrow band at ~10^32 bytes (docs/meshes.md,
/// "Size").
inline constexpr double kMinMeshSize = 1e-6;
inline constexpr double kMaxMeshSize = 1e3;

/// Fails when `mesh` (scaled, and placed for a net) spans less than kMinMeshSize or more than
/// kMaxMeshSize: at `scale`, else `units`, else `key` (the table's `file` or `mesh`), naming
/// `what` (the mesh file's path, or a built-in mesh's kind), the size and the bounds.
void check_mesh_size(const TomlTable& t, const core::TriangleMesh& mesh, std::string_view key,
                     const std::string& what);

/// Fails at `scale` (or `file` when absent) when the mesh, scaled and placed, no longer passes
/// core::validate_mesh() (a triangle degenerate after scaling), naming `path`.
void check_scaled_mesh(const TomlTable& t, const core::TriangleMesh& mesh, const std::string& path);

/// The warning "<scene file>:<line>: <key path>: <what>: <message>" located at `key` of `t`
/// (`what`: the mesh file's path, or the name of a built-in mesh).
std::string mesh_warning(const TomlTable& t, std::string_view key, const std::string& what,
                         const std::string& message);

/// Appends a mesh_warning() at `key` when `x` (the pairs of `mesh`'s triangles that meet,
/// core::find_self_intersections()) is not empty: "the surface intersects itself: N pairs of
/// triangles meet (first: triangles A and B of the file, from 0); <consequence>", A and B the
/// pair's indices in `mesh` (the file's order).
void warn_self_intersections(const TomlTable& t, std::string_view key, const std::string& what,
                             const core::TriangleMesh& mesh, const core::MeshSelfIntersections& x,
                             std::string_view consequence, std::vector<std::string>& warnings);

/// Margin added to the largest sphere radius of the bodies for a mesh shape's narrow band (m):
/// every sphere of the scene's bodies then gets the band's flat query (docs/meshes.md).
inline constexpr double kMeshBandMargin = 0.001;

/// A build that takes at least this much CPU time (s, the loading thread's) is reported with its
/// time and memory, a warning at `file` (docs/meshes.md, "Build cache").
inline constexpr double kSlowMeshBuildSeconds = 1.0;

/// The cache file that `t`'s optional `cache` key names for mesh file `what` (its path): true,
/// `default_name()` in default_mesh_cache_dir(), that folder made when missing (no cache, with a
/// warning at `cache` saying `without` happens instead, when that folder is unknown or cannot be
/// made); a string, that file (relative to `scene_dir`; no folder is made for it); false or
/// absent, none (an empty path). Anything else fails at `cache`.
std::filesystem::path scene_cache_path(const TomlTable& t, const std::filesystem::path& scene_dir,
                                       const std::string& what,
                                       const std::function<std::string()>& default_name,
                                       std::string_view without, std::vector<std::string>& warnings);

/// The closed mesh of `t`'s `file` (`units`, `scale`), built as a collision shape
/// (core::build_mesh_shape()) in its own frame and appended to `m.meshes`; returns its index. Its
/// narrow band's width is the largest radius in m.body_spheres plus kMeshBandMargin. An
/// inward-wound mesh is turned outward with a warning; an open or inconsistently wound one is
/// refused at `file`. Warnings at `file` too: a surface that intersects itself, a narrow band over
/// its memory cap (the tree answers), a build of kSlowMeshBuildSeconds or more (its time and
/// memory). `cache` (optional): true reads and writes the built shape in
/// default_mesh_cache_dir(), a string in that file (relative to `scene_dir`), false or absent
/// builds it at every load (mesh_cache.hpp); a stale or damaged cache file, or one that cannot be
/// written, is a warning at `cache` and the shape is built; a path that names anything but
/// nothing or a numen mesh-shape cache (build_mesh_shape_cached()) fails at `cache`, before the
/// build. Load time only.
int add_mesh_shape(const TomlTable& t, const std::filesystem::path& scene_dir, core::Model& m,
                   std::vector<std::string>& warnings);

}  // namespace numen::sim
