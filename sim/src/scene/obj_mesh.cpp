/// @file obj_mesh.cpp
/// Wavefront OBJ surface meshes through tinyobjloader (see obj_mesh.hpp).

#include "numen/sim/scene/obj_mesh.hpp"

#include <tiny_obj_loader.h>

#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

/// The loader's multi-line warning or error text on one line: its lines,
/// trimmed of blanks and trailing dots, joined by "; ".
std::string one_line(const std::string& text) {
  std::string out;
  std::size_t b = 0;
  while (b < text.size()) {
    std::size_t e = text.find('\n', b);
    if (e == std::string::npos) e = text.size();
    std::string line = text.substr(b, e - b);
    while (!line.empty() && (line.back() == '.' || line.back() == ' ' || line.back() == '\r' ||
                             line.back() == '\t')) {
      line.pop_back();
    }
    const std::size_t first = line.find_first_not_of(" \t.");
    if (first != std::string::npos) {
      if (!out.empty()) out += "; ";
      out += line.substr(first);
    }
    b = e + 1;
  }
  return out;
}

/// The first "line N" or "line: N" the loader wrote into `text`, 0 when there
/// is none.
int line_of(const std::string& text) {
  for (std::size_t p = text.find("line"); p != std::string::npos; p = text.find("line", p + 1)) {
    std::size_t q = p + 4;
    if (q < text.size() && text[q] == ':') ++q;
    if (q >= text.size() || text[q] != ' ') continue;
    ++q;
    int line = 0;
    std::size_t digits = 0;
    while (q < text.size() && std::isdigit(static_cast<unsigned char>(text[q])) && digits < 9) {
      line = 10 * line + (text[q] - '0');
      ++q;
      ++digits;
    }
    if (digits > 0) return line;
  }
  return 0;
}

/// True when a loader warning says faces were dropped or point outside the
/// vertex list (the loader only warns about these; the mesh would be silently
/// incomplete). Warnings about materials, normals and texture coordinates are
/// harmless here: only positions are read.
bool geometry_warning(const std::string& warn) {
  return warn.find("Vertex indices out of bounds") != std::string::npos ||
         warn.find("Degenerated face") != std::string::npos ||
         warn.find("invalid vertex index") != std::string::npos;
}

/// `message`, followed by the loader's warnings when it gave any.
std::string with_loader_text(const std::string& message, const std::string& warn) {
  const std::string w = one_line(warn);
  return w.empty() ? message : message + " (tinyobjloader: " + w + ")";
}


/// Checks every vertex line ("v x y z [w | r g b]") before the loader reads
/// it: tinyobjloader reads a missing or malformed coordinate as 0, which
/// would silently give another mesh. Throws InputError at the line.
void check_vertex_lines(const std::string& path, std::istream& in) {
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::size_t i = line.find_first_not_of(" \t");
    if (i == std::string::npos || line.compare(i, 2, "v ") != 0) {
      if (i == std::string::npos || line.compare(i, 2, "v\t") != 0) continue;
    }
    std::istringstream fields(line.substr(i + 2));
    std::string token;
    int count = 0;
    while (fields >> token) {
      if (token[0] == '#') break;
      char* end = nullptr;
      const double v = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0' || !std::isfinite(v))
        throw InputError(path, n, 0, "",
                         "vertex coordinate \"" + token + "\" is not a finite number");
      ++count;
    }
    if (count != 3 && count != 4 && count != 6 && count != 7)
      throw InputError(path, n, 0, "",
                       "a vertex needs x y z (optionally w, or r g b): got " +
                           std::to_string(count) + " numbers");
  }
  in.clear();
  in.seekg(0);
}

}  // namespace

core::TriangleMesh load_obj_mesh(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, 0, 0, "", "is a directory, not an OBJ file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the OBJ file");
  check_vertex_lines(path, in);

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn;
  std::string err;
  // No material reader: `mtllib` lines are skipped, no .mtl file is opened.
  const bool ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in,
                                   /*readMatFn=*/nullptr, /*triangulate=*/true);
  if (!ok || !err.empty()) {
    throw InputError(path, line_of(err), 0, "",
                     with_loader_text("cannot parse the OBJ file", err + warn));
  }
  if (geometry_warning(warn)) {
    throw InputError(path, 0, 0, "", with_loader_text("bad face in the OBJ file", warn));
  }

  const int num_positions = static_cast<int>(attrib.vertices.size() / 3);
  std::vector<std::array<int, 3>> triangles;
  for (const tinyobj::shape_t& shape : shapes) {
    const tinyobj::mesh_t& m = shape.mesh;
    std::size_t offset = 0;
    for (std::size_t f = 0; f < m.num_face_vertices.size(); ++f) {
      const std::size_t n = m.num_face_vertices[f];
      if (n < 3 || offset + n > m.indices.size()) {
        throw InputError(path, 0, 0, "",
                         with_loader_text("shape '" + shape.name + "' face " + std::to_string(f) +
                                              " has " + std::to_string(n) + " vertices",
                                          warn));
      }
      for (std::size_t k = 0; k < n; ++k) {
        const int v = m.indices[offset + k].vertex_index;
        if (v < 0 || v >= num_positions) {
          throw InputError(
              path, 0, 0, "",
              with_loader_text("shape '" + shape.name + "' face " + std::to_string(f) +
                                   ": vertex " + std::to_string(v + 1) + " does not exist (" +
                                   std::to_string(num_positions) + " vertices)",
                               warn));
        }
      }
      // The loader has triangulated; a fan covers any polygon it left whole.
      for (std::size_t k = 1; k + 1 < n; ++k) {
        triangles.push_back({m.indices[offset].vertex_index, m.indices[offset + k].vertex_index,
                             m.indices[offset + k + 1].vertex_index});
      }
      offset += n;
    }
  }
  if (triangles.empty()) {
    throw InputError(path, 0, 0, "", with_loader_text("the OBJ file has no face", warn));
  }

  // Keep the used positions, in file order, and renumber the triangles.
  std::vector<int> new_index(static_cast<std::size_t>(num_positions), -1);
  for (const auto& t : triangles) {
    for (const int v : t) new_index[static_cast<std::size_t>(v)] = 0;
  }
  core::TriangleMesh mesh;
  for (int v = 0; v < num_positions; ++v) {
    const auto i = static_cast<std::size_t>(v);
    if (new_index[i] < 0) continue;
    new_index[i] = mesh.num_vertices();
    mesh.vertices.emplace_back(static_cast<double>(attrib.vertices[3 * i]),
                               static_cast<double>(attrib.vertices[3 * i + 1]),
                               static_cast<double>(attrib.vertices[3 * i + 2]));
  }
  mesh.triangles.reserve(triangles.size());
  for (const auto& t : triangles) {
    mesh.triangles.push_back({new_index[static_cast<std::size_t>(t[0])],
                              new_index[static_cast<std::size_t>(t[1])],
                              new_index[static_cast<std::size_t>(t[2])]});
  }

  const std::string invalid = core::validate_mesh(mesh);
  if (!invalid.empty()) {
    // validate_mesh() counts from 0, over the used vertices and the triangles
    // after triangulation; say how that maps to the file.
    const std::string numbering = mesh.num_vertices() == num_positions
                                      ? "vertex i is the file's vertex i+1"
                                      : "vertices counted from 0 over the " +
                                            std::to_string(mesh.num_vertices()) + " used ones";
    throw InputError(path, 0, 0, "",
                     with_loader_text("invalid mesh (" + numbering +
                                          ", triangles counted from 0 after "
                                          "triangulation): " +
                                          invalid,
                                      warn));
  }
  return mesh;
}

}  // namespace numen::sim
