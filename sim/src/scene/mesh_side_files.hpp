#pragma once
/// @file mesh_side_files.hpp
/// The files a mesh file refers to (a glTF's buffers and images, an OBJ's .mtl): read only from
/// the mesh file's own folder (docs/meshes.md, "Side files"). Assimp follows a glTF buffer's `uri`
/// wherever it points: `../../../../etc/passwd` made another file's bytes an obstacle's vertices,
/// served by `numen view`. Private to numen::sim; load time only.

#include <assimp/DefaultIOSystem.h>

#include <filesystem>
#include <string>

namespace numen::sim {

/// Assimp's file access for one mesh file: opens the mesh file itself and files whose path,
/// resolved canonically (symbolic links followed, `..` removed), lies inside the mesh file's
/// folder (that of the path as given, resolved canonically); any other is not opened (Open()
/// returns null, Exists() false) and remembered in refused(). Handed to
/// Assimp::Importer::SetIOHandler(), which owns it.
class MeshFolderIOSystem final : public Assimp::DefaultIOSystem {
 public:
  /// Confines reads to the folder of `mesh_path`.
  explicit MeshFolderIOSystem(const std::string& mesh_path);

  bool Exists(const char* file) const override;
  Assimp::IOStream* Open(const char* file, const char* mode = "rb") override;

  /// The first path refused, canonical; empty when none was.
  const std::string& refused() const noexcept { return refused_; }
  /// The folder reads are confined to, canonical.
  const std::filesystem::path& folder() const noexcept { return folder_; }

 private:
  /// True when `file` may be read; remembers the first that may not.
  bool allowed(const char* file) const;

  std::filesystem::path folder_;
  std::filesystem::path mesh_;
  mutable std::string refused_;
};

/// Checks a glTF file's (`.gltf` JSON or `.glb` binary) `buffers`, `images` (and glTF 1.0's
/// `shaders`): each `uri` is a `data:` URI or a relative path that stays in the folder; one with a
/// scheme (`file:`, `http:`), an absolute path or a `..` segment is refused, naming the key and the
/// URI. A file that is not JSON is left to Assimp (its parse error). Throws InputError naming
/// `path`.
void check_gltf_uris(const std::string& path);

}  // namespace numen::sim
