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
/// loop's planes gave the god-object (MultirateGodObject), with tool switching and a
/// single-rate view of both loops for the run harness; the two loops on two threads are
/// platform::MultirateThreads. The god-object is the held body with its articulation; a net on
/// one of its bodies (paper §4.2) stays in the scene loop, its mass lumped onto its rigid
/// component in the device loop, its node contacts handed over as node planes
/// (ContactPlane::node); the linearly implicit and symplectic Euler schemes.

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Room of a ContactPlaneSet (planes).
inline constexpr int kMaxContactPlanes = 1024;

/// Room of a ContactPlaneSet (carriers: scene bodies touching the god-object at once).
inline constexpr int kMaxPlaneCarriers = 64;

/// The local linearised model, in the device loop between two scene samples, of a scene body
/// that carries planes (Otaduy & Lin 2006, §5: the intermediate model carries the other side's
/// dynamics, not only its surface). With q = (u, θ) its centre of mass's displacement and its
/// rotation vector since the sample and v = (v, ω) its twist (world):
///   (M + h D + h² K) v₁ = M v₀ + h (F₀ − K q₀) + J,   q₁ = q₀ + h v₁       (implicit Euler)
/// M = diag(m I, R I_body Rᵀ) its mass matrix at the sample; K, D the stiffness and damping of
/// its own contacts at the sample (with the scene, not the god-object), linearised about the
/// sample and their other side held still: Σ k Gᵀ n nᵀ G and Σ (c Gᵀ n nᵀ G + μ Gᵀ (I − n nᵀ) G)
/// with G = [I, −[r]×] (r: the contact point from the centre of mass, n: into the body); F₀ its
/// gravity plus those contacts' k d n at the sample (and their moments); J the impulse of the
/// device period's plane contacts on it. A light block the tool pushes gives way within the
/// scene period; a block resting on the board does not sink into it.
struct PlaneCarrier {
  int body = -1;                         ///< The scene body.
  /// −1, or a node carrier (detail::build_node_planes(); `body` its net's): an organ's node in
  /// contact with the god-object (its global index), a point mass (its own, unscaled; no rotation)
  /// on its tie and springs, K_n = k_tie I + Σ k ê êᵀ in `stiffness` (its neighbours as the sample
  /// left them, the other node carriers through CarrierLink), D_n = γ_tie I + Σ γ ê êᵀ in
  /// `node_damping`, and their elastic force at the sample plus its weight in F₀. step_god_object()
  /// steps it implicitly on its planes against the god-object as the device period left it
  /// (docs/organs.md, "Organs in multirate"). Its impulses are not handed back: the scene
  /// step meets the god-object itself.
  int node = -1;
  Mat3 node_damping = Mat3::Zero();      ///< A node carrier's D_n (N·s/m, world).
  Vec3 com = Vec3::Zero();               ///< Its centre of mass at the sample (m, world).
  Vec3 displacement = Vec3::Zero();      ///< u: of the centre of mass since the sample (m, world).
  Vec3 rotation = Vec3::Zero();          ///< θ: rotation vector since the sample (rad, world; small).
  Vec3 linear_velocity = Vec3::Zero();   ///< Now (m/s, world).
  Vec3 angular_velocity = Vec3::Zero();  ///< Now (rad/s, world).
  /// 1/m' (1/kg), m' = q m the body's mass scaled up (with all of M) by q ≥ 1 so that the
  /// explicit exchange with the god-object is stable: Σk · dt² / m' ≤ 1 over its planes'
  /// stiffnesses k (build_contact_planes()); q = 1 when that holds unscaled.
  double inverse_mass = 0.0;
  Mat6 mass = Mat6::Zero();              ///< M (kg, kg·m²), scaled as above.
  Mat6 stiffness = Mat6::Zero();         ///< K (N/m, N/rad, N·m/m, N·m/rad).
  Mat6 system_inverse = Mat6::Zero();    ///< (M + h D + h² K)⁻¹ for the device period h.
  Vec6 wrench = Vec6::Zero();            ///< F₀ (N; N·m about the centre of mass).
  Vec6 impulse = Vec6::Zero();           ///< J of the last device period (N·s; N·m·s).
  int supports = 0;                      ///< Its own contacts in K and D.
};

/// One constraint of the intermediate model: the half-space below a plane, acting on one
/// sphere of one body of the god-object. The plane moves rigidly with its carrier (none: a static
/// obstacle): at the carrier's displacement u and rotation θ since the sample,
///   p = point + u + θ × (point − com),   n' = normalised(n + θ × n),
/// and with c the sphere's centre (world), r its radius, the depth is d = n' · (p − c) + r; for
/// d > 0 the penalty law of contact_force.hpp acts at the middle of the overlap,
/// c − (r − d/2) n', with the relative velocity taken against the carrier's point velocity
/// (Contact::surface_velocity).
struct ContactPlane {
  int body = 0;             ///< The god-object model's body the plane acts on.
  int sphere = -1;          ///< Its sphere (index from the body's first).
  Vec3 point = Vec3::Zero();     ///< A point of the plane at the sample (m, world).
  Vec3 normal = Vec3::UnitZ();   ///< Unit normal out of the other side, towards the god-object.
  Vec3 velocity = Vec3::Zero();  ///< Velocity of that point at the sample (m/s, world).
  int material_pair = 0;    ///< Index into Model::material_pairs (the scene's table).
  int other_body = -1;      ///< The scene body on the other side; -1: a static obstacle.
  int obstacle = -1;        ///< The obstacle on the other side (Model::obstacles); -1: a body.
  int other_sphere = -1;    ///< The other side's sphere (Contact::sphere_b's meaning), or -1.
  /// Index into ContactPlaneSet::carriers; -1: static (an obstacle, a body in a joint or with
  /// an enabled body target, or beyond kMaxPlaneCarriers).
  int carrier = -1;
  /// A node plane (a net on the god-object, docs/multirate.md "Deformable god-objects"): the
  /// scene's global node index; −1 for a plane of a body's sphere (`sphere`). A node plane acts
  /// on a sphere of `radius` at `local_point` in body `body`'s frame — the node where the sample
  /// found it, carried rigidly by the net's rigid component between samples (the paper's hidden
  /// rigid god-object, §4.2) — through the node's compliance: with k the material pair's
  /// stiffness, Σk that of the node's planes in contact at the sample (in parallel) and
  /// k_n = nᵀ K_n n the node's stiffness towards its rigid component (its tie plus its springs
  /// to neighbours that move with the component, K_n = k_tie I + Σ k ê êᵀ at the sample), the
  /// contact renders k s, s = k_n / (Σk + k_n) (Contact::stiffness_scale), at the depth
  /// d + depth_offset, so that at the sample it gives its share w = d₀/Σd₀ of what the node's
  /// tie and springs carried, w k_n e₀ (e₀ the node's deflection along n), and releases where
  /// the node would leave the surface (docs/multirate.md, "Deformable god-objects").
  /// An organ's node (a net on an anchored body, docs/organs.md "Organs in multirate")
  /// touching a sphere of the god-object gives the same kind of plane the other way round:
  /// `node` that organ node, the sphere the god-object's (`local_point`, `radius`: its centre in
  /// its body's frame and its true radius), the normal from the node to it, the point the node
  /// sphere's surface, s from the organ node's compliance, and the offset so that at the sample
  /// the contact gives the larger of its law's elastic force k d₀ and what its nodes' ties and
  /// springs push along the normal (their elastic force F, w max(0, n · F)). A triangle contact
  /// of an organ (NodeContact::face ≥ 0) gives one such plane per node of the triangle, through
  /// the triangle's closest point, each rendering the node's share w of it (`share`).
  int node = -1;
  Vec3 local_point = Vec3::Zero();  ///< Node plane: the sphere's centre (m, body frame).
  double radius = 0.0;              ///< Node plane: the node's sphere radius (m).
  double stiffness_scale = 1.0;     ///< Node plane: w s (1 for a sphere plane).
  /// Node plane of a triangle contact: its node's barycentric share w (NodeContact::share); 1
  /// otherwise. The plane renders stiffness w k s and damping w c s².
  double share = 1.0;
  /// Node plane: w k_n e₀ / (k s) − d₀ (m; an organ's: its start above / (k s) − d₀), d₀ the
  /// node's true depth at the sample (0 for a node not in contact then).
  double depth_offset = 0.0;
  /// Written by step_god_object(): the impulse this plane gave the god-object over the last
  /// device period (N·s, world; its effective force times dt) and where it acted (m, world).
  Vec3 impulse = Vec3::Zero();
  Vec3 impulse_point = Vec3::Zero();
};

/// Room for the springs between two node carriers of one sample (CarrierLink).
inline constexpr int kMaxCarrierLinks = 4 * kMaxPlaneCarriers;

/// A spring of an organ between two of its node carriers (PlaneCarrier::node), along its
/// direction ê at the sample, counted in both carriers' K_n and D_n; carrier `a` meets
/// k ê êᵀ u_b + γ ê êᵀ v_b of `b`'s displacement and velocity (and `b` the same of `a`'s), taken
/// at the device period's start (detail::build_node_planes(), step_god_object()).
struct CarrierLink {
  int a = -1;                     ///< A carrier's index in ContactPlaneSet::carriers.
  int b = -1;                     ///< The other's.
  Mat3 stiffness = Mat3::Zero();  ///< k ê êᵀ (N/m).
  Mat3 damping = Mat3::Zero();    ///< γ ê êᵀ (N·s/m).
};

/// The planes of one scene sample, [0, count) valid, their carriers, [0, carrier_count), and the
/// springs between node carriers, [0, link_count); `dropped` counts contacts beyond the room.
struct ContactPlaneSet {
  std::array<ContactPlane, kMaxContactPlanes> planes{};
  std::array<PlaneCarrier, kMaxPlaneCarriers> carriers{};
  std::array<CarrierLink, kMaxCarrierLinks> links{};
  int count = 0;
  int carrier_count = 0;
  int link_count = 0;
  int dropped = 0;
};

/// The god-object of held body `body` in `scene`: `body` and every body joined to it by joints
/// (its articulation, ArticulationTopology::body_tree; the default scene's sleeve, tube and
/// jaws), with, for a loop of several devices, the articulation of each body of `others` (the
/// bodies the other devices drive, MultirateSettings::other_devices: a composite god-object, each
/// instrument its own articulation), in index order — the god-object model's bodies in the same
/// order. Empty for a body out of range; a body of `others` out of range is skipped. Load time:
/// allocates.
std::vector<int> god_object_bodies(const Model& scene, int body, std::span<const int> others = {});

/// The model the device loop steps: the god-object of `body` (god_object_bodies(): the held
/// body and its articulation, with their masses, inertias, spheres, materials, coupling gains,
/// and the joints among them and to the world, prescribed ones included), with the scene's
/// materials, integrator, coupling mode, gravity, Baumgarte and solver settings and device
/// feedback, no obstacles, no other body, no nets, step `device_dt` (s, > 0), the device
/// holding the held body, Model::caller_contacts set (its contacts are the planes'). A net whose rigid
/// component is a body of the god-object is lumped onto it: the body's mass and inertia gain the
/// nodes' (at their rest positions); the net itself stays in the scene loop. Returns "" and
/// fills `out`, or a message naming what refuses: a body out of range, a net on the god-object
/// whose centre of mass is more than 0.1 mm from its component's, an integrator other than the
/// linearly implicit or symplectic Euler (the impulse hand-back needs the step's effective
/// contact force, MultirateGodObject), a device_dt ≤ 0 or not finite, a body of the god-object
/// with a mesh (BodyModel::mesh: the planes stand for its spheres only; the tool's spheres against
/// another body's mesh are planes like any contact). With `others` (several devices,
/// god_object_bodies()), the model holds every device's articulation, each body driven as in the
/// scene (the held body by the target, the others by their body targets, Eq. 6; each body's
/// Eq. 8 gains its device's, Model::extra_feedback), and the bodies of two articulations collide
/// with each other in the device step (step_god_object(): instrument clashes at the device
/// rate); refused: a body of `others` out of range. Load time: allocates.
std::string make_god_object_model(const Model& scene, int body, double device_dt, Model& out,
                                  std::span<const int> others = {});

/// A copy of `scene` in which every sphere of the god-object of `body` (god_object_bodies()),
/// and every node sphere of a net on it, has its radius grown by `margin` (m, ≥ 0): the scene loop detects the god-object's contacts
/// on it, so that a contact is found, and its plane built, while the sphere is still up to
/// `margin` away from the surface. Returns "" and fills `out`, or a message (body out of range,
/// margin < 0 or not finite). `others`: the other devices' bodies (god_object_bodies()), whose
/// articulations' spheres are grown too. Load time: allocates.
std::string make_proximity_model(const Model& scene, int body, double margin, Model& out,
                                 std::span<const int> others = {});

/// The planes of the god-object's contacts in `data` (after detect_contacts on the proximity
/// model `scene`, whose god-object spheres are grown by `margin`); `device_body[b]` is scene
/// body b's index in the god-object model, −1 for a body not in it (size: the scene's bodies).
/// For a contact of a god-object sphere s (centre c, grown radius r + margin, depth d along n
/// towards the god-object) with anything not in the god-object, the plane through
/// c − (r + margin − d) n with normal n — the other side's surface point, whatever the
/// margin — carried by the other body (a PlaneCarrier per body, its model built from its state
/// in `data`, its mass and inertia in `scene` and its other contacts in `data`, for the device
/// period `device_dt`; static for a body in a joint or with an enabled body target, and for an
/// obstacle). Node contacts are not handled here: the scene loop's contact stage makes their
/// node planes (ContactPlane::node) after these. Fixed order (the contacts'); no allocation.
void build_contact_planes(const Model& scene, const Data& data, std::span<const int> device_body,
                          double device_dt, ContactPlaneSet& out) noexcept;

/// Writes the contacts of `planes` at the god-object's pose in `data` (a Data of the god-object
/// model `model`), each plane moved by its carrier: every plane with d > 0 (see ContactPlane;
/// a node plane with d + depth_offset > 0, its Contact::stiffness_scale s and damping_scale s²)
/// becomes a contact of its body against a static side moving with the carrier's point velocity
/// (Contact::surface_velocity), its Contact::sphere_b the plane's index in `planes`. A model of
/// several articulations (a composite god-object, make_god_object_model() with other devices)
/// first gets the sphere contacts between bodies of different articulations (detect_contacts():
/// the god-object model has no obstacle, net or mesh), body_b ≥ 0, then the planes' (body_b −1).
/// No allocation.
void write_plane_contacts(const Model& model, const ContactPlaneSet& planes, Data& data) noexcept;

/// The elastic energy (J) the contact law stores in the planes of `planes` at the god-object's
/// pose in `data` (a Data of the god-object model `model`), each plane moved by its carrier and
/// at the depth write_plane_contacts() gives it (a node plane's with its depth_offset, stiffness
/// k s): Σ over the planes of s · contact_elastic_energy(d) (contact_force.hpp; s = 1 for a
/// sphere's plane), the law's own k, before the time-constant floor. MultirateGodObject measures
/// with it what each new set of planes adds (MultirateCounters::reset_energy). No allocation.
double plane_elastic_energy(const Model& model, const ContactPlaneSet& planes,
                            const Data& data) noexcept;

/// One device period of the god-object against the intermediate model: step() of `model` (a
/// god-object model) with write_plane_contacts() as its contact stage — coupling (Eq. 2), the
/// planes' penalty forces with their stiffness and damping implicit, integration, feedback
/// (Eq. 8), checks; then each plane's impulse on the god-object over the period (its effective
/// force, MultirateGodObject) into ContactPlane::impulse, its opposite summed into the plane's
/// carrier's J, and every carrier stepped by dt (PlaneCarrier). A node carrier
/// (PlaneCarrier::node) is stepped instead by linearly implicit Euler with its tie and springs,
/// its links to the other node carriers at the period's start (CarrierLink), its J (the
/// god-object's step took its planes as moving at v₀) and, beyond v₀, its planes' stiffness K and
/// damping C (Σ over its active planes of the contact terms' k n nᵀ and c n nᵀ + μ (I − n nᵀ)):
///   (m + h (D_n + C) + h² (K_n + K)) v₁ = m v₀ + h (F₀ − K_n u₀ + Σ links) + J + h (C + h K) v₀.
/// A rolled-back step (non-finite) gives no impulse; the carriers still step. Never allocates,
/// throws or locks.
void step_god_object(const Model& model, ContactPlaneSet& planes, Data& data) noexcept;

/// Settings of a MultirateGodObject.
struct MultirateSettings {
  int ratio = 1;        ///< N = scene_dt / dt, ≥ 1: device periods per scene period.
  double margin = 0.0;  ///< δ (m, ≥ 0): the proximity model's growth of the god-object's spheres.
  /// Other bodies the device may hold later (tool switching, select()): their god-object and
  /// proximity models are built at construction. Duplicates and the first body are ignored.
  std::vector<int> tools;
  /// Longest step (s, > 0; infinity: no sub-steps) of a scene step where an organ's surface has
  /// folded: a scene step that starts with a triangle of an organ in contact turned more than
  /// 90° from its rest normal (detail::organ_surface_folded()) is taken in ⌈scene_dt /
  /// fold_step⌉ sub-steps, the god-object imposed along its twist (docs/organs.md, "Organs in
  /// multirate": the organ's coarse step folds its surface over the tool).
  double fold_step = 5e-4;
  /// Several devices in one loop (issue 54): a body each of the other devices (1 .. N−1) drives.
  /// Their articulations join the held body's in every god-object (god_object_bodies(): a
  /// composite god-object), so that one device step advances every instrument, each by its own
  /// target (Eq. 6) and with its own Eq. 8 feedback (Data::feedback_group), and their mutual
  /// contacts are the device step's (write_plane_contacts()). Empty: one device.
  std::vector<int> other_devices{};
};

/// Counters of a MultirateGodObject. The device loop writes device_steps, stale_models,
/// switches and reset_energy(_max), the scene loop the others.
struct MultirateCounters {
  std::int64_t device_steps = 0;  ///< Device periods stepped.
  std::int64_t scene_steps = 0;   ///< Scene periods stepped (samples taken).
  std::int64_t planes_dropped = 0;  ///< Contacts beyond kMaxContactPlanes, summed over samples.
  std::int64_t planes_max = 0;    ///< Most planes of one sample.
  std::int64_t scene_contacts = 0;  ///< God-object contacts with scene bodies in scene steps.
  std::int64_t switches = 0;      ///< select() calls that changed the god-object.
  /// Device periods stepped on a model older than one scene period: no new model for the held
  /// body in the last N periods (a late scene step, or the first ones after a switch while the
  /// scene loop has not sampled the new body). 0 when both loops share a thread.
  std::int64_t stale_models = 0;
  /// Energy the new planes added at the samples (J): at each new model of the held body, the
  /// planes' elastic energy at the god-object's pose then (plane_elastic_energy()) less that of
  /// the planes they replace, summed where it is positive. A plane set replaced at the sample
  /// is the device loop's one non-passive act (Colgate & Brown 1994): planes that start deeper,
  /// or stiffer, than those they replace hand the god-object energy that no motion of its own
  /// paid, which a scene body moving into the god-object, or an organ pushing it, may account
  /// for, and an impedance wrongly reset may not (docs/multirate.md, "The energy of a new
  /// model"; the observer, Hannaford & Ryu 2002, applied to the model update).
  double reset_energy = 0.0;
  double reset_energy_max = 0.0;  ///< The largest one sample added (J).
  /// Scene steps taken in sub-steps because an organ's surface had folded
  /// (MultirateSettings::fold_step).
  std::int64_t folded_scene_steps = 0;
};

/// What the device loop hands the scene loop (MultirateGodObject::write_report()): the
/// god-object's state, and the impulses its planes gave the scene bodies as running totals, so
/// that a report the scene loop never read loses nothing.
struct MultirateDeviceReport {
  std::int64_t period = 0;   ///< Device periods stepped when written.
  int body = -1;             ///< The held body (scene body index; −1: none held).
  /// The states of the god-object's bodies (god_object_bodies() of `body`, in that order;
  /// world); room for the largest god-object.
  std::vector<BodyState> states;
  /// Per scene body: Σ over all device periods of the impulse the planes gave it (N·s) and its
  /// moment about its centre of mass as the device loop moved it (N·m·s).
  std::vector<Wrench> impulse_total;
  std::int64_t switches = 0;  ///< select() calls that changed the god-object so far.
  int released_body = -1;     ///< The held body the last switch released (−1: none).
  std::vector<BodyState> released_states;  ///< Its god-object's bodies' states at the switch.
};

/// The scene loop's state in a MultirateSceneModel: what the single-rate view needs
/// (MultirateGodObject::view()), copied so that the device loop never reads the scene loop's
/// Data.
struct MultirateSceneSnapshot {
  std::vector<BodyState> bodies;           ///< Every scene body at the scene step's end.
  std::vector<JointState> joints;          ///< Every joint.
  std::array<Contact, kMaxContacts> contacts{};  ///< [0, num_contacts): not on the god-object.
  int num_contacts = 0;
  int contacts_dropped = 0;
  int contacts_clamped = 0;
  std::int64_t contact_overflow_steps = 0;
  std::int64_t contact_clamped_steps = 0;
  std::int64_t net_crossed_steps = 0;  ///< Data::net_crossed_steps.
  std::int64_t crossed_contact_steps = 0;  ///< Data::crossed_contact_steps.
  std::int64_t pass_throughs = 0;          ///< Data::pass_throughs.
  std::int64_t nonfinite_steps = 0;
  std::uint32_t status = 0;
  std::uint32_t stages_run = 0;
  int solver_iterations = 0;
  double solver_residual = 0.0;
  double max_joint_drift = 0.0;
  double max_joint_angle_drift = 0.0;
  /// The nets (whole: a god-object's net is the scene loop's), sized like the scene's Data.
  std::vector<NodeState> nodes;
  std::vector<NodeContact> node_contacts;  ///< [0, num_node_contacts) valid.
  int num_node_contacts = 0;
  std::vector<NetOutput> nets;
};

/// What the scene loop hands the device loop (MultirateGodObject::scene_step()): the
/// intermediate model for the god-object it sampled and the snapshot of the scene (where a
/// switch starts the new god-object).
struct MultirateSceneModel {
  ContactPlaneSet planes;
  int body = -1;                     ///< The god-object the planes are for (−1: none).
  std::int64_t sample_period = -1;   ///< MultirateDeviceReport::period of the sample.
  /// The scene at the scene step's end (where a switch starts the new god-object).
  MultirateSceneSnapshot scene;
};

/// A multirate god-object: the device loop steps the held body (the god-object) at dt against
/// the intermediate model; the scene loop steps everything else at scene_dt = N·dt and makes
/// the model (docs/multirate.md). The two loops exchange a MultirateDeviceReport and a
/// MultirateSceneModel; step() interleaves them on one thread in a fixed order (deterministic,
/// bit-identical run to run), device_step() / scene_step() run them on two (the caller's
/// threads and triple buffers: platform::MultirateThreads). One scene period:
///   1. the god-object's poses and twists from the report imposed on its bodies in the
///      scene-loop model (CouplingMode::kDirect: infinitely heavy bodies for the scene's
///      implicit solve; the held body by the target, the others by their body targets; the
///      scene-loop model has not the articulation's joints);
///   2. what each scene body is owed (below) applied to it as the explicit wrench
///      (J, L)/scene_dt of this step (Data::applied_wrench, added to the scene-loop Data's
///      own, restored after the step);
///   3. step() of the scene-loop model (the proximity model at scene_dt = N·dt), whose
///      contact stage detects the contacts, builds the planes from them before any body
///      moves, then cuts the god-object's contacts back to its true spheres (depth − δ):
///      the scene bodies feel the god-object implicitly, as in the single-rate step;
///   4. the impulse those contacts gave each scene body (their effective force over the step,
///      below) is subtracted from what it is owed; the report's new impulses are added.
/// One device period:
///   5. a new model for the held body, if one came, replaces the planes (their carriers
///      restart from the sample);
///   6. step_god_object() at dt;
///   7. the impulse each plane on a scene body gave the god-object, negated, added to that
///      body's running total (its moment about the carrier's centre of mass).
/// The effective force of a contact over a step is what the step applied: for the linearly
/// implicit Euler F₀ + K h v₁ + D Δv on the contact's relative velocity, for the symplectic
/// Euler F₀. Momentum: the scene bodies receive what the device loop gave the god-object, the
/// part the scene's own contact did not give them in the same scene period arriving one scene
/// period late; with the owed impulse counted (owed_impulse()), the total is conserved to the
/// solves' tolerance.
///
/// Tool switching (select(), device loop): the device holds one body at a time, or none. Each
/// body it may hold has its own god-object model, device Data and proximity model, built at
/// construction; with none held the scene loop steps the scene alone at scene_dt and the device
/// loop steps nothing. A switch starts the new god-object from its state in the last model and
/// hands the released one's state to the scene loop in the next report; on one thread the next
/// step() starts with a scene period.
///
/// Threads: the device-loop members (device_step, write_report, select, view, device_data,
/// planes) and the scene-loop members (scene_step, scene_data) touch disjoint state; each set
/// from one thread at a time. step() is both.
class MultirateGodObject {
 public:
  /// Builds, for `body` (−1: none held at the start) and each of settings.tools, the god-object
  /// model (dt = scene.dt), its Data, the scene-loop model (make_proximity_model() with
  /// dt = N·scene.dt, the articulation imposed: CouplingMode::kDirect, its joints removed) and
  /// its Data; and the scene-loop model and Data without a god-object (all reset from `scene`). Throws std::invalid_argument with the
  /// message of make_god_object_model() / make_proximity_model(), for N < 1, a margin < 0, no
  /// body at all (`body` −1 and no tools), `body` −1 with other devices (settings.other_devices:
  /// the first device holds a body from the start), or a net on a body in none of their god-objects
  /// and not anchored (the device loop feels a net only through its god-object's node planes,
  /// or an organ's through planes on the god-object's spheres). Allocates (load time).
  MultirateGodObject(const Model& scene, int body, const MultirateSettings& settings);

  /// One device period on one thread: every N-th (the first included, and the first after a
  /// switch) runs the scene period first with this object's own report and model. The device
  /// Data's target, target_twist (Eq. 2) are the caller's to set before. Never allocates,
  /// throws or locks.
  void step() noexcept;

  /// Device loop: the device Data's targets from `scene_data`, a Data of the scene (the run's,
  /// which the control loop fills): the held body's target and target twist (Eq. 2), the
  /// measured device wrench (Data::device_wrench, CouplingMode::kAdmittance), and the body
  /// targets (Eq. 6) and prescribed joint values of the god-object's other bodies and joints.
  /// Never allocates.
  void take_targets(const Data& scene_data) noexcept;
  /// The god-object's bodies (scene indices, god-object model order; empty: none held).
  std::span<const int> god_object() const noexcept;

  /// Device loop: one device period (5–7 above) with `fresh`, the scene loop's newest model if
  /// one came since the last call (nullptr: none). Never allocates, throws, locks or blocks.
  void device_step(const MultirateSceneModel* fresh) noexcept;
  /// Device loop: the report of the device loop's state now. `out` from make_report(). Never
  /// allocates.
  void write_report(MultirateDeviceReport& out) const noexcept;
  /// Scene loop: one scene period (1–4 above) from the device loop's newest report `in`; the
  /// new model into `out` (from make_scene_model()). Never allocates, throws or locks.
  void scene_step(const MultirateDeviceReport& in, MultirateSceneModel& out) noexcept;
  /// A report and a model sized for this object (load time: allocates), holding the initial
  /// state.
  MultirateDeviceReport make_report() const;
  MultirateSceneModel make_scene_model() const;

  /// Device loop: makes `body` the god-object from the next period on (−1: none). The released
  /// body continues in the scene loop from the god-object's pose and twist; the new one starts
  /// from its state in the last model. Returns false, changing nothing, for a body that was not
  /// one of the constructor's, and for −1 with other devices (MultirateSettings::other_devices:
  /// their instruments ride in every god-object, and with none held the scene loop would step
  /// them without their targets). Never allocates.
  bool select(int body) noexcept;

  /// Device loop: what a control loop reads of the device period, into `out` (a Data of the
  /// scene): the god-object's bodies' states and Eq. 8 feedback wrenches (Data::body_feedback,
  /// which platform::ControlLoop carries to the links, Eq. 9), its coupling, device and feedback
  /// wrenches. Part of view(); the real-time step writes only this. Never allocates.
  void write_feedback(Data& out) const noexcept;

  /// Device loop: the single-rate view of both loops, in `out`, a Data of the `scene` the object
  /// was built from (same bodies, joints): every scene body's state from the last model's
  /// snapshot with the god-object's bodies' from the device loop; its coupling, device and
  /// feedback wrenches (body_feedback of the god-object's bodies, zero for the others); the
  /// snapshot's contacts
  /// followed by the device loop's contacts against the planes (body_a the god-object, its
  /// spheres' scene indices, body_b, obstacle and sphere_b the plane's other side); the depth
  /// and counters of both (status and stages_run: the device step's, or'ed with the scene
  /// step's in the period that took its model, each loop's report its own model's
  /// Model::stage_plan; the *_steps counters summed); the joint states (the articulation's
  /// from the device loop, the others from the snapshot) and the larger drift; time and
  /// step_count of the device periods. Leaves the caller's fields (held_body, targets,
  /// applied wrenches) alone. Never allocates.
  void view(Data& out) const noexcept;

  const Model& device_model() const noexcept { return slot().device_model; }
  /// The scene-loop model of the god-object the scene loop last sampled.
  const Model& scene_model() const noexcept {
    return scene_slot_ >= 0 ? slots_[static_cast<std::size_t>(scene_slot_)].scene_model
                            : free_scene_model_;
  }
  Data& device_data() noexcept { return slot().device; }  ///< The god-object (body 0).
  Data& scene_data() noexcept { return *scene_; }         ///< The scene loop's bodies.
  const Data& device_data() const noexcept { return slot().device; }
  const Data& scene_data() const noexcept { return *scene_; }
  const ContactPlaneSet& planes() const noexcept { return planes_; }
  int body() const noexcept { return body_; }  ///< The god-object in the scene (−1: none).
  int ratio() const noexcept { return ratio_; }
  /// One thread: the impulse (N·s) and its moment (N·m·s, about the body's centre of mass)
  /// scene body `b` is owed, to be applied at the next scene step.
  Wrench owed_impulse(int b) const noexcept;
  const MultirateCounters& counters() const noexcept { return counters_; }
  /// Device loop: the last device period took a new model (a scene-step boundary).
  bool took_model() const noexcept { return took_model_; }

 private:
  /// One body the device may hold: its god-object (bodies, joints), model and Data, its
  /// scene-loop model.
  struct Slot {
    int body = -1;
    std::vector<int> bodies;       // scene indices, god-object model order
    std::vector<int> joints;       // scene joint indices, god-object model order
    std::vector<int> device_body;  // per scene body: its god-object model index, or −1
    Model device_model;
    Data device;
    Model scene_model;             // the proximity model, the god-object's joints removed
    Model fold_model;              // scene_model at a folded step's sub-step (fold_substeps_ > 1)
    Data scene;                    // the scene loop's Data while this god-object is held
    std::vector<int> scene_joints; // per scene_model joint: its scene joint index
  };
  Slot& slot() noexcept { return slots_[static_cast<std::size_t>(std::max(slot_, 0))]; }
  const Slot& slot() const noexcept { return slots_[static_cast<std::size_t>(std::max(slot_, 0))]; }
  int slot_of(int body) const noexcept;
  void hand_back() noexcept;
  /// Takes the model's snapshot, and its planes when they are the held body's: returns whether
  /// it took them.
  bool take_model(const MultirateSceneModel& model) noexcept;

  int ratio_;
  double margin_;
  bool other_devices_ = false;    // several devices: a body is held throughout (select())
  int fold_substeps_ = 1;         // sub-steps of a folded scene step: ⌈scene_dt / fold_step⌉
  std::vector<Slot> slots_;       // one per body the device may hold (at least one)
  Model free_scene_model_;        // the scene loop without a god-object
  Model free_fold_model_;         // ... at a folded step's sub-step (fold_substeps_ > 1)
  // Device loop.
  int body_;
  int slot_ = -1;                 // the held body's slot; -1: none held
  ContactPlaneSet planes_;
  std::vector<Wrench> impulse_total_;   // per scene body, running totals (report)
  MultirateSceneSnapshot snapshot_;     // from the last model
  std::int64_t period_ = 0;       // device periods since construction or the last switch
  std::int64_t periods_since_model_ = 0;
  std::int64_t switches_ = 0;
  int released_body_ = -1;
  std::vector<BodyState> released_states_;
  bool took_model_ = false;       // the last device period took a new model
  // Scene loop.
  Data free_scene_;               // the scene loop's Data while nothing is held
  std::vector<int> free_joints_;  // identity: the free model's joints are the scene's
  Data* scene_ = nullptr;         // the scene loop's current Data (its slot's, or free_scene_)
  int scene_slot_ = -1;
  std::int64_t seen_switches_ = 0;
  std::vector<Wrench> owed_;          // per scene body
  std::vector<Wrench> seen_total_;    // the report's impulse_total at the last scene step
  std::vector<Wrench> base_applied_;  // the scene-loop Data's own applied wrenches
  // Scene loop, nets on the god-object: scratch of the node planes (detail::NodePlaneScratch).
  std::vector<int> node_slot_;
  std::vector<int> slot_node_;
  std::vector<Mat3> node_stiffness_;
  std::vector<int> plane_slot_;
  std::vector<double> planes_stiffness_;
  std::vector<double> planes_depth_;
  std::vector<Vec3> node_force_;
  std::vector<std::int32_t> plane_springs_;
  // One thread (step()).
  MultirateDeviceReport report_;
  MultirateSceneModel model_;
  MultirateCounters counters_;
};

}  // namespace numen::core
