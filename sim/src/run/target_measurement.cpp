/// @file target_measurement.cpp
/// The run's measurement of the target (target_measurement.hpp): on a ghost Data, inline or on
/// a thread of its own.

#include "numen/sim/run/target_measurement.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cstddef>

#include "numen/core/collision.hpp"
#include "numen/core/features.hpp"
#include "numen/core/net_collision.hpp"

#include "contact_depths.hpp"

namespace numen::sim {
namespace {

/// The ghost's nodes (the undeformed tool where the hand is, and what the hand would meet): the
/// nodes of the nets whose rigid component belongs to articulation `tree` at their rest
/// positions on that body's pose in `ghost`, those of the anchored bodies' nets (the organs,
/// undeformed) at their rest positions — written once (`organs_placed`): an anchored body never
/// moves — and the other nets' as the loop had them (`nodes`: TargetInputs::nodes). O(the nodes of the tool's and the other nets):
/// an organ's nodes cost nothing per period.
void place_ghost_nodes(const core::Model& model, const std::vector<core::NodeState>& nodes,
                       core::Data& ghost, int tree, bool& organs_placed) {
  for (const core::NetModel& net : model.nets) {
    const bool organ = model.bodies[static_cast<std::size_t>(net.body)].anchored;
    const bool tool = model.articulation.body_tree[static_cast<std::size_t>(net.body)] == tree;
    const auto begin = static_cast<std::size_t>(net.node_begin);
    const auto end = begin + static_cast<std::size_t>(net.node_count);
    if (!organ && !tool) {
      std::copy(nodes.begin() + static_cast<std::ptrdiff_t>(begin),
                nodes.begin() + static_cast<std::ptrdiff_t>(end),
                ghost.nodes.begin() + static_cast<std::ptrdiff_t>(begin));
      continue;
    }
    if (organ && organs_placed) continue;
    const core::BodyState& b = ghost.bodies[static_cast<std::size_t>(net.body)];
    for (std::size_t n = begin; n < end; ++n) {
      ghost.nodes[n].position = b.position + b.orientation * model.node_rest[n];
      ghost.nodes[n].velocity.setZero();
    }
  }
  organs_placed = true;
}

/// Whether `model` has a net on a body that is not anchored (a tool's or a free body's): its
/// nodes move with the loop's state and the measurement reads them.
bool has_moving_nets(const core::Model& model) {
  for (const core::NetModel& net : model.nets)
    if (!model.bodies[static_cast<std::size_t>(net.body)].anchored) return true;
  return false;
}

}  // namespace

TargetInputs make_target_inputs(const core::Model& model) {
  const core::Data data = core::make_data(model);
  TargetInputs in;
  in.bodies = data.bodies;
  in.body_targets = data.body_targets;
  if (has_moving_nets(model)) in.nodes = data.nodes;
  in.hand_pose.assign(data.bodies.size(), core::Pose{});
  in.hand_bound.assign(data.bodies.size(), 0);
  return in;
}

TargetMeasurement::TargetMeasurement(const core::Model& model)
    : model_(&model), ghost_(core::make_data(model)) {}

TargetContacts TargetMeasurement::measure(const TargetInputs& in) noexcept {
  const core::Model& model = *model_;
  const auto h = static_cast<std::size_t>(in.held);
  const int tree = in.tree;
  TargetContacts c;
  // The target: the tool's bodies placed where the device puts them (held body at
  // data.target, the others at their own targets, Eq. 6).
  ghost_.bodies = in.bodies;  // same size: no allocation
  ghost_.bodies[h].position = in.target.position;
  ghost_.bodies[h].orientation = in.target.orientation;
  for (std::size_t b = 0; b < in.bodies.size(); ++b) {
    const core::BodyTarget& bt = in.body_targets[b];
    if (b == h || !bt.enabled) continue;
    ghost_.bodies[b].position = bt.pose.position;
    ghost_.bodies[b].orientation = bt.pose.orientation;
  }
  core::detect_contacts(model, ghost_);
  for (int b = 0; b < model.num_bodies(); ++b) {
    if (model.articulation.body_tree[static_cast<std::size_t>(b)] != tree) continue;
    int m = 0;
    c.target_pen = std::max(c.target_pen, detail::deepest_contact_of(ghost_, b, &m));
    c.target_contacts += m;
  }
  c.hand_pen = c.target_pen;  // replay: the encoders read the hand
  if (in.closed_loop) {
    // Closed loop: the tool's bodies where the hand means to be (each bound body at its
    // link's pose at the intent's axis values), the rest as above.
    for (std::size_t b = 0; b < in.bodies.size(); ++b) {
      if (in.hand_bound[b] == 0) continue;
      ghost_.bodies[b].position = in.hand_pose[b].position;
      ghost_.bodies[b].orientation = in.hand_pose[b].orientation;
    }
    core::detect_contacts(model, ghost_);
    c.hand_pen = 0.0;
    for (int b = 0; b < model.num_bodies(); ++b)
      if (model.articulation.body_tree[static_cast<std::size_t>(b)] == tree)
        c.hand_pen = std::max(c.hand_pen, detail::deepest_contact_of(ghost_, b));
  }
  if (model.num_nets() > 0) {
    // The tool's nets in their rest shape on the target poses, and the target's tool on the
    // organs' rest shapes (what the hand would meet).
    place_ghost_nodes(model, in.nodes, ghost_, tree, organs_placed_);
    if constexpr (core::kWithDeformable) core::detect_node_contacts(model, ghost_);
    int m = 0;
    c.target_pen =
        std::max(c.target_pen, detail::deepest_node_contact_of_tree(model, ghost_, tree, &m));
    c.target_contacts += m;
    const double organ = detail::deepest_tool_contact_on_nets(model, ghost_, tree, &m);
    c.target_pen = std::max(c.target_pen, organ);
    c.target_contacts += m;
    c.hand_pen = std::max(c.hand_pen, organ);
  }
  return c;
}

TargetMeasurementThread::TargetMeasurementThread(const core::Model& model)
    : measurement_(model), in_(make_target_inputs(model)) {}

TargetMeasurementThread::~TargetMeasurementThread() { stop(); }

bool TargetMeasurementThread::start(const std::vector<int>& avoid_cpus) {
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
  if (avoid_cpus.empty()) return false;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) return false;  // the process's CPUs
  for (const int c : avoid_cpus)
    if (c >= 0 && c < CPU_SETSIZE) CPU_CLR(c, &set);
  if (CPU_COUNT(&set) == 0) return false;  // nothing left: the scheduler's choice
  return pthread_setaffinity_np(thread_.native_handle(), sizeof(set), &set) == 0;
}

void TargetMeasurementThread::stop() noexcept {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

void TargetMeasurementThread::submit() noexcept {
  in_.publish();
  submitted_.fetch_add(1, std::memory_order_relaxed);
}

const TargetContacts& TargetMeasurementThread::latest() noexcept {
  out_.acquire();
  return out_.front();
}

void TargetMeasurementThread::run() noexcept {
  const timespec poll{0, static_cast<long>(kPollNs)};
  while (!stop_.load(std::memory_order_relaxed)) {
    if (!in_.acquire()) {
      nanosleep(&poll, nullptr);
      continue;
    }
    out_.back() = measurement_.measure(in_.front());
    out_.publish();
    measured_.fetch_add(1, std::memory_order_relaxed);
  }
}

}  // namespace numen::sim
