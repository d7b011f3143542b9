/// @file scene_fuzz.cpp
/// libFuzzer harness of the TOML scene loader (sim/scene/scene.hpp, toml++ compiled into numen_sim
/// with upstream PR #305): the input as a scene file through load_scene(). The only accepted
/// failure is sim::InputError (file, line, column, key); any other exception escapes and is a
/// finding. corpus/scene/toml-issue-295-middle-dot is the regression input of toml++ #295.

#include <cstdint>

#include "fuzz_input.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)numen::sim::load_scene(numen::fuzz::input_file(data, size, ".toml"));
  } catch (const numen::sim::InputError&) {
    // a located error: the expected outcome for a bad scene
  }
  return 0;
}
