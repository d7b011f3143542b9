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
/// scene.binding (device 0's) and each scene.extra_devices[i].binding: a body's `link` is a
/// link of the device its `device` key names, a prescribed joint's `axis` an axis of the device
/// its `prescribed.device` names (either key may be left out in a scene of one device, not of
/// several). A joint's `parent_frame = "trocar"` is the trocar of the device driving its child.
/// Bodies bound to a link that give no `position` start at the link's pose for its device's
/// trajectory's first sample · link_offset. Needs the devices (parse_device()). Throws
/// InputError (file, line, column, key), also for device 0's `attach` body driven by another
/// device's link (a body bound twice) and, at its [[device]] table, for a device after the
/// first that drives nothing (no body's link, no prescribed joint).
void parse_articulation(const TomlTable& root, const std::vector<TomlTable>& body_tables,
                        Scene& scene);

}  // namespace numen::sim
