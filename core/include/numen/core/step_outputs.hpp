#pragma once
/// @file step_outputs.hpp
/// One copy of a Data's state and outputs at a step's end (StepOutputs), kept beside Data for a
/// reader that must not read the Data itself: the multirate god-object's scene loop hands one to
/// the device loop in each MultirateSceneReport, from which the device loop writes the
/// single-rate view (docs/multirate.md). Sized once by make_step_outputs(); copy_outputs()
/// copies without allocating.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/net_state.hpp"
#include "numen/core/types.hpp"

namespace numen::core {

/// A Data's bodies, joints and net nodes, and what its step wrote: contacts, their counters,
/// status, solver figures, joint drift, node contacts, the nets' outputs and the needles'
/// passages (the fields of Data of the same names).
struct StepOutputs {
  std::vector<BodyState> bodies;
  std::vector<JointState> joints;
  std::array<Contact, kMaxContacts> contacts{};  ///< [0, num_contacts) valid.
  int num_contacts = 0;
  int contacts_dropped = 0;
  int contacts_clamped = 0;
  std::int64_t contact_overflow_steps = 0;
  std::int64_t contact_clamped_steps = 0;
  std::int64_t net_crossed_steps = 0;
  std::int64_t crossed_contact_steps = 0;
  std::int64_t pass_throughs = 0;
  std::int64_t nonfinite_steps = 0;
  std::uint32_t status = 0;
  std::uint32_t stages_run = 0;
  int solver_iterations = 0;
  double solver_residual = 0.0;
  double max_joint_drift = 0.0;
  double max_joint_angle_drift = 0.0;
  std::vector<NodeState> nodes;
  /// [0, num_node_contacts) valid, then the held node springs (the grasps', the needles' ties,
  /// the threads' eyelets: Data::num_node_grasp_springs and the rest), as in Data.
  std::vector<NodeContact> node_contacts;
  int num_node_contacts = 0;
  int num_node_grasp_springs = 0;
  int num_node_needle_ties = 0;
  int num_node_thread_ties = 0;
  std::vector<NetOutput> nets;
  std::vector<NeedleState> needles;  ///< Per needle (Model::needles): its passage (needle_puncture.hpp).
  std::vector<ThreadState> threads;  ///< Per thread (Model::threads): its nodes and outputs (thread.hpp).
};

/// A StepOutputs sized for `data` with `num_joints` joints: its bodies, nodes, nets, needles and threads copied
/// from `data`, its joints, node contacts (as many as `data` has room for) and the rest zero.
/// Load time: allocates.
StepOutputs make_step_outputs(const Data& data, std::size_t num_joints);

/// Copies `from` into `to`: every field, the vectors over the smaller of the two sizes, the
/// contacts and node contacts [0, count) within the room of both. No allocation.
void copy_outputs(const Data& from, StepOutputs& to) noexcept;
/// The same, but `from`'s joint j is `to`'s joint `joint_index[j]` (a Data of a model that
/// holds only some of the joints); `to`'s other joints are left as they are.
void copy_outputs(const Data& from, std::span<const int> joint_index, StepOutputs& to) noexcept;
/// The same from another copy.
void copy_outputs(const StepOutputs& from, StepOutputs& to) noexcept;

}  // namespace numen::core
