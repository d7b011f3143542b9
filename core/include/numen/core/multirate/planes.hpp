#pragma once
/// @file planes.hpp
/// The planes and their carriers of a multirate god-object's intermediate contact model
/// (numen/core/multirate.hpp, docs/multirate.md): one local constraint per contact of the
/// god-object, carried by the other side's linearised dynamics (PlaneCarrier); built by the
/// scene loop (build_contact_planes), evaluated by the device loop at its own pose
/// (write_plane_contacts, plane_elastic_energy).

#include <array>
#include <span>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

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
  /// Its sphere (index from the body's first); for an organ's node plane the god-object's
  /// sphere the node touches (which `local_point` and `radius` stand for); −1 for a node plane of
  /// a net on the god-object.
  int sphere = -1;
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

/// Room for the puncture ties of one sample (PunctureTie): two points of each of four needles.
inline constexpr int kMaxPunctureTies = 8;

/// A needle's puncture point of the scene loop's tissue, as the device loop holds the needle on it
/// (docs/multirate-suturing.md, "A needle in the device loop"): the material point (the punctured
/// triangle's point at its barycentric weights) at the sample and its velocity, carried on at that
/// velocity between samples, and the needle's arc; each device period the needle's closest arc
/// point is held on the line through the material point along the arc's tangent there by a
/// SlidingTie of the needle's tie (NeedleModel::tie_stiffness, tie_damping across, friction
/// along: the single-rate tie, needle_puncture.hpp), stepped implicitly with the god-object; no
/// force where the point has passed off the arc (behind the tail, or more than 4 r_w past the
/// tip: the scene loop lets it go at its next sample). The tie's reaction on the tissue is the
/// scene loop's own tie, on its nodes against the imposed needle (as a node plane's contact is
/// the scene step's own).
struct PunctureTie {
  int needle = -1;                     ///< The needle (Model::needles of the scene).
  int body = -1;                       ///< Its body in the god-object model.
  Vec3 anchor = Vec3::Zero();          ///< The material point (m, world): at the sample, then carried.
  Vec3 velocity = Vec3::Zero();        ///< Its velocity at the sample (m/s, world).
  /// Written by the device loop: the tie's force on the needle at the last device period's
  /// start (N, world; SlidingTie::force), zero where the point was off the arc.
  Vec3 force = Vec3::Zero();
};

/// Room for the thread pulls of one sample (ThreadPull): one per body of the god-object.
inline constexpr int kMaxThreadPulls = 16;

/// A suture thread's pull on a body of the god-object, as the device loop applies it
/// (docs/multirate-suturing.md, "A thread in the scene loop"): the threads' reactions on the body
/// in the scene step (Data::thread_reactions: their ties' and contacts'), applied in each device
/// period until the next sample as an explicit wrench (the device Data's Data::applied_wrench):
/// lagged by up to one scene period, as a scene body's owed impulse is the other way.
struct ThreadPull {
  int body = -1;   ///< Its body in the god-object model.
  Wrench wrench;   ///< N, N·m about its centre of mass; world.
};

/// The planes of one scene sample, [0, count) valid, their carriers, [0, carrier_count), the
/// springs between node carriers, [0, link_count), the needles' puncture ties, [0, tie_count),
/// and the threads' pulls, [0, pull_count); `dropped` counts contacts beyond the room.
struct ContactPlaneSet {
  std::array<ContactPlane, kMaxContactPlanes> planes{};
  std::array<PlaneCarrier, kMaxPlaneCarriers> carriers{};
  std::array<CarrierLink, kMaxCarrierLinks> links{};
  std::array<PunctureTie, kMaxPunctureTies> ties{};
  std::array<ThreadPull, kMaxThreadPulls> pulls{};
  int count = 0;
  int carrier_count = 0;
  int link_count = 0;
  int tie_count = 0;
  int pull_count = 0;
  int dropped = 0;
};

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
/// the god-object model has no obstacle, net or mesh), body_b ≥ 0, then the planes' (body_b −1,
/// add_contact(): a plane beyond the contacts' room is dropped and counted, and
/// step_from_contacts() reports the overflow). The device loop's contact stage, between
/// step_to_contacts() and step_from_contacts() (step.hpp): sets kStageContacts of
/// Data::stages_run. No allocation.
void write_plane_contacts(const Model& model, const ContactPlaneSet& planes, Data& data) noexcept;

/// The elastic energy (J) the contact law stores in the planes of `planes` at the god-object's
/// pose in `data` (a Data of the god-object model `model`), each plane moved by its carrier and
/// at the depth write_plane_contacts() gives it (a node plane's with its depth_offset, stiffness
/// k s): Σ over the planes of s · contact_elastic_energy(d) (contact_force.hpp; s = 1 for a
/// sphere's plane), the law's own k, before the time-constant floor. MultirateGodObject measures
/// with it what each new set of planes adds (MultirateCounters::reset_energy). No allocation.
double plane_elastic_energy(const Model& model, const ContactPlaneSet& planes,
                            const Data& data) noexcept;

}  // namespace numen::core
