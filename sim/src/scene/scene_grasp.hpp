#pragma once
/// @file scene_grasp.hpp
/// The [[grasp]] tables of a scene file (docs/scenes.md, "Grasping"; docs/grasping.md):
/// an instrument's two jaws and their grasp rules, compiled into Model::grasps. Private to
/// numen::sim (used by scene.cpp, after the bodies and joints are read).

#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads every [[grasp]] of `root` into scene.model.grasps: `name`, `jaws` (two body names),
/// `close_angle_deg` (default 10) and `open_angle_deg` (default 15, above close_angle_deg),
/// `stiffness` (N/m, default 2000), `damping` (N·s/m, default 2), `grip_radius` (m, default
/// 0.0015), `max_force` (N, default 5) and `tissue` (grasp a net's tissue, default true). Warns (scene.warnings) when a body in the scene is
/// heavier than the grip can hold against gravity (m |g| > max_force), with the numbers. Throws
/// InputError (file, line, column, key) for an unknown key, a jaw that is not a body (or is
/// anchored, or has no spheres), both jaws one body, open_angle_deg ≤ close_angle_deg, or a
/// value out of range.
void parse_grasps(const TomlTable& root, Scene& scene);

}  // namespace numen::sim
