#pragma once
/// @file peer_scene.hpp
/// The scenes of the peer comparison (issue 6, docs/peer.md): a compiled numen Model and the
/// device inputs of every period, the same for both engines.
///   wall          the god-object pushed into a wall (tests/core/step_test.cpp,
///                 StepBehaviour.GodObjectPushedIntoAWallStaysOutsideWithinThePenaltyBound)
///   construction  sim/scenes/construction.toml (paper Fig. 5/6), inputs recorded through the bus
///   instrument    sim/scenes/lattice.toml: the articulated trocar instrument against the organ
///                 and the tissue plane, on the recorded suturing motion

#include <string>

#include "numen/core/model.hpp"
#include "step_inputs.hpp"

namespace numen::peer {

/// A scene of the comparison.
struct PeerScene {
  std::string name;         ///< "wall", "construction", "instrument".
  std::string description;  ///< One line for the table's notes.
  core::Model model;        ///< Finalized.
  InputRecording inputs;    ///< One per period (dt = model.dt).
};

/// The wall push-through: a ball (radius 10 mm, 50 g) coupled by k_t = 1000 N/m (ζ = 0.85, no
/// rotational spring) to a target that starts 50 mm in front of the plane x = 0 (solid for
/// x > 0; penalty k_c = 1e5 N/m, c = 50 N·s/m, frictionless), moves at 0.2 m/s and stops 50 mm
/// inside it; no gravity; dt = 1 ms; `duration_s` of it (the test runs 3 s). Static bound of the
/// god-object's penetration: k_t (x_end + r) / (k_c + k_t) = 0.594 mm.
PeerScene make_wall_scene(double duration_s);

/// A scene file (path relative to the source tree, e.g. "sim/scenes/construction.toml") named
/// `name`, with the inputs of `duration_s` (< 0: the scene's duration) recorded through
/// sim::SceneRunner. Throws what load_scene / SceneRunner throw.
PeerScene load_recorded_scene(const std::string& name, const std::string& relative_path,
                              double duration_s);

/// The three scenes of the comparison, each cut to `duration_s` (< 0: their full length:
/// wall 3 s, construction 9 s, instrument 30 s).
std::vector<PeerScene> comparison_scenes(double duration_s);

}  // namespace numen::peer
