/// @file thread_step.cpp
/// One implicit step of every thread (thread.hpp, step_threads()): backward Euler on the
/// node velocities, g(v) = M (v − v0) − h f(x0 + h v, v) = 0, solved by Newton's method (its
/// first iteration is the linearly implicit Euler of Baraff & Witkin 1998, Eq. 6). Each
/// iteration is one block-banded system (linalg/thread_band.hpp) of the rod's stretch and bend
/// terms, its ties to bodies (the body's translational effective mass at the tie in the
/// system), and its contacts and eyelets (thread_contacts.cpp: linear in v over the step).
/// The reactions go to the bodies.

#include <algorithm>
#include <cmath>
#include <utility>

#include "scratch/data_scratch.hpp"
#include "scratch/thread_scratch.hpp"
#include "thread/thread_terms.hpp"
#include "numen/core/data.hpp"
#include "numen/core/grasp.hpp"
#include "numen/core/model.hpp"
#include "numen/core/rigid_body.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/core/thread.hpp"

namespace numen::core {
namespace {

/// Adds a thread's reaction on body `body` to its explicit wrench and to the threads' own record
/// of it (Data::thread_reactions).
void add_thread_reaction(Data& data, int body, const Wrench& w) noexcept {
  const auto b = static_cast<std::size_t>(body);
  data.body_wrench[b].force += w.force;
  data.body_wrench[b].torque += w.torque;
  if (b < data.thread_reactions.size()) {
    data.thread_reactions[b].force += w.force;
    data.thread_reactions[b].torque += w.torque;
  }
}

/// Newton iterations a step, at most: a straight segment turning by θ in a step stretches by
/// θ²/2 under the first linearisation alone (its rotation is not linear); each further
/// iteration squares the error.
constexpr int kThreadNewtonIterations = 6;
/// The iteration stops once no node's position is off by more than this fraction of l0: once an
/// update moves no node by more, or, from the second update on, once the error the updates'
/// contraction leaves after it does not exceed it (kThreadNewtonContraction).
constexpr double kThreadNewtonTolerance = 1e-6;
/// The error left after a Newton update Δ_k, estimated from its contraction Θ_k = ‖Δ_k‖ /
/// ‖Δ_{k−1}‖ (largest node move, h |Δv|) as η_k ‖Δ_k‖, η_k = Θ_k / (1 − Θ_k): the error of an
/// iteration that contracts at least at the rate Θ_k from there on (Hairer & Wanner, Solving
/// Ordinary Differential Equations II, 2nd ed., §IV.8, the stopping criterion (8.10)–(8.13)).
/// Newton's iteration contracts faster (quadratically) near the solution, so the estimate is on
/// the safe side; it is used for Θ_k below this bound, where it is below ‖Δ_k‖ itself.
constexpr double kThreadNewtonContraction = 0.5;
/// An update from Newton's matrix with the compressed segments' part across taken whole
/// (step_thread()) that moves a node further than the update before it is taken only if it
/// moves no node more than this many times further than the update with that part dropped, from
/// the same iterate: both grow from a far start, the whole one alone from a matrix near singular
/// (docs/thread.md, "The compressed segments' part across").
constexpr double kThreadNewtonWholeRatio = 2.0;

/// A tie's point: block `block` of the band, where it is and how it moves at the step's start,
/// and its translational effective mass when a dynamic body's (else it moves as given).
struct TiePoint {
  int block = 0;
  bool dynamic = false;
  Mat3 mass = Mat3::Identity();   ///< (1/m − [r]× I_w⁻¹ [r]×)⁻¹ (kg), dynamic only.
  Vec3 point = Vec3::Zero();      ///< World (m).
  Vec3 velocity = Vec3::Zero();   ///< World (m/s).
  Vec3 lever = Vec3::Zero();      ///< point − the body's COM (m).
  Mat3 rotation = Mat3::Identity();  ///< The body's orientation (world for −1).
};

TiePoint tie_point(const Model& model, const Data& data, const ThreadTie& tie, int block) noexcept {
  TiePoint p;
  p.block = block;
  if (tie.body == -1) p.point = tie.point;
  if (tie.body < 0) return p;
  const BodyModel& bm = model.bodies[static_cast<std::size_t>(tie.body)];
  const BodyState& bs = data.bodies[static_cast<std::size_t>(tie.body)];
  p.rotation = bs.orientation.toRotationMatrix();
  p.lever = p.rotation * tie.point;
  p.point = bs.position + p.lever;
  p.velocity = bs.linear_velocity + bs.angular_velocity.cross(p.lever);
  // A kDirect held body moves as given. Any other body, a multirate scene loop's imposed
  // god-object included, has its own mass here: the thread's end yields as the body alone would,
  // and the pull goes to the device loop, where the body is (ThreadPull). Taken as given there
  // (infinitely heavy), the tie's pull on the needle jumped to 36 N in one scene step once an
  // eyelet held the thread, and threw it (docs/multirate-suturing.md, "A thread in the scene loop").
  const bool imposed = model.coupling_mode == CouplingMode::kDirect && tie.body == data.held_body;
  if (bm.anchored || imposed) return p;
  Mat3 rx;
  rx << 0, -p.lever.z(), p.lever.y(), p.lever.z(), 0, -p.lever.x(), -p.lever.y(), p.lever.x(), 0;
  const Mat3 mobility = Mat3::Identity() / bm.mass -
                        rx * world_inertia_inverse(bs.orientation, bm.inertia_body_inv) * rx;
  p.mass = mobility.inverse();
  p.dynamic = true;
  return p;
}

/// A tie point's block: its inertia residual −M_p Δv_p (a dynamic body's), else identity.
void add_tie_block(const TiePoint& p, const Vec3& delta, ThreadBand& band) noexcept {
  const auto b = static_cast<std::size_t>(p.block);
  band.diag[b] += p.mass;
  if (p.dynamic) band.rhs[b] -= p.mass * delta;
}

/// Where the tie's point is at the iterate (m).
Vec3 tie_position(const TiePoint& p, const Vec3& delta, double h) noexcept {
  return p.point + h * (p.velocity + (p.dynamic ? delta : Vec3::Zero()));
}

/// The zero-length spring of stiffness k between node `node` and the tie point (offset `offset`
/// from it, world): force k (p + offset − x) on the node, at the iterate.
void add_tie_spring(const Vec3& x, const Vec3& p_at, const TiePoint& p, int node,
                    const Vec3& offset, double k, double h, ThreadBand& band) noexcept {
  const int nb = node + 1;
  const Vec3 f = k * (p_at + offset - x);
  const Mat3 hk = (h * h * k) * Mat3::Identity();
  band.diag[static_cast<std::size_t>(nb)] += hk;
  band.rhs[static_cast<std::size_t>(nb)] += h * f;
  if (!p.dynamic) return;
  band.diag[static_cast<std::size_t>(p.block)] += hk;
  band.add(nb, p.block, -hk);
  band.rhs[static_cast<std::size_t>(p.block)] -= h * f;
}

/// A point term's force at velocity v of its thread point (linear in v over the step).
Vec3 point_term_force(const ThreadPointTerm& t, const Vec3& v, const Vec3& v0, double h) noexcept {
  return t.force - h * t.stiffness * (v - t.target_velocity) - t.damping * (v - v0);
}

/// A term's thread point's value w_a u_a + w_b u_b of the nodes' `u` (velocities: m/s).
Vec3 term_point(const ThreadPointTerm& t, const std::vector<Vec3>& u) noexcept {
  return t.wa * u[static_cast<std::size_t>(t.a - 1)] + t.wb * u[static_cast<std::size_t>(t.b - 1)];
}

/// Whether a term acts on the iterate `v`: a kept contact once its force has pushed along its
/// normal on an iterate of this step (the point at the step's end inside the sphere; `engaged`
/// from then on), every other term always.
bool term_acts(const ThreadState& st, const std::vector<Vec3>& v, ThreadPointTerm& t, double h) noexcept {
  if (!t.kept || t.engaged) return true;
  t.engaged = t.axis.dot(point_term_force(t, term_point(t, v), term_point(t, st.velocity), h)) > 0.0;
  return t.engaged;
}

/// A term's force at its point's velocity `vp`: point_term_force(), but a kept contact's never
/// pulls (zero where its force along its normal would be negative: the point away from the
/// sphere at the step's end).
Vec3 term_force(const ThreadPointTerm& t, const Vec3& vp, const Vec3& vp0, double h) noexcept {
  const Vec3 f = point_term_force(t, vp, vp0, h);
  return t.kept && t.axis.dot(f) < 0.0 ? Vec3::Zero() : f;
}

void add_point_term(const ThreadState& st, const std::vector<Vec3>& v, const ThreadPointTerm& t,
                    double h, ThreadBand& band) noexcept {
  const auto ia = static_cast<std::size_t>(t.a - 1), ib = static_cast<std::size_t>(t.b - 1);
  const Vec3 f = h * term_force(t, term_point(t, v), term_point(t, st.velocity), h);
  const Mat3 m = h * t.damping + (h * h * t.matrix_scale) * t.stiffness;
  band.rhs[ia + 1] += t.wa * f;
  band.rhs[ib + 1] += t.wb * f;
  band.add(t.a, t.a, (t.wa * t.wa) * m);
  if (t.b != t.a) {
    band.add(t.b, t.b, (t.wb * t.wb) * m);
    band.add(t.b, t.a, (t.wa * t.wb) * m);
  }
}

/// The nodes' inertia, gravity, drag and external forces, the stretch springs and the bend
/// terms at the iterate (x, v) into the band, Newton's form: matrix M + h C + h² S(x),
/// right-hand side h f(x, v) − M (v − v0). `whole`: each segment's whole stiffness, its part
/// across k (1 − l0/l) negative where it is compressed (the caller checks that the matrix is
/// still positive definite); else that part clamped at 0 (positive definite by construction).
void add_rod_terms(const Model& model, const ThreadModel& th, const ThreadState& st,
                   const std::vector<Vec3>& x, const std::vector<Vec3>& v, double h, bool whole,
                   ThreadBand& band) noexcept {
  const int nodes = th.segments + 1;
  for (int i = 0; i < nodes; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const double share = (i == 0 || i == nodes - 1) ? 0.5 : 1.0;
    const double m = share * th.node_mass;
    const double drag = share * th.damping * th.rest_segment;
    band.add_identity(i + 1, i + 1, m + h * drag);
    band.rhs[u + 1] += h * (m * model.gravity + st.external_force[u] - drag * v[u]) -
                       m * (v[u] - st.velocity[u]);
  }
  const double k = th.stretch_stiffness;
  for (int s = 0; s < th.segments; ++s) {
    if (s == st.broken_segment) continue;
    const auto a = static_cast<std::size_t>(s);
    const Vec3 d = x[a + 1] - x[a];
    const double l = d.norm();
    if (!(l > 0.0)) continue;
    const Vec3 u = d / l;
    const Mat3 uu = u * u.transpose();
    const double across = whole ? 1.0 - th.rest_segment / l : std::max(0.0, 1.0 - th.rest_segment / l);
    const Mat3 stiff = (h * h * k) * (uu + across * (Mat3::Identity() - uu));
    const Vec3 f = (h * k * (l - th.rest_segment)) * u;  // h × the force on node a; −it on a + 1
    band.rhs[a + 1] += f;
    band.rhs[a + 2] -= f;
    band.add(s + 1, s + 1, stiff);
    band.add(s + 2, s + 2, stiff);
    band.add(s + 2, s + 1, -stiff);
  }
  const double kb = th.bend_stiffness;
  constexpr double c[3] = {1.0, -2.0, 1.0};
  for (int i = 1; i + 1 < nodes; ++i) {
    if (st.broken_segment == i - 1 || st.broken_segment == i) continue;
    const auto u = static_cast<std::size_t>(i);
    const Vec3 dx = x[u - 1] - 2.0 * x[u] + x[u + 1];
    for (int a = 0; a < 3; ++a) {
      band.rhs[u + static_cast<std::size_t>(a)] -= (h * kb * c[a]) * dx;
      for (int b = 0; b <= a; ++b)
        band.add_identity(i + a, i + b, h * h * kb * c[a] * c[b]);
    }
  }
}

/// Tension, stretch and the break of the step's end state.
void measure_thread(const ThreadModel& th, ThreadState& st) noexcept {
  ThreadOutput& o = st.output;
  int worst = -1;
  for (int s = 0; s < th.segments; ++s) {
    if (s == st.broken_segment) continue;
    const auto a = static_cast<std::size_t>(s);
    const double strain = (st.position[a + 1] - st.position[a]).norm() / th.rest_segment - 1.0;
    if (strain > o.max_stretch) {
      o.max_stretch = strain;
      worst = s;
    }
  }
  o.max_tension = th.stretch_stiffness * th.rest_segment * o.max_stretch;
  if (st.broken_segment < 0 && o.max_stretch > th.break_strain) {
    st.broken_segment = worst;
    o.broke = true;
  }
}

/// The tie's force on its body at the step's end (world), and its wrench about the COM.
Wrench tie_reaction(const ThreadState& st, const ThreadTie& tie, const TiePoint& p,
                    const Vec3& p_at, double k, double l0, int n0, int n1) noexcept {
  Wrench w;
  if (tie.body < 0) return w;
  auto pull = [&](int node, const Vec3& offset) {
    const Vec3 f = k * (st.position[static_cast<std::size_t>(node)] - (p_at + offset));
    w.force += f;
    w.torque += (p.lever + offset).cross(f);
  };
  pull(n0, Vec3::Zero());
  if (tie.clamped) pull(n1, l0 * (p.rotation * tie.direction));
  return w;
}

/// The point terms' forces at the step's end, before the state moves on (`v`: the step's
/// velocities): each eyelet's and each tissue contact's for the nets' step (sc.eyelet_terms,
/// sc.tissue_terms), each body contact's and held node spring's reaction on its body's wrench,
/// each held node spring's force into its GraspThreadNode::force.
void hand_point_term_forces(Data& data, ThreadState& st, ThreadScratch& sc,
                            const std::vector<Vec3>& v, double h) noexcept {
  for (int t = 0; t < sc.num_terms; ++t) {
    const ThreadPointTerm& term = sc.terms[static_cast<std::size_t>(t)];
    if (term.kept && !term.engaged) continue;  // never pushed on an iterate: no contact
    const auto ia = static_cast<std::size_t>(term.a - 1), ib = static_cast<std::size_t>(term.b - 1);
    const Vec3 vp = term_point(term, v), vp0 = term_point(term, st.velocity);
    const Vec3 f = term_force(term, vp, vp0, h);
    if (term.kept && f.isZero(0.0)) continue;  // it pushed on an iterate, not at the step's end
    if (term.kept) ++st.output.kept_contacts;
    if (term.eyelet >= 0) {
      const auto k = static_cast<std::size_t>(term.eyelet);
      st.output.eyelets[k].friction_force = term.axis.dot(term.force - term.damping * (vp - vp0));
      ThreadEyeletTerm& et = sc.eyelet_terms[k];
      et.set = true;
      et.point = term.wa * (st.position[ia] + h * v[ia]) + term.wb * (st.position[ib] + h * v[ib]);
      et.velocity = vp;
      et.axis = term.axis;
      et.force = f;
      et.stiffness = term.stiffness.trace() / 2.0;  // k (I − a aᵀ): trace 2k
      et.damping = term.axis.dot(term.damping * term.axis);
    }
    if (term.face >= 0 && sc.num_tissue_terms < kMaxThreadTissueContacts) {
      ThreadTissueTerm& tt = sc.tissue_terms[static_cast<std::size_t>(sc.num_tissue_terms++)];
      tt.face = term.face;
      tt.weights = term.face_weights;
      tt.point = term.wa * (st.position[ia] + h * v[ia]) + term.wb * (st.position[ib] + h * v[ib]);
      tt.velocity = vp;
      tt.normal = term.axis;
      tt.force = f;
      tt.stiffness = term.axis.dot(term.stiffness * term.axis);
      tt.damping = term.axis.dot(term.damping * term.axis);
    }
    if (term.grasp >= 0)
      data.grasps[static_cast<std::size_t>(term.grasp)].thread_nodes[static_cast<std::size_t>(term.grasp_node)].force += f;
    if (term.body < 0) continue;
    const BodyState& bs = data.bodies[static_cast<std::size_t>(term.body)];
    add_thread_reaction(data, term.body, Wrench{-f, -(term.point - bs.position).cross(f)});
  }
}

void step_thread(const Model& model, Data& data, int index, const ThreadModel& th, ThreadState& st,
                 ThreadScratch& sc) noexcept {
  const double h = model.dt;
  const int nodes = th.segments + 1;
  const auto n = static_cast<std::size_t>(nodes);
  ThreadBand& band = sc.band;
  const std::array<ThreadEyeletOutput, kMaxThreadEyelets> eyelets = st.output.eyelets;
  st.output = ThreadOutput{};
  st.output.eyelets = eyelets;
  const double k_tie = th.stretch_stiffness;
  const TiePoint p0 = tie_point(model, data, th.tie_start, 0);
  const TiePoint p1 = tie_point(model, data, th.tie_end, nodes + 1);
  const Vec3 off0 = th.rest_segment * (p0.rotation * th.tie_start.direction);
  const Vec3 off1 = th.rest_segment * (p1.rotation * th.tie_end.direction);
  // The held nodes' springs (first: never dropped), the contacts and eyelets at the step's start
  // (linear in v over the step).
  sc.num_terms = 0;
  for (ThreadEyeletTerm& et : sc.eyelet_terms) et.set = false;
  gather_thread_grasps(model, data, index, st, sc);
  gather_thread_body_contacts(model, data, index, th, st, sc);
  gather_thread_obstacle_contacts(model, data, th, st, sc);
  gather_thread_tissue_contacts(model, data, th, st, sc);
  gather_thread_eyelets(th, st, sc);
  std::vector<Vec3>& x = sc.trial_position;
  std::vector<Vec3>& v = sc.trial_velocity;
  for (std::size_t i = 0; i < n; ++i) {
    sc.saved_position[i] = st.position[i];
    v[i] = st.velocity[i];
  }
  sc.tie_delta = {Vec3::Zero(), Vec3::Zero()};
  bool ok = true;
  bool swept = false;  // the self contact's candidates found (on the first iterate)
  double last_move = 0.0;  // the last update's largest node move (m)
  const double tolerance = kThreadNewtonTolerance * th.rest_segment;  // m
  bool met = false;        // the iteration met its tolerance
  // Newton's matrix: from the second iteration on, with each segment's whole stiffness while
  // its factor says it is positive definite and the thread has no self-contact candidates;
  // else, and for the rest of the step once one of these fails, with the compressed segments'
  // part across dropped (docs/thread.md, "The compressed segments' part across"). An update from
  // the whole matrix that does not contract is checked against the update with the part dropped
  // from the same iterate (kThreadNewtonWholeRatio); one that fails that is not taken, the
  // dropped part's is, and the rest of the step keeps the part dropped.
  bool whole_allowed = true;
  auto assemble = [&](int iteration, bool whole) {
    band.clear();
    add_rod_terms(model, th, st, x, v, h, whole, band);
    add_tie_block(p0, sc.tie_delta[0], band);
    add_tie_block(p1, sc.tie_delta[1], band);
    const Vec3 at0 = tie_position(p0, sc.tie_delta[0], h), at1 = tie_position(p1, sc.tie_delta[1], h);
    if (th.tie_start.body >= -1) {
      add_tie_spring(x[0], at0, p0, 0, Vec3::Zero(), k_tie, h, band);
      if (th.tie_start.clamped && nodes > 2) add_tie_spring(x[1], at0, p0, 1, off0, k_tie, h, band);
    }
    if (th.tie_end.body >= -1) {
      add_tie_spring(x[n - 1], at1, p1, nodes - 1, Vec3::Zero(), k_tie, h, band);
      if (th.tie_end.clamped && nodes > 2) add_tie_spring(x[n - 2], at1, p1, nodes - 2, off1, k_tie, h, band);
    }
    for (int t = 0; t < sc.num_terms; ++t)
      if (term_acts(st, v, sc.terms[static_cast<std::size_t>(t)], h))
        add_point_term(st, v, sc.terms[static_cast<std::size_t>(t)], h, band);
    const int touching = iteration >= 1 && th.self_contact ? add_thread_self_contacts(model, th, x, v, sc, h, band) : 0;
    st.output.self_contacts = touching;
  };
  for (int iteration = 0; iteration < kThreadNewtonIterations && ok; ++iteration) {
    for (std::size_t i = 0; i < n; ++i) x[i] = st.position[i] + h * v[i];
    // Self contact from the second iteration on: its candidates swept to the first iterate.
    if (iteration == 1 && th.self_contact && !swept) find_thread_self_pairs(th, st, x, sc);
    bool whole = whole_allowed && iteration >= 1 && sc.num_self_pairs == 0;
    double move = 0.0;  // the update's largest node move (m)
    double whole_move = -1.0;  // a growing update from the whole matrix, kept (m)
    for (;;) {
      assemble(iteration, whole);
      double largest = 0.0;
      const bool factored = band.solve();
      for (std::size_t i = 0; factored && i < n; ++i) largest = std::max(largest, band.rhs[i + 1].squaredNorm());
      const bool solved = factored && largest < 1e300;  // positive definite, the update finite
      move = h * std::sqrt(largest);
      if (whole && !solved) {
        whole = whole_allowed = false;  // not positive definite: not taken
        continue;
      }
      if (whole && move >= last_move) {
        // Growing: from a far start (the dropped part's update grows as well) or from a matrix
        // near singular (it does not). Kept (its buffer swapped out, no copy) while the iterate
        // is solved with the part dropped.
        whole_move = move;
        std::swap(sc.whole_update, band.rhs);
        whole = false;
        continue;
      }
      ok = solved;
      if (ok && whole_move >= 0.0) {
        if (whole_move <= kThreadNewtonWholeRatio * move) {  // the whole matrix's update taken
          std::swap(sc.whole_update, band.rhs);
          move = whole_move;
        } else {
          whole_allowed = false;
        }
      }
      break;
    }
    if (!ok) break;
    st.output.iterations = iteration + 1;
    for (std::size_t i = 0; i < n; ++i) v[i] += band.rhs[i + 1];
    if (p0.dynamic) sc.tie_delta[0] += band.rhs[0];
    if (p1.dynamic) sc.tie_delta[1] += band.rhs[n + 1];
    const double theta = iteration >= 1 ? move / last_move : 1.0;
    last_move = move;
    const bool converged =
        move < tolerance || (theta < kThreadNewtonContraction && theta / (1.0 - theta) * move < tolerance);
    if (iteration == 0 && th.self_contact && converged) {
      // The candidates the second iteration would sweep to this iterate, found now: with none,
      // the converged first iterate is the step, as without self contact.
      for (std::size_t i = 0; i < n; ++i) x[i] = st.position[i] + h * v[i];
      find_thread_self_pairs(th, st, x, sc);
      swept = true;
      if (sc.num_self_pairs == 0) {
        met = true;
        break;
      }
    }
    const bool self_checked = !th.self_contact || iteration >= 1;
    if (self_checked && converged) {
      met = true;
      break;
    }
  }
  for (std::size_t i = 0; ok && i < n; ++i) {
    const Vec3 x1 = st.position[i] + h * v[i];
    ok = x1.allFinite() && v[i].allFinite();
  }
  if (!ok) {
    for (std::size_t i = 0; i < n; ++i) {
      st.position[i] = sc.saved_position[i];
      st.velocity[i].setZero();
    }
    data.status |= kNonFinite;
    return;
  }
  st.output.converged = met;
  hand_point_term_forces(data, st, sc, v, h);
  for (std::size_t i = 0; i < n; ++i) {
    st.velocity[i] = v[i];
    st.position[i] += h * v[i];
  }
  st.output.tie_wrench_start = tie_reaction(st, th.tie_start, p0, tie_position(p0, sc.tie_delta[0], h),
                                            k_tie, th.rest_segment, 0, 1);
  st.output.tie_wrench_end = tie_reaction(st, th.tie_end, p1, tie_position(p1, sc.tie_delta[1], h),
                                          k_tie, th.rest_segment, nodes - 1, nodes - 2);
  for (const auto& [tie, w] : {std::pair{&th.tie_start, &st.output.tie_wrench_start},
                               std::pair{&th.tie_end, &st.output.tie_wrench_end}}) {
    if (tie->body < 0 || model.bodies[static_cast<std::size_t>(tie->body)].anchored) continue;
    add_thread_reaction(data, tie->body, *w);
  }
  measure_thread(th, st);
}

}  // namespace

void step_threads(const Model& model, Data& data) noexcept {
  data.stages_run |= kStageThreads;
  data.num_node_thread_ties = 0;
  for (Wrench& w : data.thread_reactions) w = Wrench{};
  for (std::size_t i = 0; i < model.threads.size(); ++i) {
    const ThreadModel& th = model.threads[i];
    ThreadState& st = data.threads[i];
    take_over_punctures(model, data, th, st);
    place_tissue_eyelets(model, data, st);
    step_thread(model, data, static_cast<int>(i), th, st, data.scratch->threads[i]);
    tie_tissue_eyelets(model, data, st, data.scratch->threads[i]);
    tie_tissue_contacts(model, data, data.scratch->threads[i]);
  }
}

}  // namespace numen::core
