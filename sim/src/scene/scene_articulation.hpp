#pragma once
/// @file scene_articulation.hpp
/// The articulated part of a scene file (docs/scenes.md): [[joint]] tables,
/// the [baumgarte] settings, and the bodies' `link` bindings to the
/// instrument's links (paper Eq. 6) with the joints' `prescribed` axes —
/// compiled into Model::joints and the platform::DeviceBinding. Private to
/// numen::sim (used by scene.cpp, after the device section is parsed).

#include <vector>

#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads [[joint]] and [baumgarte] of `root` and the `link` / `link_offset`
/// keys of the [[body]] tables `body_tables` (same order as
/// scene.model.bodies) into scene.model.joints, scene.model.baumgarte and
/// scene.binding. Bodies bound to a link that give no `position` start at the
/// link's pose for the trajectory's first sample · link_offset. Needs
/// scene.device and scene.trajectory. Throws InputError (file, line, column, key).
void parse_articulation(const TomlTable& root, const std::vector<TomlTable>& body_tables,
                        Scene& scene);

}  // namespace numen::sim
