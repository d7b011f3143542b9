#pragma once
/// @file lattice_scene.hpp
/// The shipped lattice scene, sim/scenes/lattice.toml: the default scene (default.toml) with a
/// rigid sphere-lattice organ in place of its deformable one (same instrument, joints, tissue,
/// device, bus and recording; docs/scenes.md). The tests that measure the lattice's figures, or
/// need only *a* scene with the articulated instrument, load it: its step costs a few µs, the
/// default scene's 240–430 µs (the organ's 1002 nodes in the implicit solve).
/// Header-only; include from numen::sim test files only.

#include <filesystem>
#include <string>

#include "numen/sim/scene/scene.hpp"

namespace numen::test {

/// Path of the shipped lattice scene: lattice.toml beside the default scene
/// (sim::default_scene_path(), the source tree's sim/scenes in the tests).
inline std::string lattice_scene_path() {
  return (std::filesystem::path(numen::sim::default_scene_path()).parent_path() / "lattice.toml").string();
}

}  // namespace numen::test
