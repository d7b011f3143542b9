/// @file obj_fuzz.cpp
/// libFuzzer harness of the mesh reader (sim/scene/mesh_file.hpp, Assimp): the input as a mesh
/// file through load_mesh_file() (its checks of each format, then Assimp), named after what it
/// starts with so that every checked format is reached: ".ply" for "ply", ".glb" for "glTF",
/// ".gltf" for "{", ".stl" for "solid" or a binary STL's size (84 + 50 × its count, in 32 bits),
/// ".obj" for the rest. The only accepted failure is sim::InputError; any other exception, an
/// abort or a crash is a finding.

#include <cstdint>
#include <cstring>
#include <string_view>

#include "fuzz_input.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/mesh_file.hpp"

namespace {

/// The file name suffix of the format `data` looks like.
const char* mesh_suffix(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (text.rfind("ply", 0) == 0) return ".ply";
  if (text.rfind("glTF", 0) == 0) return ".glb";
  if (text.rfind("{", 0) == 0) return ".gltf";
  if (text.rfind("solid", 0) == 0) return ".stl";
  if (size >= 84) {
    std::uint32_t count = 0;
    std::memcpy(&count, data + 80, 4);
    // In 32 bits, as Assimp decides it: a count whose 84 + 50 N wraps to the size is reached too.
    if (std::uint32_t{84} + std::uint32_t{50} * count == size) return ".stl";
  }
  return ".obj";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)numen::sim::load_mesh_file(numen::fuzz::input_file(data, size, mesh_suffix(data, size)));
  } catch (const numen::sim::InputError&) {
    // a located error: the expected outcome for a bad mesh
  }
  return 0;
}
