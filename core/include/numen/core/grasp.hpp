#pragma once
/// @file grasp.hpp
/// Grasping (docs/grasping.md): an instrument's two jaws close on a body and hold it until they
/// open again, as a laparoscopic grasper does (the paper's graspers, Fig. 3 and 7; FLS peg
/// transfer). The rule that starts and ends a grasp reads the jaws' opening angle with
/// hysteresis (sofa_env's grasp–lift–touch: close below 10°, open above 15°) and asks for
/// contact on both jaws; while held, the body hangs on zero-length damped springs between points
/// of each jaw's grip — the centre of its contacts with the body and four points at the grip
/// radius around it in the plane of the jaw's face — and the same material points of the body
/// (the attachment model chosen by measurement in docs/grasping.md), and the jaws' penalty
/// contacts with it are off (iMSTK's grasping does the same). The grip's points off the contact
/// centre resist the turn about the pinch axis that a real jaw's face resists by friction: with
/// the contact points alone, collinear across a thin body, the body swings on them. When the
/// springs' net pull on the body exceeds the grip's limit, the body slips out; when the jaws
/// open, it is released.
///
/// The springs are stepped as the penalty contacts are (integrator.cpp): their force at the
/// step's start on both bodies' explicit wrenches, and their Jacobian, W = (h c + h² k) I per
/// point, in the linearised step's matrix with the cross blocks of a body–body contact, so the
/// held body and the instrument are one implicit system (no stiffness limit from the step).
///
/// A suture thread between the jaws (no body touched) is held at its nodes by springs to both
/// jaws in the thread's own implicit step (GraspThreadNode; docs/thread.md "The thread in the
/// jaws"); tissue, when neither a body nor a thread is touched, at its nodes in the nets' step.

#include <array>
#include <cstdint>
#include <string>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Springs of one jaw's grip: the centre of its contacts with the held body and four points at
/// the grip radius around it.
inline constexpr int kGripPointsPerJaw = 5;
/// Spring points of one grasp (both jaws).
inline constexpr int kMaxGraspPoints = 2 * kGripPointsPerJaw;
/// Net nodes one grasp of tissue holds at most (the first the jaws touch, in contact order).
inline constexpr int kMaxGraspNodes = 16;
/// Node contacts' room for the grasp springs of held nodes: three per node (NodeContact::held).
inline constexpr int kGraspSpringsPerNode = 3;
/// Thread nodes one grasp holds at most (docs/thread.md "The thread in the jaws"): the nodes of
/// the segments both jaws touch, the nearest to the pinch's centre first. A thread across a jaw
/// gives 2–4 (a 3 mm jaw sphere over 1.5 mm segments of the default 3-0 thread); laid along a
/// jaw of 9 mm of spheres (the graspers' jaws), about 8: each node's spring is the grasper's, so
/// more would only stiffen the grip, not hold the thread better.
inline constexpr int kMaxGraspThreadNodes = 8;

/// An instrument's grasper: its two jaws and the rules and springs of its grasps. Model::grasps.
struct GraspModel {
  std::string name;  ///< For messages and reports.
  /// The jaws' bodies (distinct, not anchored, each with at least one sphere).
  std::array<int, 2> jaws{-1, -1};
  /// The revolute joint that turns each jaw (the joint whose child it is), or -1 for a jaw fixed
  /// to the instrument. Derived by finalize_model(). The opening is |q₀ − q₁| (rad) over the
  /// two joints' coordinates (joint_coordinate(); a fixed jaw counts 0): the instrument's jaw
  /// angle when each joint turns its jaw by ± half of it (the default scene's jaws).
  std::array<int, 2> jaw_joints{-1, -1};
  double close_angle = 0.17453292519943295;  ///< θ_c (rad): a grasp may start at opening < θ_c.
  double open_angle = 0.2617993877991494;    ///< θ_o (rad) > θ_c: the grasp ends at opening > θ_o.
  double stiffness = 2000.0;  ///< k (N/m) of each point's spring, > 0.
  double damping = 2.0;       ///< c (N·s/m) of each point's spring, ≥ 0.
  /// Radius r (m, > 0) of each jaw's grip: its springs at the centre of its contacts and at ±r
  /// along two axes of its face (the plane normal to the contacts' mean normal). About a jaw
  /// face's half width.
  double grip_radius = 0.0015;
  /// Largest net pull (N) of the springs on the held body (or tissue) before it slips out of the
  /// grip (the friction limit μ·squeeze of a real grip); +∞: never.
  double max_force = 5.0;
  /// Grasp a deformable net's tissue when the jaws touch no body: the nodes the jaws touch are
  /// tied to them (GraspState::nodes).
  bool tissue = true;
  /// Grasp a suture thread when the jaws touch no body: the nodes of the segments both jaws
  /// touch are tied to them (GraspState::thread_nodes; docs/thread.md "The thread in the jaws").
  bool thread = true;
};

/// A held node of tissue: tied to a point of the jaw that touched it by the grasper's spring.
struct GraspNode {
  int node = -1;                   ///< Global node index.
  int jaw = -1;                    ///< The jaw's body.
  Vec3 jaw_point = Vec3::Zero();   ///< The node's place at the grasp's start, in the jaw's frame (m).
  Vec3 force = Vec3::Zero();       ///< The spring's force on the node at the step's start (N, world).
};

/// A held node of a thread (GraspState::thread_nodes): tied to the point of each jaw where it
/// was at the grasp's start, by half the grasper's spring to each (k/2, c/2: together the
/// grasper's k and c towards the jaws' mean point, and a thread pinched between the jaws stays
/// between them as they move apart before the release). Stepped by the thread's own implicit
/// step (step_threads(): a point term, the jaws' points moving as given), the reaction on the
/// jaws' Data::body_wrench.
struct GraspThreadNode {
  int node = -1;  ///< The node's index in its thread (ThreadState::position), 0 … segments.
  /// The node's place at the grasp's start in the frame of each jaw (GraspModel::jaws[j], m from
  /// its COM).
  std::array<Vec3, 2> jaw_points{Vec3::Zero(), Vec3::Zero()};
  /// Both springs' force on the node over the last thread step (N, world; at the step's end, as
  /// the implicit step applied it): the jaws together got its opposite.
  Vec3 force = Vec3::Zero();
};

/// One spring of a grasp: a point of a jaw tied to a point of the held body.
struct GraspPoint {
  int jaw = -1;                       ///< The jaw's body.
  Vec3 jaw_point = Vec3::Zero();      ///< The point in the jaw's body frame (m, from its COM).
  Vec3 body_point = Vec3::Zero();     ///< The same point at the grasp's start in the held body's frame (m).
  /// The spring's force on the held body at the step's start (N, world): k (p_jaw − p_body) +
  /// c (v_jaw − v_body); the jaw gets its opposite.
  Vec3 force = Vec3::Zero();
};

/// What happened to a grasp in a step (GraspState::event).
enum class GraspEvent : std::uint8_t {
  kNone,     ///< Nothing changed.
  kGrasp,    ///< A grasp started this step.
  kRelease,  ///< The jaws opened past θ_o: the body was let go.
  kSlip,     ///< The springs' net pull exceeded max_force: the body slipped out.
};

/// Short English name of a GraspEvent (static string).
const char* to_string(GraspEvent event) noexcept;

/// One grasp event as logged (GraspState::log): when, what, and what was held.
struct GraspRecord {
  double time = 0.0;                      ///< Simulated time of the step (s, Data::time at its start).
  GraspEvent event = GraspEvent::kNone;   ///< kGrasp, kRelease or kSlip.
  int body = -1;                          ///< The body grasped or let go, or -1 for tissue or a thread.
  int net = -1;                           ///< The net whose tissue was grasped or let go, or -1.
  /// Held nodes (tissue or a thread), or the grip's springs (a body).
  int nodes = 0;
  double grip_force = 0.0;                ///< GraspState::grip_force then (N): the pull at a release or slip.
  int thread = -1;                        ///< The thread (Model::threads) grasped or let go, or -1.
};

/// Events one grasper logs (GraspState::log): the first ones of a run; the counts go on.
inline constexpr int kGraspLogSize = 64;

/// State of one grasper (Data::grasps, one per Model::grasps). Written by the grasp stage.
struct GraspState {
  int body = -1;          ///< The held body; -1: none.
  int num_points = 0;     ///< Springs in use, [0, num_points) of `points`.
  std::array<GraspPoint, kMaxGraspPoints> points{};
  int net = -1;           ///< The net whose tissue is held; -1: none.
  int num_nodes = 0;      ///< Held nodes, [0, num_nodes) of `nodes`.
  std::array<GraspNode, kMaxGraspNodes> nodes{};
  int thread = -1;           ///< The thread (Model::threads) held; -1: none.
  int num_thread_nodes = 0;  ///< Held thread nodes, [0, num_thread_nodes) of `thread_nodes`.
  std::array<GraspThreadNode, kMaxGraspThreadNodes> thread_nodes{};
  double opening = 0.0;   ///< The jaws' opening this step (rad).
  GraspEvent event = GraspEvent::kNone;  ///< This step's event.
  double started = 0.0;   ///< Simulated time (s) the current grasp started.
  /// A grasp may start (the jaws below θ_c on a body). False after a slip until the jaws open
  /// past θ_o: a body slipping out of closed jaws is not grasped again at once.
  bool armed = true;
  std::int64_t grasps = 0;    ///< Grasps started since reset.
  std::int64_t releases = 0;  ///< Grasps ended by the jaws opening.
  std::int64_t slips = 0;     ///< Grasps ended by slipping (the net pull past max_force).
  /// ‖Σ GraspPoint::force‖ at the last step's start, ‖Σ GraspNode::force‖ likewise, or
  /// ‖Σ GraspThreadNode::force‖ of the last thread step (N): the pull the grip transmits.
  double grip_force = 0.0;
  /// The first kGraspLogSize events since reset, [0, logged) (the run's summary lists them);
  /// grasps + releases + slips count them all.
  std::array<GraspRecord, kGraspLogSize> log{};
  int logged = 0;
  /// Something is held: a body, a net's tissue or a thread.
  bool holding() const noexcept { return body >= 0 || net >= 0 || thread >= 0; }
};

/// The grasp stage (step(), after the contacts): for each grasper, reads the opening; ends a
/// grasp whose jaws opened past θ_o, or whose springs' net pull at the last step exceeded
/// max_force (slip); starts a grasp when the opening is below θ_c, nothing is held, the grasper
/// is armed (GraspState::armed: no slip since the jaws last opened past θ_o), and both
/// jaws touch one dynamic body outside their articulation — kGripPointsPerJaw springs on each
/// jaw's grip — or, when they touch no body but both touch a thread's segments, ties the nodes of
/// those segments (up to kMaxGraspThreadNodes, the nearest to the pinch first) to both jaws
/// (GraspThreadNode; the thread's step applies the springs and turns off its contacts with the
/// jaws next to them) — or, when they touch neither but both touch one net's nodes
/// (GraspModel::tissue), ties each node they touch (up to kMaxGraspNodes) to the jaw that
/// touched it: a thread on tissue is taken before the tissue under it. Then removes this
/// step's contacts between the jaws and what they hold, and writes the held nodes' springs after
/// the node contacts (NodeContact::held, Data::num_node_grasp_springs). Sets kStageGrasp in
/// Data::stages_run. No allocation.
void update_grasps(const Model& model, Data& data) noexcept;

/// The held bodies' springs' forces at the step's start into Data::body_wrench (the held body
/// gets GraspPoint::force at its point, the jaw the opposite at its own) and GraspPoint::force.
/// Part of the body forces stage. (Held nodes' forces are set by the grasp stage and applied by
/// the nets' forces stage: NodeContact::held.) No allocation.
void apply_grasp_forces(const Model& model, Data& data) noexcept;

/// Finds each grasper's jaw joints (GraspModel::jaw_joints) and checks it; returns "" or a
/// message naming the grasper and the field. Called by finalize_model().
std::string finalize_grasps(Model& model);

}  // namespace numen::core
