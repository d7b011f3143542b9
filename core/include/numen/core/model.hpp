#pragma once
/// @file model.hpp
/// core::Model: the immutable description of a scene, compiled once (sizes,
/// masses, inertias, sphere sets, obstacles, materials, gains, time step).
/// Mutable state lives in core::Data. Pattern of MuJoCo's mjModel/mjData.

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "numen/core/articulation.hpp"
#include "numen/core/broadphase.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/joint.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/thread.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

/// Time integration scheme of a scene (paper §5).
enum class Integrator : std::uint8_t {
  kLinearlyImplicitEuler,  ///< Backward Euler linearised with the stiffness and
                           ///< damping Jacobians (Baraff & Witkin 1998) — paper's choice.
  kSymplecticEuler,        ///< Semi-implicit Euler: v += h M⁻¹ f(x, v); x += h v. Explicit baseline.
  /// Linearised trapezoidal rule (implicit midpoint / Crank–Nicolson on the velocity-level
  /// system; second order, A-stable, not L-stable): the linearly implicit Euler system
  /// of a half step h/2 gives the midpoint twist u½, then x1 = x0 + h v½, q1 =
  /// exp(h ω½) q0, u1 = 2 u½ − u0 (docs/dynamics.md derives it; Hairer & Wanner,
  /// "Solving ODEs II", §IV.7, one-stage Rosenbrock method with γ = 1/2). Not with
  /// CouplingMode::kFirstOrder (refused by finalize_model()).
  kTrapezoidal,
  /// Linearised TR-BDF2 (Bank et al. 1985; Hosea & Shampine 1996): a trapezoidal stage to
  /// t + γh, γ = 2 − √2, then BDF2 to t + h, both applied to the step's linearisation (the
  /// systems of the linearly implicit Euler at the one stage step h_s = γh/2 = (1−γ)/(2−γ) h,
  /// shared by both stages). Second order, L-stable (amplification → 0 as h ω → ∞),
  /// stiffly accurate: runs every coupling mode (docs/dynamics.md derives it).
  kTrBdf2,
};

/// How the held body follows the device target (paper §3, Fig. 5, footnote).
enum class CouplingMode : std::uint8_t {
  kGodObject,   ///< Second order: damped springs of Eq. 2 on a body with mass (the paper's method).
  kFirstOrder,  ///< Massless limit of Eq. 2: γ(v_t − v) + k e + F_ext = 0, i.e. velocity
                ///< proportional to the error (the paper's footnote).
  kDirect,      ///< Pose and twist imposed from the device (paper Fig. 5): no god-object.
  kAdmittance,  ///< Admittance device (paper Fig. 2 note): no coupling spring; the held
                ///< body is driven by the force the user applies to the device
                ///< (Data::device_wrench, explicit external wrench) and the device is
                ///< commanded the body's pose. No feedback wrench (docs/dynamics.md).
};

/// A sphere of a sphere set. `center` is in the body frame for dynamic bodies
/// (origin at the COM) and in the world frame for static sphere sets. Metres.
struct Sphere {
  Vec3 center = Vec3::Zero();
  double radius = 0.0;
};

/// Gains of the coupling springs of Eq. 2 (zero-length, damped).
/// k_t N/m, gamma_t N·s/m, k_r N·m/rad, gamma_r N·m·s/rad.
struct CouplingGains {
  double k_t = 0.0;
  double gamma_t = 0.0;
  double k_r = 0.0;
  double gamma_r = 0.0;
};

/// Virtual-coupling gains of the device feedback (Eq. 8) and its saturation.
/// All zero for a non-haptic device. max_force N, max_torque N·m (norm clamps).
struct FeedbackGains {
  double k_t = 0.0;
  double gamma_t = 0.0;
  double k_r = 0.0;
  double gamma_r = 0.0;
  double max_force = std::numeric_limits<double>::infinity();
  double max_torque = std::numeric_limits<double>::infinity();
};

/// A dynamic rigid body (paper Eq. 1). The body frame has its origin at the
/// centre of mass; inertia_body is expressed in it.
struct BodyModel {
  std::string name;
  double mass = 1.0;                        ///< kg, > 0.
  Mat3 inertia_body = Mat3::Identity();     ///< kg·m², symmetric positive definite.
  Mat3 inertia_body_inv = Mat3::Identity(); ///< Derived by finalize_model().
  int sphere_begin = 0;                     ///< First sphere in Model::body_spheres.
  int sphere_count = 0;                     ///< Number of spheres (0: the body never collides).
  int material = 0;                         ///< Index into the material table.
  CouplingGains coupling;                   ///< Used while the device holds this body.
  Pose initial_pose;                        ///< World pose of the COM frame at reset.
  Twist initial_twist;                      ///< World twist at reset.
  double bounding_radius = 0.0;             ///< Derived: max |c| + r over its spheres (m).
  /// The margin δ (m, ≥ 0) its spheres were grown by: 0 but in a multirate scene loop's
  /// proximity model (make_proximity_model(), multirate.hpp), whose god-object spheres are the
  /// true ones grown by δ. What needs the true sphere (an organ's tissue contact,
  /// net_tissue_contact.hpp) takes its radius less δ.
  double sphere_margin = 0.0;
  /// A static body: held at initial_pose with a zero twist in every step (a body of infinite
  /// mass that nothing moves; never integrated, never coupled to the device, no joint). The
  /// anchored rigid component of a deformable organ (docs/organs.md, "Organs"; Meseure &
  /// Chaillou 2000): its net's ties pull the nodes back to their rest shape and the reaction
  /// goes nowhere. initial_twist must be zero.
  bool anchored = false;
  /// Mesh collision shape (docs/meshes.md, "Mesh bodies"): index into Model::meshes, or -1 for
  /// none. The spheres of the other bodies collide with it (detect_contacts(), the contact's
  /// body_b with sphere_b −1), not those of this body or of a body of its articulation; the nets'
  /// nodes, the obstacles and other meshes do not (the body touches those through its spheres).
  int mesh = -1;
  /// Pose of the mesh's frame in the body frame (origin at the COM; m).
  Pose mesh_pose;
  /// A cutting body (a needle: add_needle() sets it). It meets an organ given by its material
  /// (NetModel::contact_modulus > 0) as it meets a net given per spring — the material pair's
  /// penalty on the touched triangle's nodes — not through the two-scale law
  /// (net_tissue_contact.hpp), whose half-space is pressed by a blunt sphere: a 0.35 mm wire's
  /// tip pressed to a 1 N puncture (docs/suturing.md) would be about 4 mm, twelve of its radii,
  /// into a 120 kPa tissue (Hertz), where the net cannot wrap it.
  bool sharp = false;
};

/// Shape of a static obstacle.
enum class ShapeType : std::uint8_t { kPlane, kBox, kSphere, kCapsule, kSphereSet, kMesh };

/// A static obstacle, world frame.
/// - plane: `pose.position` is a point on it, the normal is pose.orientation·z;
///   the solid side is below the plane (half-space).
/// - box: centre and axes from `pose`, `half_extents` (m).
/// - sphere: centre pose.position, `radius` (m).
/// - capsule: segment centred at pose.position along pose.orientation·z of
///   half length `half_length`, `radius` (m).
/// - sphere set: spheres [sphere_begin, sphere_begin + sphere_count) of
///   Model::static_spheres, already in world coordinates.
/// - mesh: the closed mesh Model::meshes[mesh] (in its own frame) placed by `pose`; the solid is
///   its inside (mesh_shape.hpp, docs/meshes.md).
struct Obstacle {
  std::string name;
  ShapeType type = ShapeType::kPlane;
  int material = 0;
  Pose pose;
  Vec3 half_extents = Vec3::Zero();
  double radius = 0.0;
  double half_length = 0.0;
  int sphere_begin = 0;
  int sphere_count = 0;
  int mesh = -1;  ///< Index into Model::meshes (mesh obstacles only).
  Vec3 aabb_min = Vec3::Constant(-std::numeric_limits<double>::infinity());  ///< Derived.
  Vec3 aabb_max = Vec3::Constant(std::numeric_limits<double>::infinity());   ///< Derived.
};

/// Penalty contact parameters of a pair of materials (paper §5):
/// normal force f_n = max(0, stiffness·depth − damping·v_n) (v_n: separating
/// normal velocity), viscous tangential friction f_t = −friction·v_t.
struct MaterialPair {
  double stiffness = 1e4;  ///< N/m.
  double damping = 10.0;   ///< N·s/m.
  double friction = 0.0;   ///< N·s/m, viscous.
  /// Depth δ0 (m, ≥ 0) of the smoothed C¹ contact onset (contact_force.hpp,
  /// contact_penalty_force()): 0 (default) is the linear penalty law max(0, k d − c v_n); δ0 > 0
  /// a quadratic elastic onset k d²/(2 δ0) over 0 ≤ d < δ0 joined C¹ to k (d − δ0/2), with the
  /// damping and friction faded in by the smoothstep of d/δ0.
  double onset_depth = 0.0;
};

/// Largest SolverSettings::error_estimate_delay.
inline constexpr int kMaxErrorEstimateDelay = 8;

/// Settings of the linear solve of the implicit integrator.
struct SolverSettings {
  int max_iterations = 64;  ///< Preconditioned conjugate gradient iterations, at most.
  /// What ends the iteration. The bodies' and joints' solves and the nets' solve with joints:
  /// the relative residual ‖r‖/‖b‖. The nets' solve without joints (SSOR CG, net_solve.hpp),
  /// with error_estimate_delay d ≥ 1: the relative energy-norm error of the step's velocity
  /// increments, ‖x − x_k‖_A / ‖x‖_A (x = [Δu; Δv], A the step's matrix), as estimated by
  /// Hestenes & Stiefel's Σ α_j ρ_j over d further iterations (Strakoš & Tichý 2002;
  /// docs/deformable.md, "The stopping test"); with d = 0 the residual ratio
  /// ‖r‖_{M⁻¹}/‖b‖_{D̃⁻¹} instead.
  double tolerance = 1e-10;
  /// The tolerance of the energy-norm error rule alone (the nets' solve without joints with
  /// error_estimate_delay d ≥ 1), where a model sets it apart from `tolerance`; ≤ 0 (the
  /// default): `tolerance`. The two rules measure different things — ‖r‖/‖b‖ weighs each row
  /// by its own scale, the error rule the step's energy — so a scene whose jointed solve and
  /// whose solve without joints (the multirate scene loop, which leaves the instrument's joints
  /// to the device loop) both run may set each its own (docs/net-solver.md, "Solver tolerance").
  double error_tolerance = 0.0;
  /// d, the delay of the nets' error estimate (iterations run past the estimated iterate; the
  /// solve returns the later one): 1 … kMaxErrorEstimateDelay, or 0 for the residual ratio.
  int error_estimate_delay = 1;
  /// v_f (m/s, ≥ 0): the velocity below which the nets' solve without joints does not chase a
  /// relative tolerance. Its rules are relative (to ‖x‖_A, or to ‖b‖); an organ at rest has a
  /// right-hand side of rounding size (‖b‖² ~ 1e-34 J on the shipped organ), which they chase
  /// over 5–7 iterations a step for nothing. Both take the solution's scale as at least the
  /// nets' kinetic energy at v_f, F = Σ m_net v_f²: a step whose velocity change is below it is
  /// solved to tolerance · v_f (mass-weighted) in absolute terms — 1e-10 m/s at the shipped 1e-4
  /// and 1e-6 m/s, a drift of 1e-13 m a 1 ms step (docs/net-solver.md, "The floor"). 0: the
  /// relative rules alone.
  double velocity_floor = 1e-6;
  /// Contact time-constant floor, as ω_c h (dimensionless, > 0; +∞ switches it off): a penalty
  /// contact acts with the stiffness k_eff = min(k, m_eff (ω_c h / h)²), h = Model::dt, m_eff its
  /// effective mass along the normal (contact_effective_mass(); a net node's mass for node
  /// contacts), i.e. its time constant 1/ω = √(m_eff / k_eff) never falls below h / (ω_c h)
  /// (the role of MuJoCo's solref clamp, timeconst ≥ 2 h). The linearised step is stable on its
  /// own linearisation at any stiffness, but not on what it freezes for the step (the depth found
  /// at the step's start, the normal, the lever arms): far above ω h = 5 those errors, ∝ k h²/m,
  /// threw the shipped articulated tool away (docs/dynamics.md, "Stiff contacts"). Every shipped
  /// scene stays below it (largest: the default scene's jaws, ω h = 3.47 at 2e4 N/m), so it
  /// changes nothing there.
  double contact_max_omega_dt = 5.0;
  /// The same floor for the node contacts of deformable nets (ω h on 1 / (1/m_node + the body's
  /// mobility)). A node is a point mass: no lever arm of its own, so only the onset and a sphere
  /// pair's normal are frozen, and the shipped nets run their light nodes on 2e4 N/m at ω h up to
  /// 30–50 without harm; at 1e12 N/m the nets stay bounded with a floor of 50–200 and the
  /// endobag diverges without one. 100 keeps every shipped node contact unclamped.
  double node_contact_max_omega_dt = 100.0;
};

/// Baumgarte stabilisation of the joint constraints (paper Eq. 5): the
/// constraint error obeys C̈ + α Ċ + β C = 0 with α = alpha_dt / Δt (1/s) and
/// β = beta_dt2 / Δt² (1/s²). The paper's values 2/Δt and 1/Δt² (a critically
/// damped error at ω = 1/Δt) are the default. Discretised implicitly, like the
/// springs: see docs/articulation.md (and joint_system.hpp). Both ≥ 0, not
/// both 0: without any correction the discrete error is not even bounded.
struct BaumgarteSettings {
  double alpha_dt = 2.0;  ///< α·Δt (dimensionless).
  double beta_dt2 = 1.0;  ///< β·Δt² (dimensionless).
};

/// The immutable, compiled description of a scene. Fill the public fields,
/// then call finalize_model(); afterwards only read it (an edit needs
/// finalize_model() again: its derived fields, the stage plan included, go stale).
struct Model {
  double dt = 1e-3;                              ///< Fixed time step (s).
  Vec3 gravity = Vec3(0.0, 0.0, -9.81);          ///< m/s², world frame.
  Integrator integrator = Integrator::kLinearlyImplicitEuler;
  CouplingMode coupling_mode = CouplingMode::kGodObject;

  std::vector<BodyModel> bodies;       ///< Dynamic bodies.
  std::vector<Sphere> body_spheres;    ///< Body-frame spheres of all bodies.
  std::vector<Obstacle> obstacles;     ///< Static obstacles.
  std::vector<Sphere> static_spheres;  ///< World-frame spheres of sphere-set obstacles.
  std::vector<MeshShape> meshes;       ///< Mesh obstacles' and bodies' shapes (build_mesh_shape()).
  std::vector<JointModel> joints;      ///< Joints of the articulations (a forest; may be empty).
  BaumgarteSettings baumgarte;         ///< Joint drift correction (Eq. 5).

  // Deformable nets (net_model.hpp; paper §4.2), appended by add_net(). Node
  // arrays are indexed by the global node index; all empty without nets.
  std::vector<NetModel> nets;
  std::vector<NetSpring> net_springs;  ///< Springs of every net (structural, then bending, per net).
  std::vector<Vec3> node_rest;         ///< Rest position in the rigid component's body frame (m).
  std::vector<double> node_mass;       ///< kg, > 0 (lumped by vertex area).
  std::vector<double> node_radius;     ///< Collision sphere radius (m), > 0.
  std::vector<int> node_net;           ///< Net owning each node.
  /// Surface triangles of every net (per net, NetModel::face_begin/face_count): the mesh's
  /// triangles as global node indices, wound counter-clockwise seen from outside (outward
  /// normal (x1 − x0) × (x2 − x0); add_net() turns a mesh that encloses a negative volume).
  /// An organ's contacts with the tool are against them (net_surface.hpp).
  std::vector<std::array<int, 3>> net_faces;
  /// Tetrahedra of the nets given by their material (net_material.hpp; per net
  /// NetModel::tetrahedron_begin/count, empty for a net given per spring): those of the
  /// tetrahedral mesh well shaped at rest (kInversionWatchQuality; not the slivers) as global
  /// node indices, ordered so that each has a positive signed volume
  /// (x1 − x0) × (x2 − x0) · (x3 − x0) / 6 at rest. The net's springs do not keep them from
  /// turning inside out: measure_nets() counts those whose volume is not positive at a step's
  /// end (NetOutput::inverted_tetrahedra; docs/tissue.md, "Inversion").
  std::vector<std::array<int, 4>> net_tetrahedra;
  /// Fine surfaces mapped onto nets (net_surface_map.hpp, add_net_surface()): every fine
  /// vertex's embedding on a net triangle, per net NetModel::surface_point_begin/count.
  std::vector<NetSurfacePoint> net_surface_points;
  /// The fine surfaces' triangles as global indices into net_surface_points, wound outward (per
  /// net NetModel::surface_face_begin/count). An organ with one meets the tool with these.
  std::vector<std::array<int, 3>> net_surface_faces;
  /// Which fine triangles ride on each net triangle (those with a vertex embedded on it):
  /// net_face_surface_faces[net_face_surface_begin[f] .. net_face_surface_begin[f + 1]) for the
  /// global net triangle f; size net_faces.size() + 1 once a fine surface is added, else empty.
  std::vector<std::int32_t> net_face_surface_begin;
  std::vector<std::int32_t> net_face_surface_faces;
  /// Per entry of net_face_surface_faces: the patch its fine triangle belongs to there (the
  /// index of the patch's first record in net_surface_clusters; NetSurfaceCluster). Each net
  /// triangle's riders are split into patches of about half a dozen by the net triangles their
  /// vertices ride on and their barycentric cells (net_surface_map.cpp), a patch's riders
  /// consecutive (NetSurfaceCluster::riders); the search keeps net_face_surface_faces' order.
  /// −1: in no patch (the search gathers it whenever its net triangle is near; add_net_surface()
  /// puts every rider in one).
  std::vector<std::int32_t> net_face_surface_cluster;
  std::vector<NetSurfaceCluster> net_surface_clusters;
  /// Order in which the solver's SSOR sweeps visit the nodes (net_solve.hpp):
  /// node_sweep_order[p] is the global node at sweep position p, a reverse
  /// Cuthill–McKee order of each net's spring graph within the net's own index
  /// range (Cuthill & McKee 1969; George 1971; Boost.Graph's
  /// cuthill_mckee_ordering from a pseudo-peripheral node): a level-set order,
  /// neighbours close together, along which Gauss–Seidel carries a change
  /// across the net in one sweep — on an icosphere ~11 % fewer CG iterations
  /// than the mesh's vertex order, whose refinement levels interleave
  /// (docs/deformable.md). Derived by finalize_model() (order_net_nodes()).
  std::vector<std::int32_t> node_sweep_order;
  /// The springs at each node: node_springs[node_spring_begin[i] .. node_spring_begin[i + 1])
  /// are the indices into net_springs of node i's springs (structural and bending, ascending);
  /// every spring is listed at both its nodes. Sizes num_nodes() + 1 and 2 net_springs.size()
  /// (both empty without nets). What works on a few nodes' springs (the multirate node planes,
  /// multirate/net.hpp) reads them there instead of passing over every spring. Derived by
  /// finalize_model() (index_node_springs()).
  std::vector<std::int32_t> node_spring_begin;
  std::vector<std::int32_t> node_springs;

  /// Suture threads (thread.hpp, docs/thread.md "The thread"); empty: no thread stage.
  std::vector<ThreadModel> threads;

  /// Graspers (grasp.hpp, docs/grasping.md): an instrument's two jaws and their grasp rules.
  std::vector<GraspModel> grasps;
  /// Curved suture needles (needle.hpp, docs/suturing.md "The needle"), appended by add_needle():
  /// each a body of Model::bodies with its arc. Empty: no needle, and nothing of a step for one.
  std::vector<NeedleModel> needles;
  std::vector<std::string> material_names;  ///< Size num_materials.
  std::vector<MaterialPair> material_pairs; ///< num_materials², symmetric, row-major.

  FeedbackGains feedback;          ///< Device virtual coupling (Eq. 8); device 0's with several.
  /// Eq. 8 gains of devices 1 .. N−1 of a loop that runs several (feedback group g ≥ 1 of
  /// Data::feedback_group is extra_feedback[g − 1]; feedback_gains()). Empty: every group uses
  /// `feedback`.
  std::vector<FeedbackGains> extra_feedback;
  int initial_held_body = 0;       ///< Body the device holds at reset; -1 for none.
  SolverSettings solver;

  StaticSphereGrid static_grid;    ///< Derived by finalize_model() (broad phase).
  ArticulationTopology articulation;  ///< Derived by finalize_model() (elimination order).
  /// The stage plan (StepStage bits, step_stages.hpp): the stages step() runs for this
  /// model and the solve integrate() picks, in every step, and what Data::stages_run holds
  /// after any step (a step split at its contacts adds the caller's contact stages, step.hpp).
  /// Derived by finalize_model() as compiled_stages(*this), from integrator, coupling_mode, the
  /// joints, the nets, the graspers, needles and threads and what can collide (bodies,
  /// obstacles); 0 before finalize_model() and after a refusal. A model edited after
  /// finalize_model() has a stale plan until finalize_model() runs again: make_data() refuses
  /// a model whose plan is missing or stale, and step() asserts it current in builds without
  /// NDEBUG (it does not recompute it).
  std::uint32_t stage_plan = 0;

  int num_materials() const noexcept { return static_cast<int>(material_names.size()); }
  /// Contact parameters between materials a and b.
  const MaterialPair& material_pair(int a, int b) const noexcept {
    return material_pairs[static_cast<std::size_t>(a * num_materials() + b)];
  }
  int num_bodies() const noexcept { return static_cast<int>(bodies.size()); }
  int num_joints() const noexcept { return static_cast<int>(joints.size()); }
  int num_nets() const noexcept { return static_cast<int>(nets.size()); }
  int num_grasps() const noexcept { return static_cast<int>(grasps.size()); }
  int num_needles() const noexcept { return static_cast<int>(needles.size()); }
  int num_nodes() const noexcept { return static_cast<int>(node_rest.size()); }
  int num_threads() const noexcept { return static_cast<int>(threads.size()); }
};

/// Validates `model` and computes its derived fields (inverse inertias,
/// bounding radii, obstacle bounds, broad-phase grid, articulation topology, the
/// stage plan Model::stage_plan last). Returns an empty string on success, else a
/// message naming the offending body/obstacle/field (and leaves stage_plan 0, so
/// make_data() refuses the model). Call it again after any edit of a finalized
/// model. Allocates: load time only.
std::string finalize_model(Model& model);

/// Whether `model` has nodes and Model::node_spring_begin and Model::node_springs have the sizes
/// index_node_springs() gives them (finalize_model() ran since the nets last changed): what reads
/// a node's springs there (the resting nodes, the multirate node planes) checks this first.
inline bool node_springs_indexed(const Model& model) noexcept {
  return model.node_spring_begin.size() == static_cast<std::size_t>(model.num_nodes()) + 1 &&
         model.node_springs.size() == 2 * model.net_springs.size();
}

/// Default damping from a damping ratio ζ for a spring k acting on mass m:
/// γ = 2 ζ √(m k). The paper's rule 1.4 ≤ γ/√(mk) ≤ 2 is ζ in [0.7, 1].
double damping_from_ratio(double zeta, double mass, double stiffness) noexcept;

/// The Eq. 8 gains of feedback group `group` (Data::feedback_group, the index of the device
/// that drives the body): Model::extra_feedback[group − 1] for a group ≥ 1 it holds, else
/// Model::feedback. Real-time safe.
inline const FeedbackGains& feedback_gains(const Model& model, int group) noexcept {
  return group >= 1 && static_cast<std::size_t>(group) <= model.extra_feedback.size()
             ? model.extra_feedback[static_cast<std::size_t>(group - 1)]
             : model.feedback;
}

}  // namespace numen::core
