/// @file obj_fuzz.cpp
/// libFuzzer harness of the mesh reader (sim/scene/mesh_file.hpp, Assimp) on OBJ text: the input
/// as an .obj file through load_mesh_file() (its line checks, then Assimp). The only accepted
/// failure is sim::InputError; any other exception is a finding.

#include <cstdint>

#include "fuzz_input.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/mesh_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)numen::sim::load_mesh_file(numen::fuzz::input_file(data, size, ".obj"));
  } catch (const numen::sim::InputError&) {
    // a located error: the expected outcome for a bad mesh
  }
  return 0;
}
