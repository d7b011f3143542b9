#pragma once
/// @file needle.hpp
/// A curved suture needle (docs/suturing.md, "The needle"): a rigid body whose shape is a circular
/// arc of wire, the body an instrument's jaws grasp (grasp.hpp) and, held, the god-object the hand
/// feels through (the paper's tool switching).
///
/// Geometry, in the needle's body frame (origin at its centre of mass, as every BodyModel's): the
/// arc's centre line lies in the body's x–y plane, on the circle of radius R about `centre`, at
/// the angles θ ∈ [θ_tail, θ_tip] (θ_tip − θ_tail = φ, the arc angle; the arc is symmetric about
/// the body's x axis, θ_tail = −φ/2, θ_tip = +φ/2, and `centre` lies on the −x axis). The arc
/// parameter s (m) is the arc length from the tail (the swage, where a thread is tied) to the tip:
/// s ∈ [0, L], L = R φ, θ(s) = θ_tail + s / R. The tangent points from tail to tip (the direction
/// the needle travels when it is driven through tissue: a turn about the body's +z axis).
///
/// Sizes: a needle's "length" is the length along its circumference from swage to point (not the
/// chord; http://www.mrcophth.com/needles/needleanatomy.htm, "Needle Anatomy"), so the common
/// laparoscopic 26 mm half-circle taper needle (Ethicon's SH and CT-2 families) has R = 26 mm / π
/// = 8.28 mm and φ = π.
///
/// Collision: spheres of the wire's radius r_w along the arc (NeedleModel::sphere_count of the
/// body's spheres), their centres at most r_w apart along the arc, so that neighbours overlap by
/// at least their radius and the surface between two of them dips at most (1 − √3/2) r_w = 0.13 r_w
/// below the wire's (a jaw or a node sphere meets a smooth enough wire; nothing passes between).

#include <limits>
#include <string>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;

/// A needle's shape and mass as a scene gives them (add_needle()).
struct NeedleSpec {
  std::string name = "needle";
  double radius = 26e-3 / 3.141592653589793;  ///< R (m) of the arc's centre line, > r_w.
  /// φ / 2π: the arc's fraction of a full circle, in (0, 1) (1/2: a half-circle needle; 3/8 the
  /// other common one).
  double arc = 0.5;
  double wire_radius = 0.35e-3;  ///< r_w (m), > 0: half the wire's diameter.
  /// m (kg), > 0; NaN (the default): a steel wire's, needle_steel_mass().
  double mass = std::numeric_limits<double>::quiet_NaN();
  int material = 0;  ///< Index into Model::material_names.
  Pose pose;         ///< World pose of the needle's body frame (its centre of mass) at reset.
  /// Puncture threshold (N, > 0): the force of the tip's contact with tissue along the needle's
  /// tangent at which it punctures the surface. NaN: none given (the needle never punctures).
  double puncture_force = std::numeric_limits<double>::quiet_NaN();
  /// The largest angle (rad, in (0, π/2]) between the tip's tangent and the surface's inward
  /// normal at which it punctures: no puncture from the side or from behind (60°).
  double puncture_max_angle = 1.0471975511965976;
  /// A puncture point's tie to the arc (needle_puncture.hpp): k (N/m, > 0) and c (N·s/m, ≥ 0)
  /// normal to the tangent, and the viscous friction along it (N·s/m, ≥ 0). Chosen, not measured:
  /// the tie as stiff as ten of the shipped organ's node ties (100 N/m each), the friction 0.02 N
  /// at 10 mm/s of needle travel.
  double tie_stiffness = 1000.0;
  double tie_damping = 1.0;
  double friction = 2.0;
};

/// A needle of a model (Model::needles): its body and its arc in the body frame.
struct NeedleModel {
  std::string name;
  int body = -1;                   ///< Its body (Model::bodies): dynamic, not anchored.
  double radius = 0.0;             ///< R (m), the arc's centre line.
  double arc_angle = 0.0;          ///< φ (rad), in (0, 2π).
  double wire_radius = 0.0;        ///< r_w (m).
  Vec3 centre = Vec3::Zero();      ///< The circle's centre in the body frame (m): (−R sin(φ/2)/(φ/2), 0, 0).
  double tail_angle = 0.0;         ///< θ_tail = −φ/2 (rad, about the body's +z from its +x).
  double tip_angle = 0.0;          ///< θ_tip = +φ/2 (rad).
  int sphere_begin = 0;            ///< First of its spheres in Model::body_spheres (tail first).
  int sphere_count = 0;            ///< Its spheres along the arc, tail to tip.
  double puncture_force = std::numeric_limits<double>::quiet_NaN();  ///< NeedleSpec::puncture_force.
  double puncture_max_angle = 1.0471975511965976;  ///< NeedleSpec::puncture_max_angle (rad).
  double tie_stiffness = 1000.0;   ///< NeedleSpec::tie_stiffness (N/m).
  double tie_damping = 1.0;        ///< NeedleSpec::tie_damping (N·s/m).
  double friction = 2.0;           ///< NeedleSpec::friction (N·s/m).
  /// The puncture test is another's: find_punctures() measures NeedleState::tip_force but does not
  /// puncture, detail::puncture_on_request() does. Set in the multirate scene loop's models for a
  /// needle the device loop steps, whose tip's contacts the device loop renders and tests
  /// (docs/multirate-suturing.md, "A needle in the device loop"); false otherwise.
  bool puncture_on_request = false;
  double length() const noexcept { return radius * arc_angle; }  ///< L = R φ (m).
};

/// Density of surgical stainless steel (kg/m³; AISI 420 / 455, ~7.8e3): the default mass.
inline constexpr double kNeedleSteelDensity = 7.8e3;

/// Mass (kg) of a steel wire of radius `wire_radius` (m) bent along an arc of radius `radius` (m)
/// and fraction `arc` of a circle: ρ π r_w² R 2π arc (kNeedleSteelDensity). The 26 mm half circle
/// of 0.35 mm wire: 78 mg.
double needle_steel_mass(double radius, double arc, double wire_radius) noexcept;

/// Appends the needle's body (its spheres along the arc, its inertia) and its NeedleModel to
/// `model`; returns its index in Model::needles. The body is named spec.name; its inertia is the
/// arc's (a thin wire: ∫ over the arc, about the centre of mass, plus the wire's own cross
/// section's m r_w² / 2 on every axis so that it stays positive definite for a short arc). Does
/// not validate: finalize_model() does (finalize_needles()). Load time; allocates.
int add_needle(Model& model, const NeedleSpec& spec);

/// The arc's centre-line point at arc parameter s (m from the tail, clamped to [0, L]), in the
/// needle's body frame (m).
Vec3 needle_point(const NeedleModel& needle, double s) noexcept;

/// The arc's unit tangent at s (clamped to [0, L]), pointing from tail to tip, body frame.
Vec3 needle_tangent(const NeedleModel& needle, double s) noexcept;

/// The arc parameter s ∈ [0, L] (m) of the centre-line point closest to `point` (body frame, m):
/// the angle of its projection on the arc's plane, clamped to the arc (the nearer end when it
/// falls in the gap; the tail for a point on the circle's axis).
double needle_closest_parameter(const NeedleModel& needle, const Vec3& point) noexcept;

/// The tip's point (s = L) and the tail's (s = 0), body frame (m).
inline Vec3 needle_tip(const NeedleModel& needle) noexcept { return needle_point(needle, needle.length()); }
inline Vec3 needle_tail(const NeedleModel& needle) noexcept { return needle_point(needle, 0.0); }

/// Whether `point` (body frame, m), whose closest arc parameter is `s` (needle_closest_parameter()),
/// has passed off the arc behind its tail (s = 0 and the point behind the tail along its tangent:
/// the needle pulled through) or more than 4 r_w past its tip (the needle drawn back out): where a
/// puncture point is let go (needle_puncture.hpp).
inline bool needle_point_behind_tail(const NeedleModel& needle, const Vec3& point, double s) noexcept {
  return s <= 0.0 && (point - needle_tail(needle)).dot(needle_tangent(needle, 0.0)) < 0.0;
}
inline bool needle_point_past_tip(const NeedleModel& needle, const Vec3& point, double s) noexcept {
  return s >= needle.length() &&
         (point - needle_tip(needle)).dot(needle_tangent(needle, needle.length())) > 4.0 * needle.wire_radius;
}

/// Checks every needle of `model` (radius > wire_radius > 0, arc angle in (0, 2π), a dynamic
/// body with its spheres where add_needle() put them, puncture_force NaN or > 0, the puncture
/// angle in (0, π/2], the tie's stiffness > 0, its damping and friction ≥ 0); returns "" or a
/// message naming the needle and the field. Called by finalize_model().
std::string finalize_needles(const Model& model);

/// The widest wire (diameter, m) that the jaws of grasper `grasp` close below their close angle
/// θ_c on, at their widest point: 2 max over the jaws' spheres of (d sin(θ_c / 2) − r), d the
/// sphere centre's distance from its jaw's hinge axis and r its radius (the jaws' spheres assumed
/// on the jaw's mid-line; a jaw without a hinge counts its spheres' d as 0). A wire thicker than
/// this keeps the jaws open above θ_c: they never grasp it. +∞ for a grasper whose jaws have no
/// hinge joint (nothing to check). Finalized model.
double grasp_widest_wire(const Model& model, int grasp) noexcept;

}  // namespace numen::core
