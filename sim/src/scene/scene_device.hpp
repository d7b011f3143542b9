#pragma once
/// @file scene_device.hpp
/// The device of a scene file (docs/scenes.md, "Device"): `[device]` with its axes, its CANopen
/// nodes and their DCFs, its force feedback and its admittance coupling, compiled into a
/// hal::DeviceConfig. Private to numen::sim (used by scene.cpp).

#include <string_view>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// The index in `m` of the body a device holds, named by string key `key` of `t`, −1 for
/// "none". Throws InputError at the key for a name that is no [[body]] or an anchored one.
int body_index(const TomlTable& t, std::string_view key, const core::Model& m);

/// Reads `[device]`, or every entry of `[[device]]` (docs/scenes.md, "Several devices"), of
/// `root`: device 0 into scene.device, scene.model.feedback, the admittance settings, scene.hand,
/// scene.plant, scene.igtl, scene.trocar_note and scene.model.initial_held_body (`attach`), the
/// others into scene.extra_devices (their bindings are parse_articulation()'s).
/// `trajectories` holds each device's trajectory (one per device table; a trocar is placed from
/// its device's approach), moved into scene.trajectory (device 0's) and the extra devices'. `held_body_table` is then the [[body]] table of the held body (of
/// `body_tables`, one per body), or null. Needs scene.model.dt (the control period) and
/// coupling_mode and the bodies' names. Throws InputError (file, line, column, key) for an
/// unknown key or a bad value, and for devices that clash on the shared bus: a name used twice,
/// a CANopen node id or a COB-ID of two devices (located at the later device's key).
void parse_device(const TomlTable& root, Scene& scene, const TomlTable*& held_body_table,
                  const std::vector<TomlTable>& body_tables,
                  std::vector<Trajectory> trajectories);

}  // namespace numen::sim
