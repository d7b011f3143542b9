/// @file mesh_file.cpp
/// Mesh files through Assimp (see mesh_file.hpp).

#include "numen/sim/scene/mesh_file.hpp"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "mesh_counts.hpp"
#include "mesh_side_files.hpp"
#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

/// The extension of `path` in lower case (".obj").
std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

/// Rethrows std::bad_alloc when Assimp's read failed for want of memory: Assimp catches every
/// exception of an importer and keeps its what() as the error string ("std::bad_alloc"), which
/// would blame the mesh file for the machine's memory. The exception itself where Assimp keeps it
/// (Importer::GetException()), else the string: some of Assimp 5.2's paths keep only that.
void rethrow_out_of_memory(const Assimp::Importer& importer) {
  if (const std::exception_ptr& e = importer.GetException()) {
    try {
      std::rethrow_exception(e);
    } catch (const std::bad_alloc&) {
      throw;
    } catch (...) {
    }
  }
  if (std::string_view(importer.GetErrorString()) == std::bad_alloc().what())
    throw std::bad_alloc();
}

/// The index of an OBJ face corner ("7", "7/2", "7//3", "-1/..."): its first number.
bool corner_index(const std::string& token, long& index) {
  const std::string first = token.substr(0, token.find('/'));
  char* end = nullptr;
  index = std::strtol(first.c_str(), &end, 10);
  return !first.empty() && end != first.c_str() && *end == '\0';
}

/// Checks every vertex line ("v x y z [w | r g b]") and face line ("f a b c ...") of an OBJ file
/// before Assimp reads it, which would read a malformed coordinate as 0 and report a bad index
/// without its line. Throws InputError at the line.
void check_obj_lines(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  long vertices = 0;
  int forward_line = 0;  // first face naming a vertex declared later (allowed if it exists)
  long forward_index = 0;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::size_t i = line.find_first_not_of(" \t");
    if (i == std::string::npos || i + 1 >= line.size() || (line[i + 1] != ' ' && line[i + 1] != '\t'))
      continue;
    const char kind = line[i];
    if (kind != 'v' && kind != 'f') continue;
    std::istringstream fields(line.substr(i + 2));
    std::string token;
    int count = 0;
    while (fields >> token) {
      if (token[0] == '#') break;
      if (kind == 'v') {
        char* end = nullptr;
        const double v = std::strtod(token.c_str(), &end);
        if (end == token.c_str() || *end != '\0' || !std::isfinite(v))
          throw InputError(path, n, 0, "",
                           "vertex coordinate \"" + InputError::visible(token, true) +
                               "\" is not a finite number");
      } else {
        long index = 0;
        if (!corner_index(token, index))
          throw InputError(path, n, 0, "",
                           "face corner \"" + InputError::visible(token, true) +
                               "\" does not start with a vertex number");
        if (index == 0)
          throw InputError(path, n, 0, "", "face names vertex 0 (OBJ counts vertices from 1)");
        if (index < 0 && -index > vertices)
          throw InputError(path, n, 0, "",
                           "face names vertex " + std::to_string(index) + ", before the first (" +
                               std::to_string(vertices) + " vertices so far)");
        if (index > vertices && forward_line == 0) {
          forward_line = n;
          forward_index = index;
        }
      }
      ++count;
    }
    if (kind == 'v') {
      if (count != 3 && count != 4 && count != 6 && count != 7)
        throw InputError(path, n, 0, "",
                         "a vertex needs x y z (optionally w, or r g b): got " +
                             std::to_string(count) + " numbers");
      ++vertices;
    } else if (count < 3) {
      throw InputError(path, n, 0, "",
                       "a face needs at least 3 vertices: got " + std::to_string(count));
    }
  }
  if (forward_line > 0 && forward_index > vertices)
    throw InputError(path, forward_line, 0, "",
                     "face names vertex " + std::to_string(forward_index) + ", the file has " +
                         std::to_string(vertices));
}

/// The exact position of a vertex as a key (vertices at the same position are one).
using PositionKey = std::tuple<float, float, float>;

}  // namespace

double signed_volume(const core::TriangleMesh& mesh) {
  double v = 0.0;
  for (const auto& t : mesh.triangles)
    v += mesh.vertices[static_cast<std::size_t>(t[0])].dot(
             mesh.vertices[static_cast<std::size_t>(t[1])].cross(
                 mesh.vertices[static_cast<std::size_t>(t[2])])) /
         6.0;
  return v;
}

core::TriangleMesh load_mesh_file(const std::string& path, int max_triangles) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, 0, 0, "", "is a directory, not a mesh file");
  if (!std::filesystem::exists(path, ec))
    throw InputError(path, 0, 0, "", "mesh file not found" + (ec ? " (" + ec.message() + ")" : std::string()));
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw InputError(path, 0, 0, "", "cannot open the mesh file");
    if (probe.peek() == std::ifstream::traits_type::eof())
      throw InputError(path, 0, 0, "", "the mesh file is empty: no face");
  }
  // Only the formats whose counts and references are checked here reach Assimp: its other
  // importers trust their headers (an OFF that promises 4·10^8 vertices parses for half a minute).
  const std::string ext = extension_of(path);
  if (ext == ".obj") {
    check_obj_lines(path);
  } else if (ext == ".ply") {
    check_ply_counts(path);
  } else if (ext == ".stl") {
    check_stl_counts(path);
  } else if (ext == ".gltf" || ext == ".glb") {
    check_gltf_uris(path);
  } else {
    throw InputError(path, 0, 0, "",
                     "a mesh file is .stl, .obj, .ply, .gltf or .glb: " +
                         (ext.empty() ? std::string("this one has no extension")
                                      : "not \"" + InputError::visible(ext, true) + "\"") +
                         " (docs/meshes.md)");
  }

  Assimp::Importer importer;
  auto* io = new MeshFolderIOSystem(path);  // owned by the importer
  importer.SetIOHandler(io);
  // Only positions are read: every other component is removed before vertices are joined, so
  // that a corner's normal or texture coordinate does not keep two equal positions apart.
  importer.SetPropertyInteger(
      AI_CONFIG_PP_RVC_FLAGS,
      aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
          aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
          aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS | aiComponent_MATERIALS);
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                aiProcess_SortByPType | aiProcess_PreTransformVertices);
  if (!io->refused().empty())
    throw InputError(path, 0, 0, "",
                     "refers to " + io->refused() + ", outside the mesh file's folder " +
                         io->folder().string() +
                         ": a mesh file's side files (buffers, images, materials) are read only "
                         "from its own folder");
  if (scene == nullptr) {
    rethrow_out_of_memory(importer);
    const std::string why = importer.GetErrorString();
    throw InputError(path, 0, 0, "",
                     "cannot read the mesh file (Assimp: " + InputError::visible(why) + ")" +
                         (why.find("no meshes") != std::string::npos ||
                                  why.find("No meshes") != std::string::npos
                              ? ": no face"
                              : ""));
  }

  std::size_t faces = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m)
    if (scene->mMeshes[m]->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)
      faces += scene->mMeshes[m]->mNumFaces;
  if (faces > static_cast<std::size_t>(max_triangles))
    throw InputError(path, 0, 0, "",
                     "the mesh has " + std::to_string(faces) + " triangles, more than the " +
                         std::to_string(max_triangles) +
                         " a mesh may have (kMaxMeshTriangles, a memory bound: docs/meshes.md)");

  core::TriangleMesh mesh;
  mesh.triangles.reserve(faces);
  std::map<PositionKey, int> index_of;
  std::vector<int> local;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    if (!(am->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    local.assign(am->mNumVertices, -1);
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines left by the sort
      std::array<int, 3> tri{};
      for (unsigned k = 0; k < 3; ++k) {
        const unsigned v = face.mIndices[k];
        if (local[v] < 0) {
          const aiVector3D& p = am->mVertices[v];
          if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            throw InputError(path, 0, 0, "",
                             "mesh " + std::to_string(m) + " vertex " + std::to_string(v) +
                                 " is not finite (" + std::to_string(p.x) + ", " +
                                 std::to_string(p.y) + ", " + std::to_string(p.z) + ")");
          const auto [it, added] = index_of.try_emplace(PositionKey{p.x, p.y, p.z},
                                                        mesh.num_vertices());
          if (added) mesh.vertices.emplace_back(p.x, p.y, p.z);
          local[v] = it->second;
        }
        tri[k] = local[v];
      }
      mesh.triangles.push_back(tri);
    }
  }
  if (mesh.triangles.empty())
    throw InputError(path, 0, 0, "", "the mesh file has no face (no triangle)");

  const std::string invalid = core::validate_mesh(mesh);
  if (!invalid.empty())
    throw InputError(path, 0, 0, "",
                     "invalid mesh (vertices counted from 0 in the order the triangles first use "
                     "them, triangles from 0 after triangulation): " +
                         invalid);
  return mesh;
}

}  // namespace numen::sim
