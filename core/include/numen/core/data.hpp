#pragma once
/// @file data.hpp
/// core::Data: all mutable state, inputs, outputs and scratch of a scene,
/// allocated once by make_data() from a finalized Model. Stage functions take
/// (const Model&, Data&) and never allocate. The stages' scratch is private to
/// numen::core: Data holds it behind an opaque, deep-copying pointer
/// (Data::scratch; its type, DataScratch, in core/src/scratch/data_scratch.hpp).

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "numen/core/capacity.hpp"
#include "numen/core/contact.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/needle_puncture.hpp"
#include "numen/core/net_state.hpp"
#include "numen/core/sliding_tie.hpp"
#include "numen/core/thread.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct DataScratch;  // core/src/scratch/data_scratch.hpp

/// Owner of a Data's stage scratch (DataScratch, private to numen::core): one heap
/// block, allocated by make_data(), with value semantics — a copy of a Data holds a
/// copy of its scratch (warm starts, sweep order and saved state included), so that it
/// steps bit for bit like the original; a move takes the block along. Constness is
/// deep: a const Data gives a const DataScratch. Null in a default-constructed or
/// moved-from Data, which make_data() (or assigning a made Data) must replace before
/// any stage runs on it.
class DataScratchPtr {
 public:
  DataScratchPtr() noexcept;  ///< Null: no scratch (a Data not made by make_data()).
  /// Owns `scratch` (make_data()).
  explicit DataScratchPtr(std::unique_ptr<DataScratch> scratch) noexcept;
  /// Deep copy (allocates; null stays null).
  DataScratchPtr(const DataScratchPtr& other);
  /// Deep copy into the block already held if any (its buffers keep their capacity, so
  /// assigning a Data of the same model does not allocate), else into a new one.
  DataScratchPtr& operator=(const DataScratchPtr& other);
  DataScratchPtr(DataScratchPtr&& other) noexcept;  ///< Takes the block; `other` becomes null.
  DataScratchPtr& operator=(DataScratchPtr&& other) noexcept;  ///< Same; frees the block held.
  ~DataScratchPtr();  ///< Frees the block.

  DataScratch* get() noexcept { return scratch_.get(); }  ///< The block, or nullptr.
  const DataScratch* get() const noexcept { return scratch_.get(); }
  DataScratch* operator->() noexcept { return scratch_.get(); }
  const DataScratch* operator->() const noexcept { return scratch_.get(); }
  DataScratch& operator*() noexcept { return *scratch_; }
  const DataScratch& operator*() const noexcept { return *scratch_; }
  explicit operator bool() const noexcept { return scratch_ != nullptr; }  ///< Holds a block.

 private:
  std::unique_ptr<DataScratch> scratch_;
};

/// State of a dynamic body: COM position and orientation (world), linear
/// velocity of the COM and angular velocity, both in world coordinates.
struct BodyState {
  Vec3 position = Vec3::Zero();            ///< m.
  Quat orientation = Quat::Identity();     ///< Unit, body → world.
  Vec3 linear_velocity = Vec3::Zero();     ///< m/s.
  Vec3 angular_velocity = Vec3::Zero();    ///< rad/s, world frame.
};

/// Target of one body's own coupling springs (paper Eq. 6): the pose and
/// twist of its counterpart on the device, world frame, at the body's COM.
/// Bodies without an enabled target are left to the simulation (partial control).
struct BodyTarget {
  Pose pose;             ///< Target pose of the body's COM frame (m; world).
  Twist twist;           ///< Target twist at the COM (m/s, rad/s; world).
  bool enabled = false;  ///< false: no spring on this body (left to the simulation).
};

/// Imposed coordinate of a prescribed joint (JointModel::prescribed): angle
/// (rad) and rate (rad/s) of a revolute, slide (m) and rate (m/s) of a prismatic.
struct JointPrescription {
  double value = 0.0;  ///< Imposed coordinate at the step's start (rad or m).
  double rate = 0.0;   ///< Its rate (rad/s or m/s); the step aims at value + dt·rate.
};

/// What the articulation solve did to one joint in the last step (observable
/// drift, Baumgarte terms and reaction; paper Eq. 4–5).
struct JointState {
  /// C at the step's end (m or rad per row); a prescribed row holds the lag
  /// behind value + dt·rate of Data::joint_prescribed.
  JointVector position_error = JointVector::Zero();
  /// Right-hand side c of the joint's rows in G Δu = c (m/s or rad/s): the
  /// Baumgarte-stabilised velocity change the rows ask for this step.
  JointVector baumgarte_rhs = JointVector::Zero();
  JointVector multiplier = JointVector::Zero();  ///< λ per row (N or N·m): force of the constraint.
  Wrench reaction;            ///< G_childᵀ λ: the joint's wrench on the child (N, N·m; world; at the child's COM).
  double coordinate = 0.0;    ///< joint_coordinate() at the step's end (rad or m).
};

/// Status bits of the last step (Data::status).
enum StepStatus : std::uint32_t {
  kStepOk = 0,
  kContactOverflow = 1u << 0,      ///< More contacts than kMaxContacts: the rest were dropped.
  kNonFinite = 1u << 1,            ///< A NaN/Inf appeared; the state was restored from the last step.
  kSolverNotConverged = 1u << 2,   ///< The implicit solve hit max_iterations above tolerance.
  /// The device target was not finite: coupling skipped this step, the feedback held at the
  /// last step's value (compute_feedback()), Data::invalid_target_steps counted.
  kInvalidTarget = 1u << 3,
};

/// All mutable state of a scene.
struct Data {
  double time = 0.0;               ///< Simulated time (s).
  std::int64_t step_count = 0;

  std::vector<BodyState> bodies;   ///< Size Model::num_bodies().
  std::vector<NodeState> nodes;    ///< Net nodes, size Model::num_nodes() (net_state.hpp).

  // ---- inputs (written by the caller before step) ----
  int held_body = -1;              ///< Body the device drives; -1: none (tool switching).
  /// Device target pose of the held body's COM frame (world) — not the instrument's tool frame
  /// (a trocar instrument's tip: sim::InstrumentTargets::held_body_target() converts). Its
  /// orientation: Quat::Identity() for none, never Quat(0, 0, 0, 1) (a half turn; types.hpp).
  Pose target;
  Twist target_twist;              ///< Device target twist (world).
  std::vector<Wrench> applied_wrench;  ///< Per body, world, at the COM (N, N·m): explicit external wrench.
  /// CouplingMode::kAdmittance only: the wrench the user applies to the device, as measured by
  /// its force/torque sensor, carried to the held body (world frame; N at, and N·m about,
  /// the held body's COM). Added to the held body as an explicit external wrench in both
  /// integrators (no spring, no Jacobian term). A non-finite value is ignored for the step
  /// (kInvalidTarget). Ignored in the other modes.
  Wrench device_wrench;
  /// Per body: its own device target (Eq. 6) besides the held body's
  /// `target`. An enabled entry of the held body itself is ignored.
  std::vector<BodyTarget> body_targets;
  /// Points of bodies held on moving lines of the world (sliding_tie.hpp), [0, num_sliding_ties):
  /// the caller's, before each step (the multirate device loop writes a held needle's puncture
  /// ties here); each one's force at the step's start is written back (SlidingTie::force).
  std::array<SlidingTie, kMaxSlidingTies> sliding_ties{};
  int num_sliding_ties = 0;
  /// Per body, ≥ 0: the device whose feedback the body's Eq. 8 wrench is (compute_feedback()):
  /// with a body held, the wrenches of one group's bodies are saturated as one composite (their
  /// Eq. 9 sum), each group on its own, so that one device's load never scales another's
  /// feedback. The control loop sets it at construction to the index of the device that drives
  /// the body (platform::ControlLoop with several devices); 0 for every body by default (one
  /// device). Wiring, not state: reset_data() keeps it.
  std::vector<int> feedback_group;
  /// Per feedback group g (index g): the point (world, m) about which group g's composite is
  /// taken and saturated (compute_feedback()) when the held body is not in the group — its
  /// device's controlled frame (link 0, the tool), where its max_force and max_torque are
  /// rated, as the held body's target is for the held body's group (device 0's). The
  /// control loop writes it every period from the device's sample (platform::ControlLoop with
  /// several devices). Not finite, or no entry: the group's first targeted body's target point.
  /// make_data() sizes it 1 + Model::extra_feedback.size(), NaN; wiring: reset_data() keeps it.
  std::vector<Vec3> feedback_point;
  std::vector<JointPrescription> joint_prescribed;  ///< Per joint; read for prescribed joints only.

  // ---- outputs of the last step ----
  std::array<Contact, kMaxContacts> contacts{};  ///< [0, num_contacts) valid.
  int num_contacts = 0;
  int contacts_dropped = 0;        ///< Contacts lost to the capacity this step.
  std::int64_t contact_overflow_steps = 0;  ///< Steps with an overflow since reset.
  /// Multirate scene steps since reset in which a god-object's sphere was past a net's surface
  /// (NetOutput::crossed_contacts > 0 for some net); 0 single-rate.
  std::int64_t net_crossed_steps = 0;
  double max_penetration = 0.0;    ///< Deepest contact this step (m).
  /// Body–body sphere contacts this step whose centres had gone past each other along the
  /// pair's approach normal: held back along it (detect_contacts(), collision.hpp "Crossing").
  int crossed_contacts = 0;
  std::int64_t crossed_contact_steps = 0;  ///< Steps with crossed_contacts > 0 since reset.
  /// Body–body sphere pairs since reset that left contact with their centres past each other
  /// (a crossing not held back: the two bodies went through each other there).
  std::int64_t pass_throughs = 0;
  /// Contacts whose stiffness the time-constant floor lowered this step
  /// (SolverSettings::contact_max_omega_dt; they act with k_eff < k, so penetrate more).
  int contacts_clamped = 0;
  std::int64_t contact_clamped_steps = 0;  ///< Steps with a clamped contact since reset.
  Wrench coupling_wrench;                  ///< Coupling (Eq. 2) on the held body, at its COM.
  /// Device feedback, world, about the held body's target point: Eq. 8 of
  /// the held body plus, by Eq. 9, every other targeted body's Eq. 8
  /// wrench carried to that point. Saturated. Held at the last step's value in a
  /// step whose held body's target is not finite (kInvalidTarget; compute_feedback()).
  Wrench feedback_wrench;
  /// Per body: Eq. 8 wrench of a targeted body about its own target point
  /// (world, unsaturated); zero for bodies without a target.
  std::vector<Wrench> body_feedback;
  std::vector<JointState> joints;  ///< Per joint (Model::joints).
  double max_joint_drift = 0.0;    ///< Largest |C| of a linear joint row at the step's end (m).
  /// Largest |C| of an angular joint row at the step's end (rad); a prescribed
  /// joint's own row (its lag behind the device) is not drift and not counted.
  double max_joint_angle_drift = 0.0;
  /// Node contacts of the nets, [0, num_node_contacts) valid; capacity
  /// kMaxNodeContacts when the model has nets, else 0.
  std::vector<NodeContact> node_contacts;
  int num_node_contacts = 0;
  /// Grasp springs on held net nodes (NodeContact::held), in node_contacts right after the
  /// num_node_contacts penalty contacts; written by the grasp stage (grasp.hpp), 0 without a
  /// held net. The solve takes both; the contact reports count only num_node_contacts.
  int num_node_grasp_springs = 0;
  std::vector<NetOutput> nets;     ///< Per net (Model::nets).
  /// Per thread (Model::threads): its nodes, inputs (external forces, eyelets) and outputs.
  std::vector<ThreadState> threads;
  /// Per body when the model has threads, else empty: the threads' reactions on it this step
  /// (N, N·m about its centre of mass; world), the part of body_wrench that step_threads() added
  /// (their ties' and contacts' reactions). A multirate scene loop hands those on the god-object's
  /// bodies to the device loop (ContactPlaneSet::pulls, docs/multirate-suturing.md).
  std::vector<Wrench> thread_reactions;
  /// Per grasper (Model::grasps): what it holds, its springs and this step's event (grasp.hpp).
  std::vector<GraspState> grasps;
  /// Per needle (Model::needles): its passage through tissue, its puncture points and events
  /// (needle_puncture.hpp).
  std::vector<NeedleState> needles;
  /// The needles' puncture ties on net nodes (NodeContact::held), in node_contacts after the
  /// grasp springs (needle_puncture.hpp, tie_needles()); 0 without a punctured needle.
  int num_node_needle_ties = 0;
  /// The threads' eyelets on tissue as held node springs, in node_contacts after the needles'
  /// ties (thread.hpp, step_threads()); 0 without a thread through tissue.
  int num_node_thread_ties = 0;
  int solver_iterations = 0;       ///< Iterations of the implicit solve this step (bodies and nets).
  /// The measure the solve stopped on (SolverSettings::tolerance): the relative residual
  /// ‖r‖/‖b‖; for a model with nets and no joints the estimated relative energy-norm error
  /// ‖x − x_k‖_A / ‖x‖_A of the iterate error_estimate_delay iterations before the returned
  /// one (+∞ if the budget ended the solve before that many iterations), or with
  /// error_estimate_delay 0 ‖r‖_{M⁻¹}/‖b‖_{D̃⁻¹} (SSOR preconditioner M, its block diagonal D̃;
  /// net_solve.hpp). NaN when non-finite.
  double solver_residual = 0.0;
  std::uint32_t status = kStepOk;  ///< StepStatus bits of the last step.
  /// StepStage bits (step_stages.hpp) of the stages the last step ran, each set by
  /// its stage; equal to Model::stage_plan after any step. 0 before the first step.
  std::uint32_t stages_run = 0;
  std::int64_t nonfinite_steps = 0;  ///< Steps whose result was rejected as non-finite.
  /// Steps since reset that set kInvalidTarget: a device target that was not finite (the held
  /// body's Data::target / target_twist, an enabled Data::body_targets entry, or in
  /// CouplingMode::kAdmittance Data::device_wrench), ignored for the step.
  std::int64_t invalid_target_steps = 0;

  // ---- scratch (sized once) ----
  std::vector<Wrench> body_wrench; ///< Accumulated explicit wrench per body (N, N·m, at COM).
  /// The stages' scratch (collision, solver, articulation, nets; DataScratch,
  /// core/src/scratch/data_scratch.hpp): private to numen::core and its tests.
  DataScratchPtr scratch;
};

/// What a Data holds beyond what its model needs (make_data()).
struct DataOptions {
  /// Room for the contacts a caller writes itself in a step split at its contacts
  /// (step_to_contacts(), add_contact(), step.hpp) where the model makes none — the multirate
  /// device loop's contact planes (multirate/device_loop.hpp). The contact scratch holds
  /// max(contact_capacity(model), written_contacts) contacts, at most kMaxContacts.
  int written_contacts = 0;
};

/// Allocates a Data for a finalized `model` (its scratch block included) and resets
/// it: only what the model needs — no joint buffers or tree-solve scratch without joints, no node or net
/// buffers without nets, no contact scratch when nothing can collide
/// (capacity.hpp; sizes in data_size.hpp) — and what `options` asks for. Allocates. Throws
/// std::invalid_argument for a model without a current stage plan (Model::stage_plan): never
/// finalized, refused by finalize_model(), or edited since without finalize_model() again.
Data make_data(const Model& model, const DataOptions& options = {});

/// Puts every body back at its initial pose and twist, clears inputs, outputs
/// and counters; the device holds Model::initial_held_body.
/// No allocation.
void reset_data(const Model& model, Data& data) noexcept;

}  // namespace numen::core
