#pragma once
/// @file thread.hpp
/// A suture thread (issue 69, docs/thread.md "The thread"): an elastic rod as a chain of
/// `segments` straight segments between `segments + 1` nodes (point masses), stepped by the
/// linearly implicit Euler the rest of numen uses (Baraff & Witkin 1998) with one block-banded
/// solve per step (3×3 blocks, block bandwidth 2: O(n), linalg/thread_band.hpp).
///
/// Energy of the rod (all terms in the world frame, SI units):
///   - stretch: each segment a spring of stiffness E A / l0 (A = π r², l0 = length / segments),
///     its full Jacobian (axial E A / l0 and the geometric term (1 − l0/l) E A / l0 across it,
///     dropped when the segment is compressed so the system stays positive definite);
///   - bend: E I / (2 l0³) Σ |x_{i−1} − 2 x_i + x_{i+1}|² (I = π r⁴ / 4), the discrete
///     curvature κ_i ≈ |Δ² x_i| / l0² of a straight rest shape: E I κ² l0 / 2 per node, a
///     constant Hessian, invariant under rigid motions (the quadratic bending model of
///     Bergou et al. 2006, "A quadratic bending model for inextensible surfaces", on a curve);
///   - gravity, and a viscous drag `damping` (N·s/m per metre of thread) against the world.
/// No twist: a round thread without a knot's twist coupling does not need it (docs/thread.md).
///
/// Couplings (step_threads(), in the step's body-force stage): an end tied to a point of a
/// rigid body (ThreadTie; the body's translational effective mass at the point is in the
/// thread's solve, the tie force goes back to the body in the same step), penalty contacts of
/// the segments with the bodies' spheres (reaction on the body), of the nodes with the static
/// obstacles (plane, box, sphere, capsule, mesh, the sphere sets' spheres), of non-adjacent
/// segments with each other (capsule–capsule with the thread radius), of the nodes with the
/// nets' surface triangles, or the fine surface a net carries (tissue; the reaction goes to the
/// net triangle's nodes as held node springs, as an eyelet's on tissue below), and eyelets:
/// points the thread slides through with friction along it (ThreadEyelet, written by the
/// caller before each step, or taken over from a needle's punctures), and a grasper's jaws
/// holding some of its nodes (GraspThreadNode, grasp.hpp: springs to the jaws' points, the
/// reaction on the jaws; docs/thread.md "The thread in the jaws").
///
/// Through tissue (docs/thread.md "The thread through tissue"): a thread whose start is tied
/// to a needle (ThreadModel::needle) takes over each puncture point the needle lets go past its
/// tail (NeedleState::tail_releases) as an eyelet on that material point of the net's surface
/// (ThreadEyelet::face): the eyelet moves with the net's nodes, and its force goes back to them
/// as held node springs in the nets' implicit step (Data::num_node_thread_ties) — across the
/// thread the eyelet's stiffness, along it the friction's damping, each node by its barycentric
/// weight — while the thread's own step holds the eyelet's point as given: each side implicit in
/// its own unknowns, the other side's point moving as it did at the step's start.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct Model;
struct Data;

/// Most eyelets (puncture points) one thread slides through at once.
inline constexpr int kMaxThreadEyelets = 8;
/// Held node springs one eyelet on tissue writes: three nodes, three axes.
inline constexpr int kThreadEyeletTieSprings = 9;
/// Contacts of one thread with the nets' surfaces in one step at most (one per node, with the
/// triangle it is deepest under; more are dropped and counted in ThreadOutput::contacts_dropped),
/// and the held node
/// springs each gives its triangle's nodes (one along its normal per node): Data::node_contacts'
/// room for them (make_data()).
inline constexpr int kMaxThreadTissueContacts = 64;
inline constexpr int kThreadTissueContactSprings = 3;
/// Below this sliding speed (m/s) the friction between two strands of a thread in self contact
/// is viscous (ThreadModel::self_friction): μ |F_n| / kThreadSelfSlipSpeed per m/s.
inline constexpr double kThreadSelfSlipSpeed = 1e-3;
/// How deep below a net's surface (m) a thread node still touches it: a node deeper is in a
/// passage through the tissue (behind an eyelet or the needle), not on it.
inline constexpr double kThreadTissueContactReach = 1e-3;

/// One end of a thread tied to a point of a rigid body (e.g. a needle's tail, where the thread
/// is swaged into it). Body frame: origin at the body's centre of mass (BodyModel).
struct ThreadTie {
  /// Index into Model::bodies, or −1: the end is tied to the fixed world point `point`.
  /// −2: the end is free (no tie).
  int body = -2;
  Vec3 point = Vec3::Zero();  ///< The point, in the body frame (world frame for body −1) (m).
  /// Clamped: the second node is tied too, at point + l0 · direction (the thread leaves the
  /// body along `direction`, body frame, normalised by finalize): a swaged needle's tail. Else
  /// the end is a pin joint.
  bool clamped = false;
  Vec3 direction = Vec3::UnitX();
};

/// The settings of one thread (Model::threads). Default: a 3-0 silk suture (USP 3-0
/// non-absorbable diameter 0.200–0.249 mm, USP <861>; initial modulus 8.70 GPa, Naleway et al.
/// 2015, "Mechanical properties of suture materials in general and cutaneous surgery", J.
/// Biomed. Mater. Res. B 103(4)), docs/thread.md.
struct ThreadModel {
  std::string name;
  double length = 0.15;            ///< Rest length (m), > 0.
  int segments = 100;              ///< Segments, ≥ 1 (nodes: segments + 1).
  double radius = 1.125e-4;        ///< Cross-section radius (m), > 0: 3-0, 0.225 mm diameter.
  double young_modulus = 8.70e9;   ///< E (Pa), > 0.
  double density = 1340.0;         ///< kg/m³, > 0 (silk fibroin, 1.3–1.4 g/cm³).
  double damping = 1e-3;           ///< Viscous drag per length (N·s/m²), ≥ 0.
  /// Strain at which a segment breaks (> 0): a pull that stretches a segment past it cuts the
  /// thread there (ThreadOutput::broke) instead of stretching on. Silk 3-0: ~0.2 (Naleway 2015).
  double break_strain = 0.2;
  int material = 0;                ///< Contact material (Model::material_names index).
  Vec3 start = Vec3::Zero();       ///< Initial shape: node 0 here (world, m) ...
  Vec3 direction = Vec3::UnitX();  ///< ... the others along this direction (world; normalised).
  ThreadTie tie_start;             ///< Node 0's tie.
  ThreadTie tie_end;               ///< The last node's tie.
  bool self_contact = true;        ///< Segment–segment contacts of the thread with itself.
  /// Coulomb μ (≥ 0) of the thread sliding through a puncture point it takes over from its
  /// needle. Chosen, not measured: suture–tissue friction depends on the load, the speed and the
  /// suture (Zhang et al. 2017, "Friction Behavior at the Interface Between Surgical Sutures and
  /// Tissues", Tribol. Lett. 65:4, braided silk the highest); docs/thread.md.
  double tissue_friction = 0.3;
  /// Coulomb μ (≥ 0) between two strands of the thread in self contact: a strand sliding over
  /// another is held back by μ |F_n| (regularised to viscous below kThreadSelfSlipSpeed), what
  /// holds a knot's throws once pulled tight. 0 (default): frictionless strands.
  double self_friction = 0.0;
  // ---- derived by finalize_model() ----
  /// The needle (Model::needles) whose body the start is tied to, or −1: the thread takes over
  /// its puncture points past the tail (needle_puncture.hpp, NeedleState::tail_releases).
  int needle = -1;
  double rest_segment = 0.0;       ///< l0 = length / segments (m).
  double node_mass = 0.0;          ///< ρ A l0 (kg); the two end nodes carry half of it.
  double stretch_stiffness = 0.0;  ///< E A / l0 (N/m).
  double bend_stiffness = 0.0;     ///< E I / l0³ (N/m).
};

/// A point the thread slides through (a puncture in tissue), given by the caller before each
/// step: it holds the thread's nearest point on the eyelet across the thread (a spring of
/// `stiffness` perpendicular to the local tangent) and resists sliding along it by Coulomb
/// friction μ |F_n| (regularised below `slip_speed`).
struct ThreadEyelet {
  bool active = false;
  /// World (m) and velocity (m/s); for an eyelet on tissue (`face` ≥ 0) the stage writes them
  /// from the net's nodes at the step's start.
  Vec3 position = Vec3::Zero();
  Vec3 velocity = Vec3::Zero();  ///< World (m/s).
  double friction = 0.0;         ///< μ (dimensionless), ≥ 0.
  double stiffness = 1e3;        ///< Across the thread (N/m), > 0.
  double slip_speed = 1e-3;      ///< Below this sliding speed (m/s) friction is viscous.
  double drag = 0.0;             ///< Viscous friction along the thread besides μ (N·s/m), ≥ 0.
  /// On tissue: a triangle of Model::net_faces (−1: a point the caller moves) and the material
  /// point's barycentric weights on its nodes (sum 1). Its force goes back to those nodes.
  int face = -1;
  Vec3 weights = Vec3::Zero();
};

/// What an eyelet did in the last step.
struct ThreadEyeletOutput {
  int segment = -1;           ///< Segment through the eyelet (−1: not found yet).
  double normal_force = 0.0;  ///< |F_n| across the thread (N).
  double friction_force = 0.0;  ///< Along the thread, signed along the segment's direction (N).
};

/// Outputs of one thread's last step.
struct ThreadOutput {
  double max_tension = 0.0;  ///< Largest segment tension E A (l − l0)/l0, ≥ 0 (N).
  double max_stretch = 0.0;  ///< Largest segment strain (l − l0)/l0.
  int body_contacts = 0;     ///< Segment–body-sphere contacts this step.
  /// Kept segment–body-sphere contacts pushing at the step's end: a sphere the segment has
  /// touched and not left by more than 2 mm since, not touching at this step's start, that the
  /// step would have carried it into (docs/thread.md, "Contacts with bodies").
  int kept_contacts = 0;
  int obstacle_contacts = 0; ///< Node–obstacle contacts this step.
  int self_contacts = 0;     ///< Segment–segment contacts this step.
  int tissue_contacts = 0;   ///< Node–net-surface contacts this step (thread_tissue_contact.cpp).
  int contacts_dropped = 0;  ///< Contacts over the thread's capacity this step (not applied).
  Wrench tie_wrench_start;   ///< Tie force on node 0's body (N, N·m about its COM; world).
  Wrench tie_wrench_end;     ///< Same for the last node's tie.
  bool broke = false;        ///< The thread broke in this step (event).
  int iterations = 0;        ///< Newton iterations of the step (banded solves), 1 … 6.
  /// Whether the step's Newton iteration met its tolerance (thread_step.cpp: no node off by more
  /// than 1e-6 of a segment's length); false: it ran out of its 6 iterations and the step took
  /// the last iterate (a contact chattering between iterates, a step too long for the thread's
  /// turn). A non-finite step is rolled back and counted instead (Data::status kNonFinite).
  bool converged = true;
  std::array<ThreadEyeletOutput, kMaxThreadEyelets> eyelets{};
};

/// The state, inputs and outputs of one thread (Data::threads), sized by make_data().
struct ThreadState {
  std::vector<Vec3> position;  ///< Node positions (world, m), segments + 1.
  std::vector<Vec3> velocity;  ///< Node velocities (world, m/s).
  /// Input: an external force on each node (world, N), e.g. a grasper's pull; kept until changed.
  std::vector<Vec3> external_force;
  /// Input: the eyelets the thread slides through this step.
  std::array<ThreadEyelet, kMaxThreadEyelets> eyelets{};
  /// The segment the thread broke at (no stretch or bend across it from then on), or −1.
  int broken_segment = -1;
  std::int64_t eyelets_taken = 0;    ///< Puncture points taken over from the needle since reset.
  /// Eyelets on tissue let go since reset: the thread's free end slid out through them.
  std::int64_t eyelets_let_go = 0;
  /// Puncture points not taken over for want of a free eyelet (kMaxThreadEyelets): must stay 0.
  std::int64_t eyelets_dropped = 0;
  ThreadOutput output;
};

/// Checks `thread` (its name or index in `label`) and fills its derived fields. Returns "" or
/// a message naming the bad setting: length ≤ 0, segments < 1, radius ≤ 0, young_modulus ≤ 0,
/// density ≤ 0, damping < 0, break_strain ≤ 0, tissue_friction < 0, self_friction < 0, a zero
/// direction, a tie to a body that does not exist, a non-finite value. `num_bodies`,
/// `num_materials`: the model's. Load time.
std::string finalize_thread(ThreadModel& thread, int num_bodies, int num_materials);

/// Puts `state` at the initial straight shape of `thread` at rest (no allocation once sized).
void reset_thread(const ThreadModel& thread, ThreadState& state) noexcept;

/// Copies `from` into `to`: every field, the node vectors over the smaller of the two sizes (a
/// multirate snapshot of the scene loop's thread, StepOutputs::threads). No allocation.
void copy_thread_state(const ThreadState& from, ThreadState& to) noexcept;

/// Steps every thread of `model` by Model::dt from the bodies' states at the step's start and
/// adds the ties', contacts' and held nodes' springs' reactions to Data::body_wrench (the jaws
/// get the springs' of GraspState::thread_nodes, whose `force` it writes; the body-force stage; sets
/// kStageThreads in Data::stages_run); takes over its needle's puncture points let go past the
/// tail this step, and writes its eyelets' forces on tissue as held node springs after the
/// needles' ties (Data::num_node_thread_ties; before the nets' forces). A non-finite result
/// restores the thread's last positions at rest and sets kNonFinite. No allocation, no exception.
void step_threads(const Model& model, Data& data) noexcept;

}  // namespace numen::core
