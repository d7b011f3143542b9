/// @file mesh_side_files.cpp
/// What a mesh file may refer to (see mesh_side_files.hpp).

#include "mesh_side_files.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <system_error>

#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

/// `p` resolved canonically as far as it exists (the rest lexically normalised).
std::filesystem::path resolved(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::path out =
      std::filesystem::weakly_canonical(std::filesystem::absolute(p, ec), ec);
  return ec ? std::filesystem::path() : out;
}

/// Why `uri` leaves its file's folder, or "" when it does not (a data: URI, a relative path
/// without a ".." segment).
std::string leaves_the_folder(std::string_view uri) {
  if (uri.rfind("data:", 0) == 0) return "";
  std::size_t i = 0;
  while (i < uri.size() && (std::isalnum(static_cast<unsigned char>(uri[i])) || uri[i] == '+' ||
                            uri[i] == '-' || uri[i] == '.'))
    ++i;
  if (i > 0 && i < uri.size() && uri[i] == ':' && std::isalpha(static_cast<unsigned char>(uri[0])))
    return "a URI scheme (\"" + std::string(uri.substr(0, i + 1)) + "\")";
  if (!uri.empty() && (uri[0] == '/' || uri[0] == '\\')) return "an absolute path";
  for (std::size_t a = 0; a <= uri.size();) {
    const std::size_t b = std::min(uri.find_first_of("/\\", a), uri.size());
    if (uri.substr(a, b - a) == "..") return "a \"..\" segment";
    a = b + 1;
  }
  return "";
}

/// The JSON text of a glTF file: the whole file, or a .glb's JSON chunk (bytes 20 to 20 + the
/// length at byte 12, in glTF 2.0's and 1.0's binary containers alike).
std::string gltf_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.size() < 20 || text.compare(0, 4, "glTF") != 0) return text;
  std::uint64_t length = 0;
  for (int k = 3; k >= 0; --k)
    length = (length << 8) | static_cast<unsigned char>(text[12 + static_cast<std::size_t>(k)]);
  return text.substr(20,
                     static_cast<std::size_t>(std::min<std::uint64_t>(length, text.size() - 20)));
}

}  // namespace

MeshFolderIOSystem::MeshFolderIOSystem(const std::string& mesh_path)
    : folder_(resolved(std::filesystem::absolute(mesh_path).parent_path())),
      mesh_(resolved(mesh_path)) {}

bool MeshFolderIOSystem::allowed(const char* file) const {
  const std::filesystem::path p = resolved(file);
  if (!p.empty() && p == mesh_) return true;
  const std::filesystem::path rel = p.lexically_relative(folder_);
  if (!p.empty() && !folder_.empty() && !rel.empty() && *rel.begin() != ".." && rel != ".")
    return true;
  if (refused_.empty()) refused_ = p.empty() ? std::string(file) : p.string();
  return false;
}

bool MeshFolderIOSystem::Exists(const char* file) const {
  return allowed(file) && DefaultIOSystem::Exists(file);
}

Assimp::IOStream* MeshFolderIOSystem::Open(const char* file, const char* mode) {
  return allowed(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
}

void check_gltf_uris(const std::string& path) {
  const nlohmann::json doc = nlohmann::json::parse(gltf_json(path), nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return;  // Assimp names the parse error
  for (const char* group : {"buffers", "images", "shaders"}) {
    const auto it = doc.find(group);
    if (it == doc.end() || !(it->is_array() || it->is_object())) continue;
    std::size_t index = 0;
    for (const auto& [name, item] : it->items()) {
      const std::string key =
          std::string(group) + (it->is_array() ? "[" + std::to_string(index++) + "]" : "." + name);
      if (!item.is_object() || !item.contains("uri") || !item["uri"].is_string()) continue;
      const std::string uri = item["uri"].get<std::string>();
      const std::string why = leaves_the_folder(uri);
      if (!why.empty())
        throw InputError(path, 0, 0, "",
                         key + ".uri \"" + InputError::visible(uri.substr(0, 200), true) +
                             "\" has " + why +
                             ": a glTF's buffers and images are read only from data: URIs and "
                             "relative paths inside the mesh file's folder");
    }
  }
}

}  // namespace numen::sim
