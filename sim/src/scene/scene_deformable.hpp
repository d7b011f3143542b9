#pragma once
/// @file scene_deformable.hpp
/// The deformable god-objects of a scene file (docs/scenes.md, paper §4.2):
/// [[deformable]] tables, each a triangle mesh (built-in icosphere, capsule or
/// box, or a Wavefront OBJ file) placed in the frame of a hidden rigid
/// component (a [[body]] without spheres) and compiled by core::add_net() into
/// a mass-spring net tied to that body. Private to numen::sim (used by
/// scene.cpp, before the model is finalized).

#include <filesystem>

#include "numen/core/model.hpp"
#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads the [[deformable]] tables of `root` into `model` (its bodies and
/// materials already parsed; not yet finalized). OBJ paths are relative to
/// `scene_dir`. Throws InputError naming file, line, column and key: unknown
/// keys, unknown body or material, a rigid component with spheres, unknown
/// mesh kind, missing OBJ file, numbers out of range; core::add_net()'s own
/// message is located at the deformable's table. Appends each net's triangles (node indices
/// local to the net) to `triangles`, in the order of model.nets.
void parse_deformables(const TomlTable& root, const std::filesystem::path& scene_dir,
                       core::Model& model, std::vector<NetTriangles>& triangles);

}  // namespace numen::sim
