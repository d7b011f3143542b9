/// @file scene_mesh.cpp
/// Mesh-file keys of a scene table (see scene_mesh.hpp).

#include "scene_mesh.hpp"

#include <algorithm>
#include <array>
#include <sstream>
#include <system_error>
#include <utility>

#include "numen/core/mesh_shape.hpp"
#include "numen/sim/scene/mesh_cache.hpp"
#include "numen/sim/scene/mesh_file.hpp"
#include "numen/sim/study/study_common.hpp"  // thread_cpu_seconds(): a build's cost, whatever else runs

namespace numen::sim {
namespace {

/// Index in `mesh` of the triangle with the vertices `tri` in that order, or −1.
long triangle_index(const core::TriangleMesh& mesh, const std::array<int, 3>& tri) {
  const auto it = std::find(mesh.triangles.begin(), mesh.triangles.end(), tri);
  return it == mesh.triangles.end() ? -1 : static_cast<long>(it - mesh.triangles.begin());
}

}  // namespace

SceneMeshFile read_scene_mesh_file(const TomlTable& t, const std::filesystem::path& scene_dir) {
  std::filesystem::path file = t.string("file");
  if (file.is_relative()) file = scene_dir / file;
  SceneMeshFile out;
  out.path = file.string();
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    t.fail("file", out.path + " is a directory, not a mesh file");
  if (!std::filesystem::is_regular_file(file, ec))
    t.fail("file", "mesh file not found: " + out.path + (ec ? " (" + ec.message() + ")" : ""));
  try {
    out.mesh = load_mesh_file(out.path);
  } catch (const InputError& e) {
    t.fail("file", e.what());  // "<mesh file>[:<line>]: <message>"
  }
  return out;
}

core::Vec3 read_mesh_scale(const TomlTable& t) {
  const std::string units = t.choice("units", {"m", "cm", "mm"}, "m");
  const double unit = units == "mm" ? 1e-3 : units == "cm" ? 1e-2 : 1.0;
  core::Vec3 scale = core::Vec3::Ones();
  if (const toml::node* n = t.node("scale"); n != nullptr && n->is_number()) {
    scale = core::Vec3::Constant(t.number("scale"));
  } else if (n != nullptr) {
    scale = t.vec3("scale");
  }
  if (!scale.allFinite() || !(scale.cwiseAbs().minCoeff() > 0.0))
    t.fail("scale", "every factor must be finite and non-zero");
  return unit * scale;
}

void check_mesh_size(const TomlTable& t, const core::TriangleMesh& mesh, std::string_view key,
                     const std::string& what) {
  if (mesh.vertices.empty()) return;
  core::Vec3 lo = mesh.vertices.front(), hi = lo;
  for (const core::Vec3& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double size = (hi - lo).maxCoeff();
  if (size >= kMinMeshSize && size <= kMaxMeshSize) return;  // NaN (an overflow) fails too
  t.fail(t.has("scale")   ? "scale"
         : t.has("units") ? "units"
                          : key,
         what + ": the mesh, scaled, spans " + format_input_number(size) +
             " m (its bounding box's longest side), outside [" + format_input_number(kMinMeshSize) +
             ", " + format_input_number(kMaxMeshSize) + "] m: a wrong unit or scale?");
}

void check_scaled_mesh(const TomlTable& t, const core::TriangleMesh& mesh, const std::string& path) {
  const std::string invalid = core::validate_mesh(mesh);
  if (invalid.empty()) return;
  t.fail(t.has("scale") ? "scale" : "file",
         path + ": invalid mesh after scaling and placement (vertices counted from 0 in the order "
                "the triangles first use them): " + invalid);
}

std::string mesh_warning(const TomlTable& t, std::string_view key, const std::string& what,
                         const std::string& message) {
  std::ostringstream os;
  os << t.file();
  if (const toml::node* n = t.node(key)) os << ":" << n->source().begin.line;
  os << ": " << t.key_path(key) << ": " << what << ": " << message;
  return os.str();
}

void warn_self_intersections(const TomlTable& t, std::string_view key, const std::string& what,
                             const core::TriangleMesh& mesh, const core::MeshSelfIntersections& x,
                             std::string_view consequence, std::vector<std::string>& warnings) {
  if (x.count == 0) return;
  warnings.push_back(mesh_warning(
      t, key, what,
      "the surface intersects itself: " + std::to_string(x.count) + " pair" +
          (x.count == 1 ? "" : "s") + " of triangles meet (first: triangles " +
          std::to_string(triangle_index(mesh, x.first_a)) + " and " +
          std::to_string(triangle_index(mesh, x.first_b)) + " of the file, from 0); " +
          std::string(consequence)));
}

std::filesystem::path scene_cache_path(const TomlTable& t, const std::filesystem::path& scene_dir,
                                       const std::string& what,
                                       const std::function<std::string()>& default_name,
                                       std::string_view without, std::vector<std::string>& warnings) {
  std::filesystem::path cache;  // empty: no cache file
  if (!t.has("cache")) return cache;
  const toml::node* n = t.node("cache");
  if (const auto* on = n->as_boolean()) {
    if (on->get()) {
      const std::filesystem::path dir = default_mesh_cache_dir();
      std::error_code ec;
      if (dir.empty())
        warnings.push_back(mesh_warning(t, "cache", what,
                                        "no cache folder ($XDG_CACHE_HOME and $HOME are unset): " +
                                            std::string(without)));
      else if (std::filesystem::create_directories(dir, ec); ec)  // numen's own folder only
        warnings.push_back(mesh_warning(t, "cache", what,
                                        "cannot make the cache folder " + dir.string() + " (" +
                                            ec.message() + "): " + std::string(without)));
      else
        cache = dir / default_name();
    }
  } else if (n->is_string()) {
    cache = t.string("cache");
    if (cache.empty()) t.fail("cache", "expected a file path, true or false");
    if (cache.is_relative()) cache = scene_dir / cache;
  } else {
    t.fail("cache", "expected true, false or a file path (a string)");
  }
  return cache;
}

int add_mesh_shape(const TomlTable& t, const std::filesystem::path& scene_dir, core::Model& m,
                   std::vector<std::string>& warnings) {
  SceneMeshFile file = read_scene_mesh_file(t, scene_dir);
  core::transform_mesh(file.mesh, read_mesh_scale(t), core::Pose{});
  check_mesh_size(t, file.mesh, "file", file.path);
  check_scaled_mesh(t, file.mesh, file.path);
  if (signed_volume(file.mesh) < 0.0) {
    for (auto& tri : file.mesh.triangles) std::swap(tri[1], tri[2]);
    warnings.push_back(mesh_warning(t, "file", file.path,
                                    "the triangles wind inward (negative volume): turned outward"));
  }
  core::MeshShapeOptions options;
  double largest = 0.0;
  for (const core::Sphere& sp : m.body_spheres) largest = std::max(largest, sp.radius);
  options.band = largest > 0.0 ? largest + kMeshBandMargin : core::kMeshDefaultBand;
  core::MeshShape shape;
  const std::filesystem::path cache = scene_cache_path(
      t, scene_dir, file.path,
      [&] {
        return mesh_cache_file_name(std::filesystem::path(file.path).stem().string(),
                                    mesh_cache_key(file.mesh, options));
      },
      "the shape is built at every load", warnings);
  const double t0 = study::thread_cpu_seconds();
  MeshCacheOutcome outcome;
  const std::string err =
      cache.empty() ? core::build_mesh_shape(file.mesh, shape, options)
                    : build_mesh_shape_cached(file.mesh, options, cache, shape, outcome);
  if (outcome.cache_refused) t.fail("cache", err);
  if (!err.empty()) t.fail("file", file.path + ": " + err);
  if (!outcome.note.empty()) warnings.push_back(mesh_warning(t, "cache", file.path, outcome.note));
  const double seconds = study::thread_cpu_seconds() - t0;
  if (!outcome.loaded && seconds >= kSlowMeshBuildSeconds) {
    std::ostringstream os;
    os.precision(2);
    os << "built in " << std::fixed << seconds << " s of CPU ("
       << static_cast<double>(shape.memory_bytes()) / 1e6 << " MB, of which the narrow band "
       << static_cast<double>(core::mesh_band_bytes(shape.band)) / 1e6 << " MB)"
       << (cache.empty() ? "; `cache = true` keeps the built shape for the next load" : "");
    warnings.push_back(mesh_warning(t, "file", file.path, os.str()));
  }
  if (!shape.band.note.empty())
    warnings.push_back(mesh_warning(t, "file", file.path, shape.band.note));
  warn_self_intersections(t, "file", file.path, file.mesh, core::find_self_intersections(shape),
                          "contacts near them may push the wrong way", warnings);
  m.meshes.push_back(std::move(shape));
  return static_cast<int>(m.meshes.size()) - 1;
}

}  // namespace numen::sim
