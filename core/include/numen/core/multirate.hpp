#pragma once
/// @file multirate.hpp
/// The intermediate contact model of a multirate god-object (docs/multirate.md): the scene
/// loop, at the slow period, finds the god-object's contacts and hands the device loop one
/// local constraint per contact — a plane carried by the other side, with its penalty material
/// — which the device loop evaluates at its own pose every fast period, its stiffness and
/// damping implicit in the god-object's integrator (Mark et al., "Adding force feedback to
/// graphics systems", SIGGRAPH 1996; Otaduy & Lin, "A modular haptic rendering algorithm for
/// stable and transparent 6-DOF manipulation", IEEE T-RO 22(4), 2006; SOFA's
/// LCPForceFeedback plays the same role for constraint-based contact).
///
/// What is here: the god-object model the device loop steps (make_god_object_model), the
/// proximity model the scene loop detects with (make_proximity_model: the god-object's spheres
/// grown by a margin, so that a plane exists before its sphere reaches the surface), the planes
/// (ContactPlaneSet, build_contact_planes), the device step against them (step_god_object), and
/// the two loops interleaved on one thread, the scene bodies receiving the impulse the device
/// loop's planes gave the god-object (MultirateGodObject). Rigid god-objects without joints,
/// scenes without nets, the linearly implicit and symplectic Euler schemes; the threads and the
/// scene file's [multirate] are docs/multirate.md's next steps.

#include <array>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Room of a ContactPlaneSet (planes).
inline constexpr int kMaxContactPlanes = 256;

/// One constraint of the intermediate model: the half-space below a plane, acting on one
/// sphere of the god-object. With c the sphere's centre (world), r its radius, the plane's
/// point moving as p(τ) = point + velocity·τ (τ: time since the scene sample), the depth is
///   d = n · (p(τ) − c) + r,
/// and for d > 0 the penalty law of contact_force.hpp acts on the sphere's deepest point's
/// neighbourhood (the middle of the overlap, c − (r − d/2) n) with the relative velocity taken
/// against `velocity`.
struct ContactPlane {
  int sphere = -1;          ///< Sphere of the god-object model's body 0 (index from its first).
  Vec3 point = Vec3::Zero();     ///< A point of the plane at the sample (m, world).
  Vec3 normal = Vec3::UnitZ();   ///< Unit normal out of the other side, towards the god-object.
  Vec3 velocity = Vec3::Zero();  ///< Velocity of the other side's surface point (m/s, world).
  int material_pair = 0;    ///< Index into Model::material_pairs (the scene's table).
  int other_body = -1;      ///< The scene body on the other side; -1: a static obstacle.
};

/// The planes of one scene sample, [0, count) valid; `dropped` counts contacts beyond the room.
struct ContactPlaneSet {
  std::array<ContactPlane, kMaxContactPlanes> planes{};
  int count = 0;
  int dropped = 0;
};

/// The model the device loop steps: body `body` of `scene` alone (its mass, inertia, spheres,
/// material and coupling gains), with the scene's materials, integrator, coupling mode,
/// gravity, solver settings and device feedback, no obstacles, no joints, no nets, step
/// `device_dt` (s, > 0), Model::caller_contacts set (its contacts are the planes'). Returns ""
/// and fills `out`, or a message naming what refuses: a body out of range, a body in a joint,
/// a scene with nets, an integrator other than the linearly implicit or symplectic Euler (the
/// impulse hand-back needs the step's effective contact force, MultirateGodObject), a
/// device_dt ≤ 0 or not finite. Load time: allocates.
std::string make_god_object_model(const Model& scene, int body, double device_dt, Model& out);

/// A copy of `scene` whose body `body` has every sphere's radius grown by `margin` (m, ≥ 0): the
/// scene loop detects the god-object's contacts on it, so that a contact is found, and its plane
/// built, while the sphere is still up to `margin` away from the surface. Returns "" and fills
/// `out`, or a message (body out of range, margin < 0 or not finite). Load time: allocates.
std::string make_proximity_model(const Model& scene, int body, double margin, Model& out);

/// The planes of the god-object `body`'s contacts in `data` (after detect_contacts on the
/// proximity model `scene`, whose spheres of `body` are the god-object's grown by `margin`):
/// for a contact of sphere s (centre c, grown radius r + margin, depth d along n towards the
/// god-object) the plane through c − (r + margin − d) n with normal n — the other side's surface
/// point, whatever the margin — moving with the other body's velocity at that point (zero for
/// an obstacle). Contacts between two spheres of `body` and node contacts are not planes.
/// Fixed order (the contacts'); no allocation.
void build_contact_planes(const Model& scene, const Data& data, int body, ContactPlaneSet& out) noexcept;

/// Writes the contacts of `planes` at the god-object's pose in `data` (a Data of the god-object
/// model `model`), `elapsed` seconds after the planes' sample: every plane with d > 0 (see
/// ContactPlane) becomes a contact of body 0 against a static side moving with the plane's
/// velocity (Contact::surface_velocity), its Contact::sphere_b the plane's index in `planes`.
/// No allocation.
void write_plane_contacts(const Model& model, const ContactPlaneSet& planes, double elapsed,
                          Data& data) noexcept;

/// One device period of the god-object against the intermediate model: step() of `model` (a
/// god-object model) with write_plane_contacts() as its contact stage — coupling (Eq. 2), the
/// planes' penalty forces with their stiffness and damping implicit, integration, feedback
/// (Eq. 8), checks. Never allocates, throws or locks.
void step_god_object(const Model& model, const ContactPlaneSet& planes, double elapsed,
                     Data& data) noexcept;

/// Settings of a MultirateGodObject.
struct MultirateSettings {
  int ratio = 1;        ///< N = scene_dt / dt, ≥ 1: device periods per scene period.
  double margin = 0.0;  ///< δ (m, ≥ 0): the proximity model's growth of the god-object's spheres.
};

/// Counters of a MultirateGodObject.
struct MultirateCounters {
  std::int64_t device_steps = 0;  ///< Device periods stepped.
  std::int64_t scene_steps = 0;   ///< Scene periods stepped (samples taken).
  std::int64_t planes_dropped = 0;  ///< Contacts beyond kMaxContactPlanes, summed over samples.
  std::int64_t planes_max = 0;    ///< Most planes of one sample.
  std::int64_t scene_contacts = 0;  ///< God-object contacts with scene bodies in scene steps.
};

/// The two loops of a multirate god-object interleaved on one thread in a fixed order
/// (deterministic, bit-identical run to run; docs/multirate.md):
///   every N-th device period (the first included), the scene period:
///     1. the god-object's pose and twist, as the device loop left them, imposed on it in the
///        scene-loop model (CouplingMode::kDirect: an infinitely heavy body for the scene's
///        implicit solve);
///     2. what each scene body is owed (below) applied to it as the explicit wrench
///        (J, L)/scene_dt of this step (Data::applied_wrench, added to the scene-loop Data's
///        own, restored after the step);
///     3. step() of the scene-loop model (the proximity model at scene_dt = N·dt), whose
///        contact stage detects the contacts, builds the planes from them before any body
///        moves, then cuts the god-object's contacts back to its true spheres (depth − δ):
///        the scene bodies feel the god-object implicitly, as in the single-rate step;
///     4. the impulse those contacts gave each scene body (their effective force over the step,
///        below) is subtracted from what it is owed;
///   then every device period:
///     5. step_god_object() at dt, τ = (period mod N)·dt after the sample;
///     6. the impulse each plane on a scene body gave the god-object, negated, added to what
///        that body is owed (its moment about the body's centre of mass, extrapolated by its
///        velocity over τ, to the moment owed).
/// The effective force of a contact over a step is what the step applied: for the linearly
/// implicit Euler F₀ + K h v₁ + D Δv on the contact's relative velocity, for the symplectic
/// Euler F₀. Momentum: the scene bodies receive what the device loop gave the god-object, the
/// part the scene's own contact did not give them in the same scene period arriving one scene
/// period late; with the owed impulse counted, the total is conserved to the solves' tolerance.
class MultirateGodObject {
 public:
  /// Builds the god-object model (dt = scene.dt), the scene-loop model (make_proximity_model()
  /// with dt = N·scene.dt) and their Data (reset). Throws std::invalid_argument with the message
  /// of make_god_object_model() / make_proximity_model(), or for N < 1. Allocates (load time).
  MultirateGodObject(const Model& scene, int body, const MultirateSettings& settings);

  /// One device period (the order above). The device Data's target, target_twist (Eq. 2) are
  /// the caller's to set before. Never allocates, throws or locks.
  void step() noexcept;

  const Model& device_model() const noexcept { return device_model_; }
  const Model& scene_model() const noexcept { return scene_model_; }
  Data& device_data() noexcept { return device_; }       ///< The god-object (body 0).
  Data& scene_data() noexcept { return scene_; }         ///< The scene loop's bodies.
  const Data& device_data() const noexcept { return device_; }
  const Data& scene_data() const noexcept { return scene_; }
  const ContactPlaneSet& planes() const noexcept { return planes_; }
  int body() const noexcept { return body_; }            ///< The god-object in the scene.
  int ratio() const noexcept { return ratio_; }
  /// Impulse (N·s) and its moment (N·m·s, about the body's centre of mass) each scene body is
  /// owed: applied at the next scene step.
  const std::vector<Wrench>& pending_impulse() const noexcept { return pending_; }
  const MultirateCounters& counters() const noexcept { return counters_; }

 private:
  void scene_step() noexcept;
  void hand_back(const BodyState& before) noexcept;

  int body_;
  int ratio_;
  double margin_;
  Model device_model_;
  Model scene_model_;
  Data device_;
  Data scene_;
  ContactPlaneSet planes_;
  std::vector<Wrench> pending_;  // per scene body
  std::vector<Wrench> base_applied_;  // the scene-loop Data's own applied wrenches
  std::vector<BodyState> scene_before_;  // the scene bodies at the scene step's start
  std::int64_t period_ = 0;
  MultirateCounters counters_;
};

}  // namespace numen::core
