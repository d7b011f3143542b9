/// @file grasp_thread.cpp
/// A grasper's jaws closing on a thread (grasp/grasp_thread.hpp, docs/thread.md "The thread in
/// the jaws"): which segments both jaws touch, and which of their nodes the grasp holds. The
/// springs themselves are the thread's step's (thread/thread_grasp.cpp).

#include "grasp/grasp_thread.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <limits>
#include <utility>

#include "mesh/mesh_shape_query.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {
namespace {

/// A jaw's spheres in the world this step, as far as the search needs them: the box of their
/// reach (each sphere's centre ± its radius + the thread's), for a first cut.
struct JawReach {
  int body = -1;
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
};

JawReach jaw_reach(const Model& model, const Data& data, int body, double rt) noexcept {
  JawReach j;
  j.body = body;
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(body)];
  const BodyState& bs = data.bodies[static_cast<std::size_t>(body)];
  j.lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  j.hi = -j.lo;
  for (int k = bm.sphere_begin; k < bm.sphere_begin + bm.sphere_count; ++k) {
    const Sphere& sp = model.body_spheres[static_cast<std::size_t>(k)];
    const Vec3 c = bs.position + bs.orientation * sp.center;
    j.lo = j.lo.cwiseMin(c - Vec3::Constant(sp.radius + rt));
    j.hi = j.hi.cwiseMax(c + Vec3::Constant(sp.radius + rt));
  }
  return j;
}

/// Whether the segment [a, b] of a thread of radius rt touches a sphere of the jaw: the point
/// of the segment nearest the sphere's centre closer than its radius + rt.
bool jaw_touches(const Model& model, const Data& data, const JawReach& jaw, const Vec3& a, const Vec3& b,
                 double rt) noexcept {
  const Vec3 lo = a.cwiseMin(b), hi = a.cwiseMax(b);
  if ((hi.array() < jaw.lo.array()).any() || (lo.array() > jaw.hi.array()).any()) return false;
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(jaw.body)];
  const BodyState& bs = data.bodies[static_cast<std::size_t>(jaw.body)];
  const Vec3 d = b - a;
  for (int k = bm.sphere_begin; k < bm.sphere_begin + bm.sphere_count; ++k) {
    const Sphere& sp = model.body_spheres[static_cast<std::size_t>(k)];
    const Vec3 c = bs.position + bs.orientation * sp.center;
    const double u = detail::segment_parameter(a, b, c);
    const double reach = sp.radius + rt;
    if ((a + u * d - c).squaredNorm() < reach * reach) return true;
  }
  return false;
}

/// Whether both jaws touch segment s of the thread (its segments next to a tie to a jaw, and a
/// broken one, left out as the thread's contacts leave them out).
bool pinched(const Model& model, const Data& data, const ThreadModel& th, const ThreadState& ts,
             const std::array<JawReach, 2>& jaws, int s) noexcept {
  if (s == ts.broken_segment) return false;
  const auto i = static_cast<std::size_t>(s);
  for (const JawReach& j : jaws) {
    if ((th.tie_start.body == j.body && s < 3) || (th.tie_end.body == j.body && s >= th.segments - 3)) return false;
    if (!jaw_touches(model, data, j, ts.position[i], ts.position[i + 1], th.radius)) return false;
  }
  return true;
}

/// The nodes to hold, nearest to `centre` first: at most kMaxGraspThreadNodes, each once.
struct NearestNodes {
  std::array<int, kMaxGraspThreadNodes> node{};
  std::array<double, kMaxGraspThreadNodes> distance2{};
  int count = 0;
  void offer(int n, double d2) noexcept {
    for (int k = 0; k < count; ++k)
      if (node[static_cast<std::size_t>(k)] == n) return;
    if (count == kMaxGraspThreadNodes && !(d2 < distance2[kMaxGraspThreadNodes - 1])) return;
    int at = count < kMaxGraspThreadNodes ? count++ : kMaxGraspThreadNodes - 1;
    for (; at > 0 && distance2[static_cast<std::size_t>(at - 1)] > d2; --at) {
      node[static_cast<std::size_t>(at)] = node[static_cast<std::size_t>(at - 1)];
      distance2[static_cast<std::size_t>(at)] = distance2[static_cast<std::size_t>(at - 1)];
    }
    node[static_cast<std::size_t>(at)] = n;
    distance2[static_cast<std::size_t>(at)] = d2;
  }
};

}  // namespace

bool take_thread(const Model& model, const Data& data, const GraspModel& g, GraspState& st) noexcept {
  for (std::size_t t = 0; t < model.threads.size() && t < data.threads.size(); ++t) {
    const ThreadModel& th = model.threads[t];
    const ThreadState& ts = data.threads[t];
    if (ts.position.size() != static_cast<std::size_t>(th.segments + 1)) continue;
    const std::array<JawReach, 2> jaws{jaw_reach(model, data, g.jaws[0], th.radius),
                                       jaw_reach(model, data, g.jaws[1], th.radius)};
    Vec3 centre = Vec3::Zero();
    int count = 0;
    for (int s = 0; s < th.segments; ++s) {
      if (!pinched(model, data, th, ts, jaws, s)) continue;
      centre += 0.5 * (ts.position[static_cast<std::size_t>(s)] + ts.position[static_cast<std::size_t>(s + 1)]);
      ++count;
    }
    if (count == 0) continue;
    centre /= static_cast<double>(count);
    NearestNodes nearest;
    for (int s = 0; s < th.segments; ++s) {
      if (!pinched(model, data, th, ts, jaws, s)) continue;
      for (const int n : {s, s + 1})
        nearest.offer(n, (ts.position[static_cast<std::size_t>(n)] - centre).squaredNorm());
    }
    // Held in the thread's order (insertion sort of at most kMaxGraspThreadNodes).
    std::array<int, kMaxGraspThreadNodes> nodes = nearest.node;
    for (int p = 1; p < nearest.count; ++p)
      for (int q = p; q > 0 && nodes[static_cast<std::size_t>(q - 1)] > nodes[static_cast<std::size_t>(q)]; --q)
        std::swap(nodes[static_cast<std::size_t>(q - 1)], nodes[static_cast<std::size_t>(q)]);
    st.num_thread_nodes = 0;
    for (int k = 0; k < nearest.count; ++k) {
      const int n = nodes[static_cast<std::size_t>(k)];
      GraspThreadNode& held = st.thread_nodes[static_cast<std::size_t>(st.num_thread_nodes++)];
      held.node = n;
      for (std::size_t j = 0; j < 2; ++j) {
        const BodyState& js = data.bodies[static_cast<std::size_t>(g.jaws[j])];
        held.jaw_points[j] = js.orientation.conjugate() * (ts.position[static_cast<std::size_t>(n)] - js.position);
      }
      held.force.setZero();
    }
    st.thread = static_cast<int>(t);
    return true;
  }
  return false;
}

}  // namespace numen::core
