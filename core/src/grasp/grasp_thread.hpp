#pragma once
/// @file grasp_thread.hpp
/// The grasp stage's search for a thread between a grasper's jaws (grasp.hpp, GraspThreadNode;
/// docs/thread.md "The thread in the jaws"). Private to numen::core.

namespace numen::core {

struct Model;
struct Data;
struct GraspModel;
struct GraspState;

/// Looks for a thread both jaws of `g` touch this step: a segment is touched by a jaw when it is
/// within the thread's radius of one of the jaw's spheres (the thread's own contact test, the
/// segments next to a tie to that jaw left out, and a broken segment). In the first thread (in
/// Model::threads order) with segments touched by both jaws, holds the nodes of those segments
/// (up to kMaxGraspThreadNodes, the nearest to the mean of their midpoints first), each at its
/// place in both jaws' frames; sets GraspState::thread, num_thread_nodes, thread_nodes (by node
/// index) and returns true. Returns false and changes nothing when no thread is pinched. No
/// allocation.
bool take_thread(const Model& model, const Data& data, const GraspModel& g, GraspState& st) noexcept;

}  // namespace numen::core
