/// @file thread_grasp.cpp
/// A thread in a grasper's jaws, on the thread's side (thread/thread_terms.hpp; grasp.hpp
/// GraspThreadNode; docs/thread.md "The thread in the jaws"): each held node's springs to the
/// jaws as point terms of the thread's implicit step. Which nodes are held is the grasp stage's
/// (grasp/grasp_thread.cpp).

#include <cstddef>

#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {

void gather_thread_grasps(const Model& model, Data& data, int index, ThreadState& st,
                          ThreadScratch& scratch) noexcept {
  const int last = static_cast<int>(st.position.size()) - 1;
  for (std::size_t i = 0; i < model.grasps.size() && i < data.grasps.size(); ++i) {
    GraspState& gs = data.grasps[i];
    if (gs.thread != index) continue;
    const GraspModel& g = model.grasps[i];
    const double k = 0.5 * g.stiffness, c = 0.5 * g.damping;  // per jaw
    for (int h = 0; h < gs.num_thread_nodes; ++h) {
      GraspThreadNode& held = gs.thread_nodes[static_cast<std::size_t>(h)];
      held.force.setZero();
      if (held.node < 0 || held.node > last) continue;
      const auto n = static_cast<std::size_t>(held.node);
      for (std::size_t j = 0; j < 2; ++j) {
        const BodyState& jaw = data.bodies[static_cast<std::size_t>(g.jaws[j])];
        const Vec3 r = jaw.orientation * held.jaw_points[j];
        const Vec3 p = jaw.position + r;
        const Vec3 v_p = jaw.linear_velocity + jaw.angular_velocity.cross(r);
        ThreadPointTerm* term = next_thread_term(scratch, st);
        if (term == nullptr) return;  // make_data() gave them room: not reached
        term->a = term->b = held.node + 1;
        term->stiffness = k * Mat3::Identity();
        term->damping = c * Mat3::Identity();
        // At the step's end k (p + h v_p − x0 − h v) + c (v_p − v): this force at the start,
        // −h k (v − v_p) − c (v − v0) over the step (point_term_force()).
        term->force = k * (p - st.position[n]) + c * (v_p - st.velocity[n]);
        term->target_velocity = v_p;
        term->body = g.jaws[j];
        term->point = p;
        term->grasp = static_cast<int>(i);
        term->grasp_node = h;
      }
    }
  }
}

const GraspState* jaw_holding_thread(const Model& model, const Data& data, int index, int body) noexcept {
  for (std::size_t i = 0; i < model.grasps.size() && i < data.grasps.size(); ++i) {
    const GraspState& gs = data.grasps[i];
    if (gs.thread == index && (model.grasps[i].jaws[0] == body || model.grasps[i].jaws[1] == body)) return &gs;
  }
  return nullptr;
}

bool next_to_held_node(const GraspState& hold, int segment) noexcept {
  for (int h = 0; h < hold.num_thread_nodes; ++h) {
    const int n = hold.thread_nodes[static_cast<std::size_t>(h)].node;
    if (n == segment || n == segment + 1) return true;
  }
  return false;
}

}  // namespace numen::core
