#pragma once
/// @file scene_model.hpp
/// The physical part of a scene file: materials, contact pairs, bodies with
/// their sphere sets and coupling gains, obstacles, integrator — compiled into
/// a core::Model. Private to numen::sim (used by scene.cpp).

#include <filesystem>
#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads the top-level physics keys and tables of `root` into a core::Model
/// (not yet finalized: the caller sets the held body, then finalizes). Throws InputError (file, line, column, key). Warnings that do
/// not stop the load (e.g. damping outside the paper's rule) are appended. Mesh files
/// (obstacles of type "mesh") are relative to `scene_dir`.
core::Model parse_scene_model(const TomlTable& root, const std::filesystem::path& scene_dir,
                              std::vector<std::string>& warnings);

}  // namespace numen::sim
