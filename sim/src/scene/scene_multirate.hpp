#pragma once
/// @file scene_multirate.hpp
/// The [multirate] table of a scene file (docs/scenes.md, docs/multirate.md): the scene loop's
/// period and the proximity margin of a multirate god-object, checked against what
/// core::MultirateGodObject runs. Private to numen::sim (used by scene.cpp, after the model,
/// the device binding and the events are read).

#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads [multirate] of `root` into scene.multirate (left empty without the table):
///   scene_dt — the scene loop's period (s), a whole multiple N ≥ 1 of dt (to 1e-9 relative);
///   margin   — the proximity margin δ (m, in [0, 1]); required when N > 1, 0 by default at N = 1.
/// The tools are the held body and the events' bodies; each one's god-object is its
/// articulation (core::god_object_bodies()), with, in a scene of several devices, every other
/// device's (its first bound body's: MultirateScene::other_devices, a composite god-object). Refuses (located at the table) what a multirate
/// god-object cannot run: the admittance coupling, a tool that make_god_object_model() refuses
/// (a net on it whose centre of mass is off its component's, an integrator without an
/// effective contact force), another device that drives no body, a scene of several devices
/// whose first device holds no body at the start or releases it (`[[event]] attach = "none"`,
/// located there), and a device binding (any
/// device's) that drives a body or prescribes a joint outside every tool's god-object, and a net on a
/// body outside them. Needs a finalized scene.model, scene.binding
/// and scene.events. Throws InputError (file, line, column, key). Load time: allocates.
void parse_multirate(const TomlTable& root, Scene& scene);

}  // namespace numen::sim
