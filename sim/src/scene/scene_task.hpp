#pragma once
/// @file scene_task.hpp
/// The [task] table of a scene file (docs/scenes.md, "Grasping"; docs/grasping.md, "Peg
/// transfer"): the objects a bimanual task moves and the pegs they go to. Private to numen::sim
/// (used by scene.cpp, after the bodies and obstacles are read).

#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads `[task]` of `root`, if any, into scene.task: `objects` (names of dynamic bodies, none
/// twice), `pegs` (names of capsule obstacles, none twice) and `reach` (m, > 0, default 0.005).
/// Throws InputError (file, line, column, key) for an unknown key, a missing or empty list, a
/// name that is no such body or obstacle, an anchored object, a peg that is not a capsule, a
/// name given twice, or a reach out of range.
void parse_task(const TomlTable& root, Scene& scene);

}  // namespace numen::sim
