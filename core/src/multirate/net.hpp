#pragma once
/// @file multirate/net.hpp
/// The nets of a multirate god-object (docs/multirate.md, "Deformable god-objects"): the net
/// is the scene loop's; the device loop steps its rigid component (the paper's hidden rigid
/// god-object, §4.2) with the net's mass lumped onto it, against node planes — one per node
/// contact the scene loop found, rendered through the node's compliance (ContactPlane::node).
/// Private to numen::core (core/src/multirate/).

#include <algorithm>
#include <span>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/multirate/planes.hpp"
#include "model/node_contact_copy.hpp"

namespace numen::core::detail {

/// Scratch of build_node_planes(), sized at load time: `slot_of_node` one entry per scene node,
/// all −1 between calls; `slot_node`, `stiffness` and `plane_slot` kMaxContactPlanes entries;
/// `springs` Model::node_springs.size() entries.
struct NodePlaneScratch {
  std::span<int> slot_of_node;  ///< Per scene node: its slot (a node with planes), or −1.
  std::span<int> slot_node;     ///< Per slot: its node.
  std::span<Mat3> stiffness;    ///< Per slot: K_n, the node's stiffness towards its component (N/m).
  std::span<int> plane_slot;    ///< Per plane of the set: its node's slot, or −1.
  std::span<double> planes_stiffness;  ///< Per slot: Σ k over the node's planes in contact (N/m).
  std::span<double> planes_depth;      ///< Per slot: Σ d₀ over its planes in contact (m).
  std::span<Vec3> force;  ///< Per slot of an organ's node: its tie's and springs' elastic force (N,
                          ///< world); 0 otherwise.
  /// The springs at the nodes with planes (indices into Model::net_springs, ascending, each
  /// once): gathered from Model::node_springs, so that the springs' passes touch a few nodes'
  /// springs, not every spring of the scene.
  std::span<std::int32_t> springs;
};

/// True when scene body `b` is a body of the god-object (`device_body`: per scene body, its
/// god-object model index or −1).
inline bool in_god_object(std::span<const int> device_body, int b) noexcept {
  return b >= 0 && b < static_cast<int>(device_body.size()) && device_body[static_cast<std::size_t>(b)] >= 0;
}

/// True when the rigid component of scene net `net` is a body of the god-object.
bool net_on_god_object(const Model& scene, std::span<const int> device_body, int net) noexcept;

/// Lumps every net of `scene` whose rigid component is a body of the god-object onto that body
/// of the god-object model `out` (`device_body`: per scene body, its index in `out`, or −1):
/// the body's mass += Σ m_i, its body-frame inertia += Σ m_i (|r_i|² I − r_i r_iᵀ) over the
/// nodes' rest positions r_i (the net moves with its component at the device rate; its
/// deformation is the scene loop's). Returns "" or a message naming a net whose centre of mass
/// is more than 0.1 mm from its component's (the lumped body keeps the component's centre of
/// mass). Load time.
std::string lump_nets(const Model& scene, std::span<const int> device_body, Model& out);

/// True when a triangle of an organ (a net on an anchored body) in one of `data`'s node contacts
/// (NodeContact::face ≥ 0: the last scene step's) has turned more than 90° from its rest
/// normal, the rest triangle carried by its body's orientation: the organ's surface has folded
/// where something touches it (MultirateSettings::fold_step). O(node contacts). No allocation.
bool organ_surface_folded(const Model& scene, const Data& data) noexcept;

/// The nets' state — nodes, node contacts, per-net outputs — from `from` to `to` (each a Data
/// or a StepOutputs: the same fields), within the smaller sizes. No allocation.
template <typename From, typename To>
void copy_nets(const From& from, To& to) noexcept {
  std::copy_n(from.nodes.begin(), std::min(to.nodes.size(), from.nodes.size()), to.nodes.begin());
  detail::copy_node_contacts(from, to);
  std::copy_n(from.nets.begin(), std::min(to.nets.size(), from.nets.size()), to.nets.begin());
}

/// Grows by `margin` (m) the sphere radius of every node of a net on the god-object in `m` (the
/// proximity model). Load time.
void grow_god_object_nodes(std::span<const int> device_body, double margin, Model& m);

/// Appends to `out` a node plane (ContactPlane::node) for every node contact in `data` (detected
/// on the proximity model `scene`, node spheres grown by `margin`) of a net on the god-object
/// against anything but the god-object's bodies: point x − (r + δ − d) n (the other side's surface point), normal n, the
/// node's centre in its component's frame, its true radius r, s = k_n / (Σk + k_n) with
/// K_n = k_tie I + Σ over the node's springs k ê êᵀ (ê at the sample) and Σk over the node's
/// planes in contact at the sample (in parallel; a plane not in contact counted with them), and for a plane in contact (true depth d₀ = d − δ > 0) the depth
/// offset that makes it start from its share w = d₀ / Σd₀ of what the node's tie and springs
/// carried, k s (d₀ + offset) = w k_n e₀ (e₀ ≥ 0 the node's deflection from its rest position
/// along n) — a net on the god-object; an organ's contact as below. Static planes (no
/// carrier): the net renders its contacts on the scene's bodies in the scene loop. Likewise for
/// every node contact of an organ (a net on an anchored body) with a sphere of the god-object (grown by `margin`): a plane
/// on that sphere (its centre in its body's frame, its true radius), normal from the node to it,
/// point on the node sphere's surface, s from the organ node's K_n and Σk. A triangle contact
/// of an organ (NodeContact::face) gives a plane per node of its shares through the triangle's
/// closest point (ContactPlane::share w):
/// the contact in series with its nodes, s = 1 / (1 + Σ_m w_m Σk_m / k_n,m) (Σk_m counting w k
/// per plane; for a node sphere's plane this is k_n / (Σk + k_n)), each plane w_m k s, one
/// offset for the contact: an organ's contact starts from the larger of its law's elastic force
/// k d₀ and what its nodes' ties and springs push along the normal at the sample,
/// k s (d₀ + offset) = max(k d₀, Σ_m (w_m d₀ / Σ w d₀) max(0, n · F_m)) (F_m the elastic force of
/// node m's tie and springs; the node sphere's plane of an organ likewise, w = 1); an organ's
/// spring between two nodes with planes is left out of their K_n (they move together). Then
/// each organ node with planes (up to kMaxPlaneCarriers) gets a node carrier
/// (PlaneCarrier::node: its mass, K_n and D_n with the springs to the other carriers counted,
/// their CarrierLink, F₀ its tie's and springs' elastic force at the sample plus its weight) and
/// its planes move with it at w k from their true depth (stiffness_scale w, no offset): the
/// static start above is kept only for nodes beyond the carriers' room. Counts planes beyond the
/// room in out.dropped. `scene` finalized (its nodes' springs are read from Model::node_springs).
/// An organ given by its material (NetModel::contact_modulus > 0) gives no node planes: each
/// sphere's primary contact on it (NodeContact::primary, its first entry) gives one tissue plane
/// on that sphere (detail::tissue_plane(): the load patch's plane at the sample, `node` the
/// entry's node, no carrier), rendering the law linearised at the sample in series with the
/// patch's compliance c_ρ — stiffness k s = 1 / (1 / F'(d₀) + c_ρ) (the plane stays for the scene
/// period, so the device loop feels the net's share too), damping c s, from the offset that gives
/// F(d₀) at the sample; with no force at the sample (the look-ahead), the law's secant at 1 % of
/// the sphere's radius in series with c_ρ from the true depth (docs/tissue.md, "Multirate").
/// Uses NetScratch's load patch (hence `data` not const). No allocation.
void build_node_planes(const Model& scene, Data& data, std::span<const int> device_body,
                       double margin, NodePlaneScratch scratch, ContactPlaneSet& out) noexcept;

/// The look-ahead's reach (m): a node of a net on the god-object within this distance of a
/// surface, touching nothing else, keeps its contact (depth ≤ 0) as a look-ahead candidate
/// (NodeContact::engaged). An engaged contact that the node does not reach pulls it by k d₁
/// (d₁ its depth at the step's end, ≥ −0.1 mm: 2 N at 2·10⁴ N/m); a wider reach for every
/// node let the endobag's bag be pulled into its sphere-set organs (docs/multirate.md,
/// "Deformable god-objects"). Farther nodes are candidates by anchor_reaches().
inline constexpr double kLookAheadGap = 1e-4;

/// True when the anchor of the node of contact `c` (its rest position on its rigid component,
/// carried at the component's twist over `step` seconds) lies beyond the contact's tangent
/// plane (the other side's point carried at its body's velocity) at the step's end: the tie
/// pulls the node there within the step, however far it is from the surface at the start
/// (d − n · (a₁ − x − h v_b) > 0, d the contact's true depth, n its normal, x the node's
/// position, a₁ the anchor at the step's end). For a node of a net on the god-object, whose
/// contact `c` is in `data` (its component's state the sample's). No allocation.
bool anchor_reaches(const Model& scene, const Data& data, const NodeContact& c, double step) noexcept;

/// Cuts the node contacts of nets on the god-object in `data` back to the true node spheres
/// (depth − δ, the middle of the overlap δ/2 towards the node), marks the look-ahead
/// candidates when `step` > 0 (the scene step, s; NodeContact::engaged: every contact left
/// with depth > 0, and one with depth ≤ 0 of a node with no other contact, within
/// kLookAheadGap of the surface or whose anchor reaches it within the step, anchor_reaches();
/// the rest is dropped; with `step` = 0, no look-ahead, a contact left without depth is
/// dropped), drops those with
/// a body of the god-object (the scene-loop model has not the god-object's joints, so a net on
/// one of its bodies is no longer in the same articulation as the others, with which it never
/// collides in the scene: ArticulationTopology::body_tree);
/// cuts the contacts of the other nets with the god-object's grown spheres back the same way
/// (the middle δ/2 towards the god-object), keeping, when `step` > 0, an organ's triangle
/// contact within kLookAheadGap of the surface as a look-ahead candidate (NodeContact::engaged;
/// its node contacts and those left without depth are dropped); and re-measures every net's
/// NetOutput::max_penetration from the contacts kept (contacts beyond kMaxNodeContacts no
/// longer counted) and the crossed ones drop_back_face_contacts() counted
/// (NetOutput::crossed_depth), and data.max_penetration (`body_deepest`: the deepest body contact).
/// No allocation.
void cut_back_node_contacts(const Model& scene, Data& data, std::span<const int> device_body,
                            double margin, double body_deepest, double step) noexcept;

/// Drops from `data` every organ triangle contact (NodeContact::face ≥ 0, a net on an anchored
/// body) with a sphere of the god-object (grown by `margin` in the proximity model `scene`)
/// whose true depth d − δ is r or more: the sphere's centre on the triangle's inner side. The
/// grown sphere reaches triangles whose back faces it (across a fold, or the far wall of a dent
/// the tool pressed) up to r + δ behind it, which its true radius r does not (true depth ≥ 2 r);
/// and a sphere that got past a triangle's plane (the jaws in the shipped organ's folds) meets
/// it from behind within r (true depth r to 2 r). Taken,
/// the law pushes such a triangle around the sphere's far side: it hooks onto the tool, which
/// drags the organ along, and its nodes are thrown through the tool (docs/organs.md,
/// "Organs in multirate"). Those from r to 2 r deep (the true sphere overlapping the triangle
/// from behind: a sphere past the surface, or the surface folded over it) are counted, not
/// hidden: NetOutput::crossed_contacts and crossed_depth of their net (reset by every call;
/// cut_back_node_contacts() puts crossed_depth in max_penetration) and, once per call with one,
/// data.net_crossed_steps. An organ given by its material (NetModel::contact_modulus > 0) keeps
/// its contacts up to 2 r deep, uncounted: a tool sinks into tissue deeper than its radius, and
/// the law acts through the load patch's plane (docs/tissue.md, "Multirate"). Call before
/// build_node_planes(). Keeps the order of the rest. No allocation.
void drop_back_face_contacts(const Model& scene, Data& data, std::span<const int> device_body,
                             double margin) noexcept;

/// Drops the node contacts without depth from `data` (the look-ahead's candidates, once the
/// scene step is done: not contacts). No allocation.
void drop_look_ahead_contacts(Data& data) noexcept;

}  // namespace numen::core::detail
