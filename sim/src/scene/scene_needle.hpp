#pragma once
/// @file scene_needle.hpp
/// The [[needle]] tables of a scene file (docs/suturing.md, "The
/// needle"): curved suture needles, each a body of its own shape (core::add_needle()). Private to
/// numen::sim (used by scene.cpp).

#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads every [[needle]] of `root` into scene.model (a body and a core::NeedleModel each, after
/// the [[body]] bodies and the nets): `name`, `radius` (m, the arc's centre line; default 26 mm /
/// π, the 26 mm half circle), `arc` (fraction of a circle in (0, 1), default 0.5), `wire_radius`
/// (m, default 0.35 mm, below radius), `mass` (kg, default a steel wire's,
/// core::needle_steel_mass()), `material`, `position` and `orientation` (the pose of its centre of
/// mass frame: the arc in its x–y plane, symmetric about its x axis, the tip at +y),
/// `puncture_force` (N, > 0; absent: the needle does not puncture), `puncture_max_angle_deg` (in
/// (0, 90], default 60), `tie_stiffness` (N/m, > 0, default 1000), `tie_damping` (N·s/m, default 1)
/// and `friction` (N·s/m, default 2) of its puncture points (core::NeedleSpec). Throws InputError (file,
/// line, column, key) for an unknown key, a name taken by a body or another needle, or a value out
/// of range.
void parse_needles(const TomlTable& root, Scene& scene);

/// The checks of the needles that need the finalized model (after core::finalize_model()): a
/// needle whose wire is thicker than every grasper's jaws close on (core::grasp_widest_wire(); a
/// scene with graspers), or whose spheres start inside a deformable's rest surface or overlapping
/// its node spheres: InputError located at the needle's `wire_radius` or `position`. Warns
/// (scene.warnings) of a grasper whose jaws' surface dips between their spheres deeper than the
/// wire's radius (they may close on the wire between two spheres without grasping it), and of a
/// puncturing needle with an organ given by its material on a net whose mean edge passes
/// kNeedleMaterialNetEdge (its puncture can overshoot the threshold there), with the numbers.
void check_needles(const TomlTable& root, Scene& scene);

/// The mean edge (m) of an organ given by its material above which a needle's puncture is warned
/// of: on the test slab the puncture force was 3.35 N for 1 N at 2 mm cells, 1.02 N at 1 mm
/// (docs/suturing.md, "An organ given by its material").
inline constexpr double kNeedleMaterialNetEdge = 0.0015;

}  // namespace numen::sim
