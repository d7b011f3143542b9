#pragma once
/// @file thread_scratch.hpp
/// One thread's step scratch (thread.hpp, step_threads()): its banded system, the point terms of
/// its contacts and eyelets, the saved state for a rollback, the self-contact sweep order. Sized
/// by make_data(); private to numen::core (DataScratch::threads).

#include <array>
#include <cstdint>
#include <vector>

#include "linalg/thread_band.hpp"
#include "numen/core/thread.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

struct ThreadModel;

/// Segments a run of the contacts with bodies takes (thread_contacts.cpp): a body sphere meets
/// a run's box before its segments' (200 segments: 25 runs).
inline constexpr int kThreadSegmentRun = 8;

/// Body spheres a segment's touches are remembered for, per step (ThreadScratch::touched).
inline constexpr int kThreadTouchedSpheres = 4;

/// A spring-damper between a point of the thread (w_a x_a + w_b x_b, blocks a, b of the band)
/// and an outside point moving at `target_velocity` (a body's sphere, an obstacle, the other
/// segment of a self-contact, an eyelet): force `force` on the thread point at the step's start,
/// stiffness K and damping C on the relative motion, K scaled by `matrix_scale` in the matrix.
struct ThreadPointTerm {
  int a = 0, b = 0;
  double wa = 1.0, wb = 0.0;
  Mat3 stiffness = Mat3::Zero();
  Mat3 damping = Mat3::Zero();
  Vec3 force = Vec3::Zero();
  Vec3 target_velocity = Vec3::Zero();
  double matrix_scale = 1.0;
  int body = -1;            ///< The body that takes the reaction at `point`, or −1.
  Vec3 point = Vec3::Zero();  ///< World (m).
  int eyelet = -1;          ///< The eyelet (ThreadState::eyelets) this term is, or −1.
  Vec3 axis = Vec3::Zero(); ///< An eyelet's: the thread's unit tangent there.
  /// A contact with a net's surface: the triangle (Model::net_faces), or −1, and the touched
  /// point's barycentric weights on its nodes; `axis` is then the contact's unit normal (out of
  /// the tissue).
  int face = -1;
  Vec3 face_weights = Vec3::Zero();
  /// A held node's spring to a jaw (GraspThreadNode): the grasp (Data::grasps), or −1, and the
  /// held node (GraspState::thread_nodes) whose `force` this term's adds to.
  int grasp = -1;
  int grasp_node = -1;
  /// A kept contact (ThreadScratch::touched): a body sphere the segment has touched and not left
  /// by more than kThreadContactMargin since, not touching at this step's start: `force` is
  /// k d0 n with its gap d0 ≤ 0, `axis` its unit normal n. It enters Newton's system on the first
  /// iterate where it pushes (n · f(v) > 0: the point would end the step inside the sphere) and
  /// stays in it for the rest of the step (`engaged`: the matrix does not cycle between
  /// iterates), and it never pulls: its force is zero on an iterate where n · f(v) < 0
  /// (thread_step.cpp, term_acts(), term_force()).
  bool kept = false;
  bool engaged = false;  ///< A kept contact that has pushed on an iterate of this step.
};

/// A thread node's deepest contact with the nets' surfaces this step (thread_tissue_contact.cpp).
struct ThreadTissueHit {
  double depth = 0.0;           ///< Penetration of the node's sphere (m); 0: none.
  int face = -1;                ///< Model::net_faces index, or −1.
  int material = 0;             ///< The net's contact material (NetModel::material).
  Vec3 weights = Vec3::Zero();  ///< Barycentric weights of the touched point.
  Vec3 normal = Vec3::UnitZ();  ///< Unit, out of the tissue (world).
};

/// A contact with tissue as the thread's step left it, for the net's nodes (as ThreadEyeletTerm).
struct ThreadTissueTerm {
  int face = -1;                 ///< Model::net_faces index.
  Vec3 weights = Vec3::Zero();   ///< Barycentric weights of the touched point.
  Vec3 point = Vec3::Zero();     ///< The thread's node (world, m) at the step's end.
  Vec3 velocity = Vec3::Zero();  ///< Its velocity (world, m/s).
  Vec3 normal = Vec3::UnitZ();   ///< The contact's unit normal, out of the tissue (world).
  Vec3 force = Vec3::Zero();     ///< The contact's force on the thread (N, world).
  double stiffness = 0.0;        ///< Along the normal (N/m).
  double damping = 0.0;          ///< Along the normal (N·s/m).
};

/// A pair of non-adjacent segments that may touch within the step (their boxes swept from the
/// step's start to the first Newton iterate overlap): the nearest points' parameters and the
/// normal n0 from t's point to s's at the step's start, along which the pair is held apart.
struct ThreadSelfPair {
  int s = 0, t = 0;
  double us = 0.0, ut = 0.0;
  Vec3 normal = Vec3::UnitZ();
};

/// An eyelet's term as the thread's step left it: the thread's point and its velocity at the
/// step's end, the thread's axis there, the force on the thread, the friction's damping along it.
struct ThreadEyeletTerm {
  bool set = false;           ///< Written by this step (the eyelet active and its term applied).
  Vec3 point = Vec3::Zero();  ///< The thread's point (world, m).
  Vec3 velocity = Vec3::Zero();  ///< Its velocity (world, m/s).
  Vec3 axis = Vec3::UnitX();  ///< The thread's unit tangent there (world).
  Vec3 force = Vec3::Zero();  ///< The eyelet's force on the thread (N, world).
  double stiffness = 0.0;     ///< Across the axis (N/m).
  double damping = 0.0;       ///< Along the axis: friction's damping and the drag (N·s/m).
};

/// The scratch of one thread.
struct ThreadScratch {
  ThreadBand band;  ///< Blocks: 0 the start tie's point, 1 … nodes, nodes + 1 the end tie's.
  std::vector<ThreadPointTerm> terms;  ///< Capacity fixed at make_data().
  int num_terms = 0;
  std::vector<Vec3> saved_position;    ///< Rollback of a non-finite step.
  std::vector<Vec3> trial_position;    ///< Newton's iterate x_k = x0 + h v_k (m).
  std::vector<Vec3> trial_velocity;    ///< Newton's iterate v_k (m/s).
  /// An update from Newton's matrix with the compressed segments' part across whole, kept while
  /// the same iterate is solved with it dropped (thread_step.cpp): swapped with the band's
  /// right-hand side, so sized as it (blocks as the band's).
  std::vector<Vec3> whole_update;
  std::array<Vec3, 2> tie_delta{};     ///< The ties' points' velocity change so far (m/s).
  std::vector<std::int32_t> sweep_order;  ///< Self contact: segments sorted along sweep_axis.
  std::vector<Vec3> segment_min, segment_max;  ///< Self contact: each segment's swept box (m).
  /// Contacts with bodies: the box of each run of kThreadSegmentRun segments' nodes at the
  /// step's start (m; thread_contacts.cpp).
  std::vector<Vec3> run_min, run_max;
  /// Per segment, the body spheres (Model::body_spheres, −1: none) it touched, or kept, in the
  /// last step and in this one (kThreadTouchedSpheres each; more are not remembered).
  std::vector<std::array<int, kThreadTouchedSpheres>> touched_before, touched;
  std::vector<ThreadSelfPair> self_pairs;  ///< Capacity fixed at make_data().
  int num_self_pairs = 0;
  int sweep_axis = 0;
  /// Each eyelet's term at the step's end (ThreadState::eyelets; valid where `eyelet_term_set`):
  /// what its springs on tissue give the net's nodes (thread_tissue.cpp).
  std::array<ThreadEyeletTerm, kMaxThreadEyelets> eyelet_terms{};
  /// Contacts with tissue: per node its deepest hit, the nodes in order of their coordinate
  /// along the thread's longest axis (`tissue_key`), and the contacts as the step left them
  /// (the first num_tissue_terms), what their springs on the net's nodes take.
  std::vector<ThreadTissueHit> tissue_hits;
  std::vector<std::int32_t> tissue_order;
  std::vector<double> tissue_key;
  /// Per net node (global): its outcode against the thread's box grown by the contact's reach
  /// (per axis one bit for "below", one for "above"): a triangle whose three nodes share a bit is
  /// out of reach of every node of the thread.
  std::vector<std::uint8_t> net_node_outcode;
  std::array<ThreadTissueTerm, kMaxThreadTissueContacts> tissue_terms{};
  int num_tissue_terms = 0;
  /// Resizes for `thread` in a model of `model_nodes` net nodes and `graspers` graspers (their
  /// held nodes' springs: 2 kMaxGraspThreadNodes terms each) (load time).
  void resize(const ThreadModel& thread, int model_nodes, int graspers);
  /// Forgets the spheres the segments touched (a reset: no contact is kept into the first step).
  void forget_touches() noexcept {
    for (auto& t : touched_before) t.fill(-1);
    for (auto& t : touched) t.fill(-1);
  }
};

}  // namespace numen::core
