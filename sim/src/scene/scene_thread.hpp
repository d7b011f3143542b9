#pragma once
/// @file scene_thread.hpp
/// The [[thread]] tables of a scene file (docs/thread.md): suture threads compiled into Model::threads (core/include/numen/core/thread.hpp).
/// Private to numen::sim (used by scene.cpp, after the bodies are read).

#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads every [[thread]] of `root` into scene.model.threads: `name`, `length` (m, > 0),
/// `segments` (≥ 1), `radius` (m, > 0), `youngs_modulus_kpa` (> 0), `density` (kg/m³, > 0),
/// `damping` (N·s/m², ≥ 0), `break_strain` (> 0), `material`, the initial straight line
/// `start` (m, world; with `attach_body` the attach point's starting position, which it must
/// equal if given) and `direction`, and the start's tie: `attach_body` (a body's name; absent:
/// the start is free), `attach_point` (m, the body's frame), `attach_direction` (the body's
/// frame: the end is clamped along it; absent: pinned); `self_contact` (default true). Defaults:
/// ThreadModel's (3-0 silk). Throws InputError (file, line, column, key) for an unknown key, a
/// value out of range, an unknown body or material.
void parse_threads(const TomlTable& root, Scene& scene);

}  // namespace numen::sim
