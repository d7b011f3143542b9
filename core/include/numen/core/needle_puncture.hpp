#pragma once
/// @file needle_puncture.hpp
/// A needle through tissue (docs/suturing.md, "The needle through tissue"): the tip of a needle
/// (needle.hpp) punctures a deformable net's surface when its contact with the net pushes back
/// along the needle's tangent by the needle's puncture force and the tangent points into the
/// surface; from then on the surface's material point where it entered (a net triangle and its
/// barycentric weights) is tied to the closest point of the needle's arc — stiff sideways (normal
/// to the tangent), viscous along it (the friction of the tissue on the needle) — and the needle's
/// spheres inside make no penalty contact with that net. The tip coming out through the surface (a
/// swept test of its move in the step against the net's triangles) makes an exit point, tied the
/// same way. A tie whose point passes off the arc (past the tail, as the needle is pulled through;
/// or past the tip, as it is drawn back out) is let go: the thread takes over there.
///
/// The ties are springs on the triangle's nodes written as held node contacts (NodeContact::held,
/// as a grasp of tissue writes its springs; grasp.hpp): per tie and node, three along the arc's
/// tangent and two normals to it, each with the node's weight w of the tie's stiffness and damping
/// (the triangle contacts' lumping: a node's row carries w k of the tie's k), the force at the
/// step's start on the nodes by their weights and its opposite on the needle at its arc point. They
/// are in the implicit step of the nodes and bodies with the needle's cross blocks: the tie's
/// stiffness sets the hold, not the step's stability.

#include <array>
#include <cstdint>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Puncture points a needle holds at once: one pass, its entry and its exit.
inline constexpr int kMaxNeedlePunctures = 2;
/// Held node contacts one puncture point writes: three nodes, three axes.
inline constexpr int kNeedleTieSprings = 9;

/// One puncture point: a material point of a net's surface tied to the needle's arc. Written by
/// the needle stages (NeedleState::punctures). What the thread (docs/thread.md, "The thread")
/// reads: `position`, `tangent`, `friction`.
struct NeedlePuncture {
  int net = -1;                    ///< The punctured net (Model::nets).
  int face = -1;                   ///< Its triangle (index into Model::net_faces).
  Vec3 weights = Vec3::Zero();     ///< Barycentric weights on the triangle's nodes (sum 1).
  bool exit = false;               ///< Where the tip came out (else where it went in).
  double arc_parameter = 0.0;      ///< s (m from the tail) of the arc's closest point this step.
  Vec3 position = Vec3::Zero();    ///< The material point at the step's start (m, world).
  Vec3 tangent = Vec3::UnitZ();    ///< The arc's unit tangent at s (world, towards the tip).
  double friction = 0.0;           ///< Viscous friction along the tangent (N·s/m): NeedleModel::friction.
  /// The tie's force on the needle at the step's start (N, world; the nodes get its opposite).
  Vec3 force = Vec3::Zero();
  double deviation = 0.0;          ///< |material point − arc point| at the step's start (m).
};

/// What happened to a needle's passage in a step (NeedleState::event).
enum class PunctureEvent : std::uint8_t {
  kNone,      ///< Nothing changed.
  kPuncture,  ///< The tip went into a net's surface: an entry point.
  kExit,      ///< The tip came out through the surface: an exit point.
  kRelease,   ///< A puncture point passed off the arc and was let go.
};

/// A needle's passage through tissue (Data::needles, one per Model::needles).
struct NeedleState {
  std::array<NeedlePuncture, kMaxNeedlePunctures> punctures{};
  int num_punctures = 0;           ///< Points held, [0, num_punctures) of `punctures`.
  PunctureEvent event = PunctureEvent::kNone;  ///< This step's (the last of them if several).
  /// The tip's contacts with tissue this step: their force on the needle against its tangent,
  /// −F · t (N; > 0 when the tissue resists the tip going forward), as compute_net_forces() found
  /// them (the forces at the step's start).
  double tip_force = 0.0;
  /// tip_force in the step of the last puncture (N): the force the tissue carried there, at most
  /// NeedleModel::puncture_force (find_punctures() scales the tip's contacts down to it).
  double puncture_tip_force = 0.0;
  /// The tip's contacts' force along the needle in the step of the last puncture as they were
  /// found, before the tissue gave way at the threshold (N; ≥ puncture_tip_force): how far one
  /// step's contact onset carried it past the threshold.
  double puncture_contact_force = 0.0;
  double puncture_time = 0.0;      ///< Simulated time of the last puncture (s).
  double max_deviation = 0.0;      ///< Largest NeedlePuncture::deviation this step (m).
  /// Where the tip was last swept to (m, world): the next sweep's start. The tip at the last
  /// step's start (tie_needles()), or, with no passage, where stop_needle_tunnels() left it at
  /// that step's end (its segment already swept against the nets, which have not moved since).
  Vec3 tip_previous = Vec3::Zero();
  bool tip_previous_valid = false;
  std::int64_t punctures_made = 0; ///< Entries since reset.
  std::int64_t exits = 0;          ///< Exits since reset.
  std::int64_t releases = 0;       ///< Points let go since reset.
  /// Steps since reset in which the tip crossed a net's surface inwards without a puncture (the
  /// penalty contact did not hold it: it went through without the threshold): must stay 0.
  std::int64_t tunnels = 0;
  /// Steps since reset in which stop_needle_tunnels() held the tip back at a net's surface that
  /// the step's motion took it through without a puncture.
  std::int64_t tunnels_stopped = 0;
  /// The points let go past the tail this step, [0, num_tail_releases): where the needle has been
  /// pulled through, what a thread tied to its tail takes over as eyelets (thread.hpp,
  /// ThreadModel::needle). Written by tie_needles() each step.
  std::array<NeedlePuncture, kMaxNeedlePunctures> tail_releases{};
  int num_tail_releases = 0;
};

/// The needle's ties, before the forces (step(), after the grasp stage; kStageNeedles): for each
/// needle, sweeps its tip from its last place through the punctured net's triangles (an exit
/// point where it comes out going forward, or anyhow more than 4 r_w along the arc past the entry;
/// every point let go where it comes out going back within 4 r_w of the entry: drawn back out the
/// way it came; a tunnel counted where it goes in without a puncture), lets go the points past the
/// arc's ends, drops this step's node contacts of its spheres inside the net (those between the
/// entry's and the exit's arc parameters, ± 2 r_w), keeps the points let go past the tail in
/// NeedleState::tail_releases, and writes each point's springs after the node contacts and the
/// grasp springs (Data::num_node_needle_ties). No allocation.
void tie_needles(const Model& model, Data& data) noexcept;

/// The puncture test, after the forces (step(); kStageNeedles): for each needle with a puncture
/// force and no passage yet, the force of its tip's contacts with a net (its spheres within 2 r_w
/// of the tip) along its tangent; a puncture when it reaches NeedleModel::puncture_force and the
/// tangent is within NeedleModel::puncture_max_angle of the contacts' inward normal: the entry
/// point at its deepest triangle contact, tied from the next step. The tissue gives way at the
/// threshold within the puncture's step: where the step's contacts carry more (a contact's onset
/// of 0.01 mm at the tip adds a few tenths of a newton in one step), each of the tip's contacts is
/// scaled by F_p / F_tip — its force on the node and on the needle, and its stiffness, damping and
/// friction in the implicit step's Jacobian — so that the needle and the tissue meet F_p along the
/// tangent, no more (NeedleState::puncture_contact_force keeps what the contacts asked). No
/// allocation.
void find_punctures(const Model& model, Data& data) noexcept;

/// How far under the surface (in wire radii r_w) stop_needle_tunnels() leaves the tip sphere's
/// lowest point: its centre (1 − kTunnelStopDepth) r_w over the crossed triangle's plane.
inline constexpr double kTunnelStopDepth = 0.5;

/// Continuous collision of each needle's tip, after the integration (step(); kStageNeedles): a
/// needle not in a passage whose tip's centre went this step (NeedleState::tip_previous → its tip
/// now) through a net triangle against its outward normal — a step longer than the penalty
/// contacts could stop, as when the tip slips off a box's corner and the coupling spring throws
/// it 0.4 mm along its arc (docs/suturing.md, "The pad's edge") — is translated back along that
/// path to where its centre is (1 − kTunnelStopDepth) r_w over the earliest crossed triangle's
/// plane (or to its start, if that was lower), and its tip's velocity into the triangle is
/// removed from its body's linear velocity; counted in NeedleState::tunnels_stopped. A puncture is
/// the tip's only way in (the threshold read at the step's start, find_punctures()). Conservative
/// advancement of the tip alone (the swept centre against the triangles at the step's end; Mirtich
/// 1996, "Impulse-based dynamic simulation of rigid body systems", ch. 3). No allocation.
void stop_needle_tunnels(const Model& model, Data& data) noexcept;

}  // namespace numen::core
