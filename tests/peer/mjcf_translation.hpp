#pragma once
/// @file mjcf_translation.hpp
/// A compiled numen scene (core::Model) written as MuJoCo's MJCF, in memory (docs/peer.md):
///   - each body: a MuJoCo body whose frame is numen's COM frame, with an explicit <inertial>
///     (same mass, same full inertia tensor) and one sphere geom per sphere of its sphere set
///     (same centres and radii); a body jointed to nothing gets a <freejoint/>;
///   - joints (a forest in numen, maximal coordinates) become MuJoCo's reduced coordinates by
///     nesting each child body in its parent: spherical → ball, revolute → hinge,
///     prismatic → slide, cylindrical → slide + hinge, fixed → no joint, all about the child's
///     joint frame (JointModel::frame_child); a prescribed joint gets an equality constraint
///     q = polycoef[0] updated every step (numen's prescribed row). The trocar joint has no
///     single MuJoCo equivalent and is refused;
///   - bodies of one articulation never collide with each other (<contact><exclude>), as in
///     numen;
///   - static obstacles: plane → plane (infinite, solid below as in numen), box → box,
///     sphere → sphere, capsule → capsule, sphere set → one sphere geom per sphere, in the world
///     body;
///   - contact softness per body geom from soft_constraint_mapping (the body's material against
///     the obstacles' material), the body geoms taking precedence (priority 1) over the static
///     ones; numen's viscous tangential friction μ (N·s/m) has no MuJoCo contact equivalent:
///     μ = 0 → frictionless rows (condim 1), μ > 0 → Coulomb friction of coefficient μ (condim 3);
///   - the device: kMocapWeld — one mocap body per body the device holds during the run, and a
///     weld equality between them (matched to the body's coupling springs k_t, γ_t), active only
///     while that body is held (MuJoCo's documented way to drive a body from a device);
///     kPdForce — no mocap: numen's coupling wrench (Eq. 2, Eq. 6) is applied through
///     mjData::xfrc_applied every step.
/// Same time step and gravity; MuJoCo's default solver (Newton), cone (pyramidal) and
/// integrator (semi-implicit Euler).

#include <string>
#include <vector>

#include "numen/core/model.hpp"

namespace numen::peer {

/// How the device drives the tool in MuJoCo.
enum class Drive {
  kMocapWeld,  ///< A mocap body at the device target, welded to the tool (soft weld equality).
  kPdForce,    ///< numen's coupling springs (Eq. 2) as an explicit wrench in xfrc_applied.
};

/// Name of a drive for tables: "mocap weld", "PD xfrc_applied".
const char* to_string(Drive drive) noexcept;

/// The MJCF text and the names that tie it back to the numen model.
struct MjcfTranslation {
  std::string xml;                      ///< A complete <mujoco> document.
  std::vector<std::string> body_names;  ///< MuJoCo body name of each numen body.
  /// Per numen body: the weld equality to its mocap body ("" if the body is never held).
  std::vector<std::string> weld_names;
  std::vector<std::string> mocap_names;  ///< Per numen body: its mocap body ("" if none).
  /// Per numen joint: the equality constraint holding a prescribed joint ("" if not prescribed).
  std::vector<std::string> prescribed_names;
  /// Per numen joint: numen's joint coordinate at the initial poses, i.e. MuJoCo's q = 0
  /// (rad or m); MuJoCo's q = numen's coordinate − this.
  std::vector<double> coordinate_offset;
  /// What differs from numen in this scene, one remark per line (for docs and the table notes).
  std::vector<std::string> differences;
};

/// Writes `model` as MJCF (file comment). `held_bodies`: the bodies the device holds at some
/// point of the run (welded to their own mocap body with kMocapWeld; ignored with kPdForce).
/// Throws std::invalid_argument for what has no faithful translation (a trocar joint, a body
/// that collides with obstacles of different contact parameters, a deformable net), naming it.
MjcfTranslation translate_to_mjcf(const core::Model& model, Drive drive,
                                  const std::vector<int>& held_bodies);

}  // namespace numen::peer
