/// @file data.cpp
/// Allocation and reset of core::Data.

#include "numen/core/data.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "scratch/data_scratch.hpp"
#include "numen/core/capacity.hpp"
#include "numen/core/features.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step_outputs.hpp"
#include "numen/core/step_stages.hpp"
#include "model/node_contact_copy.hpp"

namespace numen::core {
namespace {

/// Nodes at their rest positions on their rigid component's current pose,
/// moving with it (rigid-body point velocities); no warm start.
void reset_nodes(const Model& model, Data& data) noexcept {
  for (std::size_t i = 0; i < data.nodes.size(); ++i) {
    const NetModel& net = model.nets[static_cast<std::size_t>(model.node_net[i])];
    const BodyState& b = data.bodies[static_cast<std::size_t>(net.body)];
    const Vec3 lever = b.orientation * model.node_rest[i];
    data.nodes[i].position = b.position + lever;
    data.nodes[i].velocity = b.linear_velocity + b.angular_velocity.cross(lever);
  }
  for (Vec3& d : data.scratch->net.delta) d.setZero();
}

}  // namespace

DataScratchPtr::DataScratchPtr() noexcept = default;

DataScratchPtr::DataScratchPtr(std::unique_ptr<DataScratch> scratch) noexcept
    : scratch_(std::move(scratch)) {}

DataScratchPtr::DataScratchPtr(const DataScratchPtr& other)
    : scratch_(other.scratch_ ? std::make_unique<DataScratch>(*other.scratch_) : nullptr) {}

DataScratchPtr& DataScratchPtr::operator=(const DataScratchPtr& other) {
  if (this == &other) return *this;
  if (!other.scratch_)
    scratch_.reset();
  else if (scratch_)
    *scratch_ = *other.scratch_;  // element-wise: the buffers keep their capacity
  else
    scratch_ = std::make_unique<DataScratch>(*other.scratch_);
  return *this;
}

DataScratchPtr::DataScratchPtr(DataScratchPtr&& other) noexcept = default;
DataScratchPtr& DataScratchPtr::operator=(DataScratchPtr&& other) noexcept = default;
DataScratchPtr::~DataScratchPtr() = default;

Data make_data(const Model& model, const DataOptions& options) {
  // The stage plan is computed once, by finalize_model(); step() only reads it.
  if (model.stage_plan == 0)
    throw std::invalid_argument(
        "make_data: the model has no stage plan (Model::stage_plan 0): finalize_model() has not "
        "accepted it");
  if (const std::uint32_t current = compiled_stages(model); model.stage_plan != current)
    throw std::invalid_argument(
        "make_data: the model's stage plan is stale (Model::stage_plan " +
        std::to_string(model.stage_plan) + ", the model now compiles to " +
        std::to_string(current) + "): call finalize_model() again after editing the model");
  Data data;
  data.scratch = DataScratchPtr(std::make_unique<DataScratch>());
  DataScratch& scratch = *data.scratch;
  const auto n = static_cast<std::size_t>(model.num_bodies());
  data.bodies.resize(n);
  data.nodes.resize(static_cast<std::size_t>(model.num_nodes()));
  // Room for the penalty contacts (detection stops at kMaxNodeContacts), the held nodes'
  // grasp springs after them (grasp.hpp), the needles' puncture ties (needle_puncture.hpp) and the
  // threads' eyelets on tissue and contacts with it (thread.hpp).
  data.node_contacts.resize(model.num_nodes() > 0
                                ? static_cast<std::size_t>(kMaxNodeContacts +
                                                           model.num_grasps() * kMaxGraspNodes * kGraspSpringsPerNode +
                                                           model.num_needles() * kMaxNeedlePunctures * kNeedleTieSprings +
                                                           model.num_threads() * (kMaxThreadEyelets * kThreadEyeletTieSprings +
                                                                                  kMaxThreadTissueContacts * kThreadTissueContactSprings))
                                : 0);
  data.needles.resize(static_cast<std::size_t>(model.num_needles()));
  data.nets.resize(static_cast<std::size_t>(model.num_nets()));
  data.grasps.resize(static_cast<std::size_t>(model.num_grasps()));
  data.applied_wrench.resize(n);
  data.body_wrench.resize(n);
  data.body_targets.resize(n);
  data.feedback_group.assign(n, 0);
  data.feedback_point.assign(model.extra_feedback.size() + 1,
                             Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  data.body_feedback.resize(n);
  data.joint_prescribed.resize(static_cast<std::size_t>(model.num_joints()));
  data.joints.resize(static_cast<std::size_t>(model.num_joints()));
  // Tree-solve scratch only with joints: without, step() runs no tree solve.
  if constexpr (kWithArticulation)
    if (model.num_joints() > 0) scratch.articulation.resize(model);
  scratch.collision.resize(model);
  scratch.solver.resize(model, options.written_contacts);
  if constexpr (kWithDeformable) {
    scratch.net.resize(model);  // empty without nets
    // The arrowhead preconditioner's contacts by node (joints only; net_scratch.hpp).
    scratch.net.node_contact_next.assign(model.joints.empty() ? 0 : data.node_contacts.size(), -1);
  }
  data.threads.resize(model.threads.size());  // thread.hpp
  data.thread_reactions.resize(model.threads.empty() ? 0 : n);
  scratch.threads.resize(model.threads.size());
  for (std::size_t i = 0; i < model.threads.size(); ++i) {
    const auto nodes = static_cast<std::size_t>(model.threads[i].segments + 1);
    data.threads[i].position.resize(nodes);
    data.threads[i].velocity.resize(nodes);
    data.threads[i].external_force.resize(nodes);
    scratch.threads[i].resize(model.threads[i], model.num_nodes(), model.num_grasps());
  }
  reset_data(model, data);
  return data;
}

void reset_data(const Model& model, Data& data) noexcept {
  data.time = 0.0;
  data.step_count = 0;
  for (std::size_t b = 0; b < data.bodies.size(); ++b) {
    const BodyModel& bm = model.bodies[b];
    BodyState& s = data.bodies[b];
    s.position = bm.initial_pose.position;
    s.orientation = bm.initial_pose.orientation;
    s.linear_velocity = bm.initial_twist.linear;
    s.angular_velocity = bm.initial_twist.angular;
    data.applied_wrench[b] = Wrench{};
    data.body_wrench[b] = Wrench{};
    data.body_targets[b] = BodyTarget{};
    data.body_feedback[b] = Wrench{};
  }
  data.device_wrench = Wrench{};
  reset_nodes(model, data);
  for (std::size_t i = 0; i < data.threads.size(); ++i) {
    reset_thread(model.threads[i], data.threads[i]);
    data.scratch->threads[i].forget_touches();
  }
  for (Wrench& w : data.thread_reactions) w = Wrench{};
  for (JointPrescription& p : data.joint_prescribed) p = JointPrescription{};
  for (JointState& j : data.joints) j = JointState{};
  for (Vec6& v : data.scratch->solver.delta) v.setZero();  // Δu_prev of the joint rows (joint_system.hpp)
  data.max_joint_drift = 0.0;
  data.max_joint_angle_drift = 0.0;
  data.held_body = model.initial_held_body;
  if (data.held_body >= 0) {
    const BodyState& s = data.bodies[static_cast<std::size_t>(data.held_body)];
    data.target = Pose{s.position, s.orientation};
    data.target_twist = Twist{s.linear_velocity, s.angular_velocity};
  } else {
    data.target = Pose{};
    data.target_twist = Twist{};
  }
  data.num_contacts = 0;
  data.num_node_contacts = 0;
  data.num_node_grasp_springs = 0;
  data.num_node_needle_ties = 0;
  data.num_node_thread_ties = 0;
  for (NeedleState& n : data.needles) n = NeedleState{};
  for (NetOutput& o : data.nets) o = NetOutput{};
  for (GraspState& g : data.grasps) g = GraspState{};
  data.contacts_dropped = 0;
  data.contact_overflow_steps = 0;
  data.net_crossed_steps = 0;
  data.crossed_contacts = 0;
  data.crossed_contact_steps = 0;
  data.pass_throughs = 0;
  data.scratch->collision.num_pairs = 0;  // no contact remembered (collision.hpp, "Crossing")
  data.scratch->collision.num_pairs_prev = 0;
  data.contacts_clamped = 0;
  data.contact_clamped_steps = 0;
  data.max_penetration = 0.0;
  data.coupling_wrench = Wrench{};
  data.feedback_wrench = Wrench{};
  data.solver_iterations = 0;
  data.solver_residual = 0.0;
  data.status = kStepOk;
  data.stages_run = 0;
  data.nonfinite_steps = 0;
  data.invalid_target_steps = 0;
}

// One copy of a Data's state and outputs (step_outputs.hpp).
namespace {

/// Every field of `to` but the joints, from a Data or a StepOutputs.
template <typename From>
void copy_all_but_joints(const From& from, StepOutputs& to) noexcept {
  std::copy_n(from.bodies.begin(), std::min(to.bodies.size(), from.bodies.size()),
              to.bodies.begin());
  to.num_contacts = std::clamp(from.num_contacts, 0, kMaxContacts);
  std::copy_n(from.contacts.begin(), to.num_contacts, to.contacts.begin());
  to.contacts_dropped = from.contacts_dropped;
  to.contacts_clamped = from.contacts_clamped;
  to.contact_overflow_steps = from.contact_overflow_steps;
  to.contact_clamped_steps = from.contact_clamped_steps;
  to.net_crossed_steps = from.net_crossed_steps;
  to.crossed_contact_steps = from.crossed_contact_steps;
  to.pass_throughs = from.pass_throughs;
  to.nonfinite_steps = from.nonfinite_steps;
  to.status = from.status;
  to.stages_run = from.stages_run;
  to.solver_iterations = from.solver_iterations;
  to.solver_residual = from.solver_residual;
  to.max_joint_drift = from.max_joint_drift;
  to.max_joint_angle_drift = from.max_joint_angle_drift;
  std::copy_n(from.nodes.begin(), std::min(to.nodes.size(), from.nodes.size()), to.nodes.begin());
  detail::copy_node_contacts(from, to);
  std::copy_n(from.nets.begin(), std::min(to.nets.size(), from.nets.size()), to.nets.begin());
  std::copy_n(from.needles.begin(), std::min(to.needles.size(), from.needles.size()), to.needles.begin());
  for (std::size_t i = 0; i < to.threads.size() && i < from.threads.size(); ++i)
    copy_thread_state(from.threads[i], to.threads[i]);
}

}  // namespace

StepOutputs make_step_outputs(const Data& data, std::size_t num_joints) {
  StepOutputs o;
  o.bodies = data.bodies;
  o.joints.assign(num_joints, JointState{});
  o.nodes = data.nodes;
  o.node_contacts.assign(data.node_contacts.size(), NodeContact{});
  o.nets = data.nets;
  o.needles = data.needles;
  o.threads = data.threads;
  return o;
}

void copy_outputs(const Data& from, StepOutputs& to) noexcept {
  copy_all_but_joints(from, to);
  std::copy_n(from.joints.begin(), std::min(to.joints.size(), from.joints.size()),
              to.joints.begin());
}

void copy_outputs(const Data& from, std::span<const int> joint_index, StepOutputs& to) noexcept {
  copy_all_but_joints(from, to);
  for (std::size_t j = 0; j < joint_index.size() && j < from.joints.size(); ++j) {
    const auto sj = static_cast<std::size_t>(joint_index[j]);
    if (sj < to.joints.size()) to.joints[sj] = from.joints[j];
  }
}

void copy_outputs(const StepOutputs& from, StepOutputs& to) noexcept {
  copy_all_but_joints(from, to);
  std::copy_n(from.joints.begin(), std::min(to.joints.size(), from.joints.size()),
              to.joints.begin());
}

}  // namespace numen::core
