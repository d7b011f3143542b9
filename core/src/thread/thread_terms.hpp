#pragma once
/// @file thread_terms.hpp
/// The point terms of a thread's step (thread.hpp, step_threads()): its contacts with the
/// bodies' spheres, the static obstacles and itself, and its eyelets, each written as a
/// ThreadPointTerm into its scratch for the implicit solve (thread_step.cpp). Node i of the
/// thread is block i + 1 of its band. No allocation: a term past the scratch's capacity is
/// dropped and counted in ThreadOutput::contacts_dropped.

#include <vector>

#include "numen/core/types.hpp"

namespace numen::core {

struct ThreadBand;
struct ThreadPointTerm;
struct MaterialPair;

struct Model;
struct Data;
struct ThreadModel;
struct ThreadState;
struct ThreadScratch;
struct GraspState;

/// The next free term of `scratch` (cleared), or nullptr (counted in
/// ThreadOutput::contacts_dropped) when its capacity is used up.
ThreadPointTerm* next_thread_term(ThreadScratch& scratch, ThreadState& state) noexcept;

/// Fills a penalty contact term of `stiffness` (N/m) and the pair `mp`'s damping (on closing
/// only) and viscous friction: `depth` (m) along the unit normal `n` (out of the other side,
/// towards the thread), `v_rel` the thread point's velocity relative to the other side (m/s).
void fill_contact(ThreadPointTerm& term, const MaterialPair& mp, double stiffness, double depth,
                  const Vec3& n, const Vec3& v_rel) noexcept;

/// How far from a body sphere (m, beyond the thread's and the sphere's radii) a segment that
/// has touched it keeps it as a contact (ThreadPointTerm::kept; remembered while within this). A light thread
/// under tension that loses its contact with a receding jaw straightens back at metres per
/// second (the suturing scene at 25.010 s: 1.1–2.1 m/s, its nodes carried 1.2 mm into the jaw in
/// one 1 ms step, and 12 N of tension the step after from 15 contacts at once); kept, the
/// contact follows the jaw away.
inline constexpr double kThreadContactMargin = 2e-3;

/// Segment–sphere contacts with every body sphere (a body's material pair with the thread's:
/// stiffness under the body's contact time-constant floor, damping, viscous friction; the
/// reaction goes to the body). The segments next to a tie (3) do not touch the tied body; the
/// segments next to a node a grasper holds (thread_grasp.cpp) do not touch its jaws. `index`:
/// the thread's in Model::threads.
void gather_thread_body_contacts(const Model& model, const Data& data, int index, const ThreadModel& thread,
                                 ThreadState& state, ThreadScratch& scratch) noexcept;

/// The thread in the jaws (grasp.hpp GraspThreadNode, docs/thread.md "The thread in the
/// jaws"): for each grasp holding thread `index` (GraspState::thread), each held node's springs
/// to both jaws — half the grasper's stiffness and damping each, towards the node's place at the
/// grasp's start in the jaw's frame, the jaw's point moving as given — as point terms whose
/// reaction goes to the jaw (ThreadPointTerm::body) and whose force the step adds to
/// GraspThreadNode::force (zeroed here). No allocation.
void gather_thread_grasps(const Model& model, Data& data, int index, ThreadState& state,
                          ThreadScratch& scratch) noexcept;

/// The grasp of Data::grasps holding thread `index` with `body` as one of its jaws, or nullptr.
const GraspState* jaw_holding_thread(const Model& model, const Data& data, int index, int body) noexcept;

/// Whether `segment` is next to a node `hold` holds (its contacts with the jaws are off).
bool next_to_held_node(const GraspState& hold, int segment) noexcept;

/// Node contacts (a sphere of the thread's radius) with the obstacles: planes, boxes, spheres,
/// capsules, meshes (sphere_mesh()) and the sphere sets' spheres (through Model::static_grid,
/// its query stamps in the collision scratch).
void gather_thread_obstacle_contacts(const Model& model, Data& data, const ThreadModel& thread,
                                     ThreadState& state, ThreadScratch& scratch) noexcept;

/// Self contact, candidates: the pairs of non-adjacent segments whose boxes, swept from the
/// step's start (`state`) to the iterate `x` and grown by the radius, overlap (a sweep along the
/// thread's longest axis), with their nearest points and normal at the step's start, into
/// ThreadScratch::self_pairs. Pairs past its capacity are dropped and counted.
void find_thread_self_pairs(const ThreadModel& thread, ThreadState& state,
                            const std::vector<Vec3>& x, ThreadScratch& scratch) noexcept;

/// Self contact, forces: each candidate pair closer than two radii along its start normal n0 at
/// the iterate `x` (a pair that crossed within the step is held back the way it came) pushes its
/// two segments apart by k (2 r − (p − q)·n0) n0 and, with the thread's self_friction μ, holds
/// back their sliding across n0 by Coulomb friction μ k d (regularised to viscous below
/// kThreadSelfSlipSpeed, at the iterate's velocities `v`), into `band` in Newton's form (its
/// force h f at the iterate; its stiffness and the friction's damping in each side's own blocks,
/// doubled, the other side as given). Returns the pairs in contact.
int add_thread_self_contacts(const Model& model, const ThreadModel& thread,
                             const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                             const ThreadScratch& scratch, double h, ThreadBand& band) noexcept;

/// The active eyelets of `state`: a spring across the thread at its nearest point and Coulomb
/// friction along it, with the eyelet's drag (ThreadEyelet). An eyelet on tissue past a free end
/// of the thread is let go (ThreadState::eyelets_let_go).
void gather_thread_eyelets(const ThreadModel& thread, ThreadState& state,
                           ThreadScratch& scratch) noexcept;

/// Through tissue, before the thread's step: each puncture point its needle (ThreadModel::needle)
/// let go past the tail this step (NeedleState::tail_releases) becomes an eyelet on that material
/// point (ThreadEyelet::face), with the thread's tissue_friction and the needle's tie stiffness
/// and friction; one with no free eyelet is counted (ThreadState::eyelets_dropped).
void take_over_punctures(const Model& model, const Data& data, const ThreadModel& thread,
                         ThreadState& state) noexcept;

/// Each eyelet on tissue at its material point: position and velocity from its triangle's nodes
/// at the step's start (an eyelet on a triangle the model does not have is let go).
void place_tissue_eyelets(const Model& model, const Data& data, ThreadState& state) noexcept;

/// Node contacts with the nets' surface triangles (tissue): each node's sphere (the thread's
/// radius) against the triangle it is deepest under (on a face: less than
/// kThreadTissueContactReach below its plane; at an edge or corner: reaching it from outside),
/// the net's material pair with the thread's (stiffness, damping, viscous friction), the surface
/// point moving with its nodes. Left out (a passage through the tissue): the nodes between two
/// eyelets on tissue along the thread (and, for a thread following a needle with an odd count of
/// them, from its start to the first: the needle's tail is in the tissue), the nodes next to a
/// tie to a body and within 2.5 segments of an active eyelet. At most kMaxThreadTissueContacts; the
/// triangles are visited once each, the nodes within a triangle's extent along the thread's
/// longest axis found in their sorted order (ThreadScratch::tissue_order).
void gather_thread_tissue_contacts(const Model& model, const Data& data, const ThreadModel& thread,
                                   ThreadState& state, ThreadScratch& scratch) noexcept;

/// After the thread's step: each contact with tissue's force given back to its triangle's nodes
/// as held node springs along its normal (per node of weight w > 0: w × the contact's stiffness
/// and damping, towards the thread's node as the step left it; ThreadScratch::tissue_terms),
/// appended after the needles' ties (Data::num_node_thread_ties).
void tie_tissue_contacts(const Model& model, Data& data, const ThreadScratch& scratch) noexcept;

/// After the thread's step: each eyelet on tissue's force given back to its triangle's nodes as
/// held node springs (per node of weight w > 0: along the thread w × the friction's damping,
/// across it w × the eyelet's stiffness, towards the thread's point moving as the step left it),
/// appended after the needles' ties (Data::num_node_thread_ties).
void tie_tissue_eyelets(const Model& model, Data& data, const ThreadState& state,
                        const ThreadScratch& scratch) noexcept;

}  // namespace numen::core
