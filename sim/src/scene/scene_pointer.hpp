#pragma once
/// @file scene_pointer.hpp
/// The pointer trajectory of a scene file (docs/scenes.md, "Trajectory"): `[trajectory]
/// source = "pointer"`, an evemu recording of a mouse (`file`) and the relative-pose
/// integrator's settings (`[trajectory.pointer]`, `[[trajectory.pointer.axis]]`), replayed
/// into a PointerPath at load time. Private to numen::sim (used by scene.cpp).

#include <filesystem>
#include <string>
#include <vector>

#include "numen/hal/input/relative_pose_integrator.hpp"
#include "numen/sim/input/trajectory.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// The integrator settings of `[trajectory.pointer]` in `traj` (the [trajectory] table), with
/// `start` as the initial pose. Every bad key is an InputError at its place: an unknown key,
/// an axis `code` that is neither an EV_REL code name known to libevdev nor a number in
/// [0, REL_MAX], a `dof` not x|y|z|roll|pitch|yaw, a `scale` not finite or zero, more than
/// hal::kMaxRelAxisMappings axes, a `clutch_key` that is neither an EV_KEY name nor a number
/// in [0, KEY_MAX], a `clutch_mode` not hold|toggle|none, a `frame` not world|tool, a
/// workspace corner not finite or above the other, a start position outside the workspace.
hal::RelativePoseIntegratorSettings parse_pointer_settings(const TomlTable& traj,
                                                           const core::Pose& start);

/// The trajectory of `traj` (source = "pointer"): `file` (relative to `scene_dir`) read with
/// hal::load_evemu_recording(), replayed through the integrator into a PointerPath and
/// sampled at `dt`. `start` is the [trajectory.start] pose and jaw. Throws InputError at
/// `trajectory.file` for a file that is missing, a directory, malformed (the message carries
/// the recording's own "path:line:column: what"), without any report, or driving the target
/// beyond kMaxTargetDistance. Adds a warning to `warnings` when the recording never moves the
/// target (the clutch never engaged or no mapped axis moved).
Trajectory parse_pointer_trajectory(const TomlTable& traj, double dt,
                                    const std::filesystem::path& scene_dir,
                                    const TrajectorySample& start,
                                    std::vector<std::string>& warnings);

}  // namespace numen::sim
