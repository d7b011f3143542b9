/// @file thread_contacts.cpp
/// A thread's contacts with the bodies' spheres, the static obstacles and itself, and its
/// eyelets, as point terms of its implicit step (thread/thread_terms.hpp).

#include <algorithm>
#include <cmath>

#include "contact/collision_query.hpp"
#include "contact/narrowphase.hpp"
#include "mesh/mesh_shape_query.hpp"
#include "scratch/data_scratch.hpp"
#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"
#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {
namespace {

using detail::segment_parameter;  // mesh/mesh_shape_query.hpp

/// Nearest points of segments [p1, q1] and [p2, q2]: parameters s, t (Ericson, "Real-Time
/// Collision Detection", 2005, §5.1.9).
void segment_segment(const Vec3& p1, const Vec3& q1, const Vec3& p2, const Vec3& q2, double& s,
                     double& t) noexcept {
  const Vec3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double c = d1.dot(r), b = d1.dot(d2);
  const double denom = a * e - b * b;
  s = denom > 1e-30 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  t = e > 0.0 ? (b * s + f) / e : 0.0;
  if (t < 0.0) {
    t = 0.0;
    s = a > 0.0 ? std::clamp(-c / a, 0.0, 1.0) : 0.0;
  } else if (t > 1.0) {
    t = 1.0;
    s = a > 0.0 ? std::clamp((b - c) / a, 0.0, 1.0) : 0.0;
  }
}

/// The thread point w_a x_a + w_b x_b of segment s at parameter u, and its velocity.
struct SegmentPoint {
  Vec3 x, v;
};
SegmentPoint segment_point(const ThreadState& st, int s, double u) noexcept {
  const auto i = static_cast<std::size_t>(s);
  return {(1.0 - u) * st.position[i] + u * st.position[i + 1],
          (1.0 - u) * st.velocity[i] + u * st.velocity[i + 1]};
}

void set_segment_blocks(ThreadPointTerm& term, int s, double u) noexcept {
  term.a = s + 1;
  term.b = s + 2;
  term.wa = 1.0 - u;
  term.wb = u;
}

}  // namespace

ThreadPointTerm* next_thread_term(ThreadScratch& scratch, ThreadState& state) noexcept {
  if (scratch.num_terms >= static_cast<int>(scratch.terms.size())) {
    ++state.output.contacts_dropped;
    return nullptr;
  }
  ThreadPointTerm& t = scratch.terms[static_cast<std::size_t>(scratch.num_terms++)];
  t = ThreadPointTerm{};
  return &t;
}

void fill_contact(ThreadPointTerm& term, const MaterialPair& mp, double stiffness, double depth,
                  const Vec3& n, const Vec3& v_rel) noexcept {
  const Mat3 nn = n * n.transpose();
  const double vn = v_rel.dot(n);
  const double elastic = stiffness * depth;
  const bool damped = elastic - mp.damping * vn > 0.0;
  const double fn = damped ? elastic - mp.damping * vn : elastic;
  term.stiffness = stiffness * nn;
  term.damping = (damped ? mp.damping : 0.0) * nn + mp.friction * (Mat3::Identity() - nn);
  term.force = fn * n - mp.friction * (v_rel - vn * n);
}

void gather_thread_body_contacts(const Model& model, const Data& data, int index, const ThreadModel& thread,
                                 ThreadState& st, ThreadScratch& scratch) noexcept {
  const int segs = thread.segments;
  const double rt = thread.radius;
  // The box of each run of kThreadSegmentRun segments (its nodes), and the thread's.
  const int runs = (segs + kThreadSegmentRun - 1) / kThreadSegmentRun;
  for (int r = 0; r < runs; ++r) {
    const int end = std::min(segs, (r + 1) * kThreadSegmentRun);
    Vec3 rlo = st.position[static_cast<std::size_t>(r * kThreadSegmentRun)], rhi = rlo;
    for (int i = r * kThreadSegmentRun + 1; i <= end; ++i) {
      rlo = rlo.cwiseMin(st.position[static_cast<std::size_t>(i)]);
      rhi = rhi.cwiseMax(st.position[static_cast<std::size_t>(i)]);
    }
    scratch.run_min[static_cast<std::size_t>(r)] = rlo;
    scratch.run_max[static_cast<std::size_t>(r)] = rhi;
  }
  std::swap(scratch.touched_before, scratch.touched);
  for (auto& t : scratch.touched) t.fill(-1);
  Vec3 lo = scratch.run_min[0], hi = scratch.run_max[0];
  for (int r = 1; r < runs; ++r) {
    lo = lo.cwiseMin(scratch.run_min[static_cast<std::size_t>(r)]);
    hi = hi.cwiseMax(scratch.run_max[static_cast<std::size_t>(r)]);
  }
  for (int b = 0; b < model.num_bodies(); ++b) {
    const BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const BodyState& bs = data.bodies[static_cast<std::size_t>(b)];
    const Mat3 rot = bs.orientation.toRotationMatrix();
    // Anchored or imposed (kDirect, and a multirate scene loop's god-object): infinitely heavy.
    const bool imposed = bm.anchored || data.scratch->solver.imposed[static_cast<std::size_t>(b)] != 0;
    const int first = thread.tie_start.body == b ? 3 : 0;
    const int last = thread.tie_end.body == b ? segs - 3 : segs;
    const MaterialPair& mp = model.material_pair(thread.material, bm.material);
    const GraspState* hold = jaw_holding_thread(model, data, index, b);  // a jaw holding the thread
    for (int k = bm.sphere_begin; k < bm.sphere_begin + bm.sphere_count; ++k) {
      const Sphere& sp = model.body_spheres[static_cast<std::size_t>(k)];
      const Vec3 c = bs.position + rot * sp.center;
      // The true sphere: a multirate scene loop grows the god-object's by its margin.
      const double radius = sp.radius - bm.sphere_margin;
      const double reach = radius + rt;
      const double candidate_reach = reach + kThreadContactMargin;
      // The thread, a run, then a segment, whose bounds miss the sphere's is out of its reach
      // (the test below would leave it): the bounds first, cheaper. The segments in their order.
      const Vec3 r3 = Vec3::Constant(candidate_reach);
      const Vec3 sphere_lo = c - r3, sphere_hi = c + r3;
      if (!collision_detail::boxes_overlap(lo, hi, sphere_lo, sphere_hi)) continue;
      for (int s = std::max(first, 0); s < last; ++s) {
        if (s % kThreadSegmentRun == 0) {
          const auto run = static_cast<std::size_t>(s / kThreadSegmentRun);
          if (!collision_detail::boxes_overlap(scratch.run_min[run], scratch.run_max[run], sphere_lo, sphere_hi)) {
            s += kThreadSegmentRun - 1;  // the run's last segment: the loop's ++s starts the next run
            continue;
          }
        }
        if (hold != nullptr && next_to_held_node(*hold, s)) continue;
        const auto i = static_cast<std::size_t>(s);
        const Vec3& xa = st.position[i];
        const Vec3& xb = st.position[i + 1];
        if (!collision_detail::boxes_overlap(xa.cwiseMin(xb), xa.cwiseMax(xb), sphere_lo, sphere_hi)) continue;
        const double u = segment_parameter(st.position[i], st.position[i + 1], c);
        const SegmentPoint p = segment_point(st, s, u);
        const Vec3 d = p.x - c;
        const double dist2 = d.squaredNorm();
        if (dist2 >= candidate_reach * candidate_reach) continue;
        const bool touching = dist2 < reach * reach;
        auto& before = scratch.touched_before[static_cast<std::size_t>(s)];
        if (!touching && std::find(before.begin(), before.end(), k) == before.end()) continue;
        auto& now = scratch.touched[static_cast<std::size_t>(s)];
        if (auto slot = std::find(now.begin(), now.end(), -1); slot != now.end()) *slot = k;
        const double dist = std::sqrt(dist2);
        const Vec3 n = dist2 > kDegenerateDistance2 ? Vec3(d / dist) : Vec3::UnitZ();
        const Vec3 r = c + radius * n - bs.position;  // lever arm of the contact point
        const Vec3 vb = bs.linear_velocity + bs.angular_velocity.cross(r);
        const double m_eff = contact_effective_mass(bm, bs, r, imposed, nullptr, nullptr,
                                                    Vec3::Zero(), false, n);
        const double k = std::min(mp.stiffness, contact_stiffness_limit(
                                                    m_eff, model.dt, model.solver.contact_max_omega_dt));
        ThreadPointTerm* term = next_thread_term(scratch, st);
        if (term == nullptr) return;
        set_segment_blocks(*term, s, u);
        term->target_velocity = vb;
        term->body = bm.anchored ? -1 : b;
        term->point = c + radius * n;
        if (touching) {
          fill_contact(*term, mp, k, reach - dist, n, p.v - vb);
          ++st.output.body_contacts;
        } else {
          // Touched in the last step, not at this one's start: the spring alone, from its gap
          // (no damping, no friction: they act on a contact, which this is only if the step
          // closes the gap).
          term->kept = true;
          term->axis = n;
          term->stiffness = k * (n * n.transpose());
          term->force = (k * (reach - dist)) * n;
        }
      }
    }
  }
}

void gather_thread_obstacle_contacts(const Model& model, Data& data, const ThreadModel& thread,
                                     ThreadState& st, ThreadScratch& scratch) noexcept {
  const double rt = thread.radius;
  // The sphere sets' spheres through the static grid (as the bodies' spheres meet them,
  // collision.cpp), each node its own query.
  if (model.static_grid.num_entries > 0) {
    CollisionScratch& cs = data.scratch->collision;
    for (std::size_t i = 0; i < st.position.size(); ++i) {
      const Vec3& x = st.position[i];
      collision_detail::query_static_grid(
          model.static_grid, x, rt, cs.entry_stamp.data(), cs.stamp, [&](const GridEntry& en) {
            ContactGeometry g;
            if (!sphere_sphere(x, rt, en.center, en.radius, Vec3::UnitZ(), g)) return;
            ThreadPointTerm* term = next_thread_term(scratch, st);
            if (term == nullptr) return;
            const MaterialPair& mp = model.material_pair(thread.material, en.material);
            term->a = term->b = static_cast<int>(i) + 1;
            fill_contact(*term, mp, mp.stiffness, g.depth, g.normal, st.velocity[i]);
            ++st.output.obstacle_contacts;
          });
    }
  }
  for (const Obstacle& o : model.obstacles) {
    if (o.type == ShapeType::kSphereSet) continue;  // above
    const MaterialPair& mp = model.material_pair(thread.material, o.material);
    const Mat3 rot = o.pose.orientation.toRotationMatrix();
    for (std::size_t i = 0; i < st.position.size(); ++i) {
      const Vec3& x = st.position[i];
      if (((x.array() + rt) < o.aabb_min.array()).any() ||
          ((x.array() - rt) > o.aabb_max.array()).any())
        continue;
      ContactGeometry g;
      bool hit = false;
      switch (o.type) {
        case ShapeType::kPlane: hit = sphere_plane(x, rt, o.pose.position, rot.col(2), g); break;
        case ShapeType::kBox: hit = sphere_box(x, rt, o.pose.position, rot, o.half_extents, g); break;
        case ShapeType::kSphere:
          hit = sphere_sphere(x, rt, o.pose.position, o.radius, Vec3::UnitZ(), g);
          break;
        case ShapeType::kCapsule:
          hit = sphere_capsule(x, rt, o.pose.position, rot.col(2), o.half_length, o.radius, g);
          break;
        case ShapeType::kMesh:
          hit = o.mesh >= 0 && sphere_mesh(x, rt, model.meshes[static_cast<std::size_t>(o.mesh)], o.pose, g);
          break;
        default: break;
      }
      if (!hit) continue;
      ThreadPointTerm* term = next_thread_term(scratch, st);
      if (term == nullptr) return;
      term->a = term->b = static_cast<int>(i) + 1;
      fill_contact(*term, mp, mp.stiffness, g.depth, g.normal, st.velocity[i]);
      ++st.output.obstacle_contacts;
    }
  }
}

void find_thread_self_pairs(const ThreadModel& thread, ThreadState& st,
                            const std::vector<Vec3>& x, ThreadScratch& scratch) noexcept {
  scratch.num_self_pairs = 0;
  const int segs = thread.segments;
  if (segs < 3) return;
  const double rt = thread.radius;
  Vec3 lo = st.position[0], hi = st.position[0];
  for (int s = 0; s < segs; ++s) {
    const auto i = static_cast<std::size_t>(s);
    const Vec3 a = st.position[i].cwiseMin(st.position[i + 1]).cwiseMin(x[i]).cwiseMin(x[i + 1]);
    const Vec3 b = st.position[i].cwiseMax(st.position[i + 1]).cwiseMax(x[i]).cwiseMax(x[i + 1]);
    scratch.segment_min[i] = a.array() - rt;
    scratch.segment_max[i] = b.array() + rt;
    lo = lo.cwiseMin(scratch.segment_min[i]);
    hi = hi.cwiseMax(scratch.segment_max[i]);
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);  // sweep along the longest extent
  scratch.sweep_axis = axis;
  std::vector<std::int32_t>& order = scratch.sweep_order;
  // Insertion sort of last step's order: nearly sorted, O(n) a step.
  for (std::size_t p = 1; p < order.size(); ++p) {
    const std::int32_t key = order[p];
    const double v = scratch.segment_min[static_cast<std::size_t>(key)][axis];
    std::size_t q = p;
    for (; q > 0 && scratch.segment_min[static_cast<std::size_t>(order[q - 1])][axis] > v; --q)
      order[q] = order[q - 1];
    order[q] = key;
  }
  for (std::size_t p = 0; p < order.size(); ++p) {
    const int s = order[p];
    const Vec3& smin = scratch.segment_min[static_cast<std::size_t>(s)];
    const Vec3& smax = scratch.segment_max[static_cast<std::size_t>(s)];
    for (std::size_t q = p + 1; q < order.size(); ++q) {
      const int t = order[q];
      const Vec3& tmin = scratch.segment_min[static_cast<std::size_t>(t)];
      if (tmin[axis] > smax[axis]) break;
      if (std::abs(s - t) < 2 || s == st.broken_segment || t == st.broken_segment) continue;
      const Vec3& tmax = scratch.segment_max[static_cast<std::size_t>(t)];
      if ((tmin.array() > smax.array()).any() || (smin.array() > tmax.array()).any()) continue;
      if (scratch.num_self_pairs >= static_cast<int>(scratch.self_pairs.size())) {
        ++st.output.contacts_dropped;
        continue;
      }
      ThreadSelfPair& pair = scratch.self_pairs[static_cast<std::size_t>(scratch.num_self_pairs++)];
      pair.s = s;
      pair.t = t;
      const auto si = static_cast<std::size_t>(s), ti = static_cast<std::size_t>(t);
      segment_segment(st.position[si], st.position[si + 1], st.position[ti], st.position[ti + 1],
                      pair.us, pair.ut);
      const Vec3 d = segment_point(st, s, pair.us).x - segment_point(st, t, pair.ut).x;
      pair.normal = d.squaredNorm() > kDegenerateDistance2 ? Vec3(d.normalized()) : Vec3::UnitZ();
    }
  }
}

int add_thread_self_contacts(const Model& model, const ThreadModel& thread,
                             const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                             const ThreadScratch& scratch, double h, ThreadBand& band) noexcept {
  const double k = model.material_pair(thread.material, thread.material).stiffness;
  const double reach = 2.0 * thread.radius;
  int touching = 0;
  for (int i = 0; i < scratch.num_self_pairs; ++i) {
    const ThreadSelfPair& pair = scratch.self_pairs[static_cast<std::size_t>(i)];
    const auto si = static_cast<std::size_t>(pair.s), ti = static_cast<std::size_t>(pair.t);
    const Vec3 p = (1.0 - pair.us) * x[si] + pair.us * x[si + 1];
    const Vec3 q = (1.0 - pair.ut) * x[ti] + pair.ut * x[ti + 1];
    const double depth = reach - (p - q).dot(pair.normal);
    if (depth <= 0.0) continue;
    ++touching;
    const Mat3 nn = pair.normal * pair.normal.transpose();
    Vec3 f = (h * k * depth) * pair.normal;  // h × the force on s's point; −it on t's
    Mat3 m = (2.0 * h * h * k) * nn;
    if (thread.self_friction > 0.0) {
      // Coulomb friction on the sliding of s's point over t's, across the normal: c = μ k d /
      // max(|v_t|, v_slip) at the iterate, implicit in v as a viscous term (c lagged).
      const Vec3 vs = (1.0 - pair.us) * v[si] + pair.us * v[si + 1];
      const Vec3 vt = (1.0 - pair.ut) * v[ti] + pair.ut * v[ti + 1];
      const Mat3 across = Mat3::Identity() - nn;
      const Vec3 slide = across * (vs - vt);
      const double c =
          thread.self_friction * k * depth / std::max(slide.norm(), kThreadSelfSlipSpeed);
      f -= (h * c) * slide;
      m += (2.0 * h * c) * across;
    }
    const double w[4] = {1.0 - pair.us, pair.us, 1.0 - pair.ut, pair.ut};
    const int blocks[4] = {pair.s + 1, pair.s + 2, pair.t + 1, pair.t + 2};
    for (int a = 0; a < 4; ++a) {
      band.rhs[static_cast<std::size_t>(blocks[a])] += (a < 2 ? w[a] : -w[a]) * f;
      const int side = a / 2;  // each side's own blocks only (the other side as given)
      for (int b = side * 2; b <= a; ++b) band.add(blocks[a], blocks[b], (w[a] * w[b]) * m);
    }
  }
  return touching;
}

void gather_thread_eyelets(const ThreadModel& thread, ThreadState& st,
                           ThreadScratch& scratch) noexcept {
  const int segs = thread.segments;
  for (int k = 0; k < kMaxThreadEyelets; ++k) {
    const ThreadEyelet& e = st.eyelets[static_cast<std::size_t>(k)];
    ThreadEyeletOutput& out = st.output.eyelets[static_cast<std::size_t>(k)];
    if (!e.active) {
      out = ThreadEyeletOutput{};
      continue;
    }
    // The nearest segment: near last step's one, or over the whole thread the first time.
    const int from = out.segment < 0 ? 0 : std::max(0, out.segment - 4);
    const int to = out.segment < 0 ? segs : std::min(segs, out.segment + 5);
    int best = from;
    double best_u = 0.0, best_d2 = std::numeric_limits<double>::infinity();
    for (int s = from; s < to; ++s) {
      if (s == st.broken_segment) continue;
      const auto i = static_cast<std::size_t>(s);
      const double u = segment_parameter(st.position[i], st.position[i + 1], e.position);
      const double d2 = (segment_point(st, s, u).x - e.position).squaredNorm();
      if (d2 < best_d2) {
        best_d2 = d2;
        best = s;
        best_u = u;
      }
    }
    // An eyelet on tissue past a free end: the thread has slid out through it.
    const bool off_start = best == 0 && best_u <= 0.0 && thread.tie_start.body == -2;
    const bool off_end = best == segs - 1 && best_u >= 1.0 && thread.tie_end.body == -2;
    if (e.face >= 0 && (off_start || off_end)) {
      st.eyelets[static_cast<std::size_t>(k)] = ThreadEyelet{};
      ++st.eyelets_let_go;
      out = ThreadEyeletOutput{};
      continue;
    }
    out.segment = best;
    ThreadPointTerm* term = next_thread_term(scratch, st);
    if (term == nullptr) return;
    // The thread's tangent there, blended from its nodes' (central differences): continuous
    // along the thread, so that a bend at the eyelet is held across its bisector.
    const auto i = static_cast<std::size_t>(best);
    const auto last = static_cast<std::size_t>(segs);
    const auto node_tangent = [&](std::size_t n) {
      return Vec3(st.position[std::min(n + 1, last)] - st.position[n == 0 ? 0 : n - 1]).normalized();
    };
    const Vec3 axis = ((1.0 - best_u) * node_tangent(i) + best_u * node_tangent(i + 1)).normalized();
    const SegmentPoint p = segment_point(st, best, best_u);
    const Mat3 across = Mat3::Identity() - axis * axis.transpose();
    const Vec3 fn = e.stiffness * (across * (e.position - p.x));
    const double v_slide = axis.dot(p.v - e.velocity);
    const double c = e.friction * fn.norm() / std::max(std::abs(v_slide), e.slip_speed) + e.drag;
    set_segment_blocks(*term, best, best_u);
    term->stiffness = e.stiffness * across;
    term->damping = c * axis * axis.transpose();
    term->force = fn - c * v_slide * axis;
    term->target_velocity = e.velocity;
    term->eyelet = k;
    term->axis = axis;
    out.normal_force = fn.norm();
  }
}

}  // namespace numen::core
