/// @file thread_knot_test.cpp
/// A knot in the suture thread (core/include/numen/core/thread.hpp; docs/thread.md "A knot"):
/// an overhand knot laid open in a 3-0 silk thread, its two ends pulled apart by
/// the hands until the knot holds a stated tension, then held. Whether it is still a knot is
/// read from the thread itself by a knot invariant (the determinant of its projection, 3 for the
/// overhand knot's trefoil, 1 for no knot), not from the figures of the run.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"
#include "numen/core/thread.hpp"
#include "sanitizer.hpp"
#include "thread_scenes.hpp"

namespace numen {
namespace {

using core::Vec3;

/// The knot determinant |Δ(−1)| of an open thread `p`, closed far outside it: each end carried
/// 1 m on along its last segment, the two joined by a path 1 m off to one side of the line
/// through them. The closed curve is projected along a direction normal to that line (turned by
/// `turn` rad about it: each turn a different diagram of the same knot), each crossing gives the
/// colouring relation 2 a_over − a_in − a_out = 0 of the arcs between under-crossings, and the
/// determinant is that of the relations' matrix less one row and column (the colouring matrix:
/// Livingston, "Knot Theory", 1993; the unknot 1, the trefoil 3).
int knot_determinant(const std::vector<Vec3>& p, double turn) {
  const Vec3 u = (p.back() - p.front()).normalized();
  Vec3 a = Vec3(0.3, 0.5, 0.8) - Vec3(0.3, 0.5, 0.8).dot(u) * u;
  a.normalize();
  const Vec3 b0 = u.cross(a);
  a = std::cos(turn) * a + std::sin(turn) * b0;
  const Vec3 b = u.cross(a);  // the view: depth along b
  const Vec3 out_end = (p.back() - p[p.size() - 2]).normalized();
  const Vec3 out_start = (p.front() - p[1]).normalized();
  std::vector<Vec3> q(p);
  q.push_back(p.back() + out_end);
  q.push_back(p.back() + out_end + a);
  q.push_back(p.front() + out_start + a);
  q.push_back(p.front() + out_start);
  const std::size_t n = q.size();
  struct Crossing {
    double over, under;  // curve parameters: edge index + fraction
  };
  std::vector<Crossing> crossings;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 &p1 = q[i], &p2 = q[(i + 1) % n];
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;  // neighbours through the closure
      const Vec3 &q1 = q[j], &q2 = q[(j + 1) % n];
      const double d1u = (p2 - p1).dot(u), d1a = (p2 - p1).dot(a);
      const double d2u = (q2 - q1).dot(u), d2a = (q2 - q1).dot(a);
      const double den = d1u * d2a - d1a * d2u;
      if (std::abs(den) <= 1e-9 * std::hypot(d1u, d1a) * std::hypot(d2u, d2a))
        continue;  // parallel
      const double ru = (q1 - p1).dot(u), ra = (q1 - p1).dot(a);
      const double s = (ru * d2a - ra * d2u) / den, t = (ru * d1a - ra * d1u) / den;
      if (s < 0.0 || s >= 1.0 || t < 0.0 || t >= 1.0) continue;
      const double zi = (p1 + s * (p2 - p1)).dot(b), zj = (q1 + t * (q2 - q1)).dot(b);
      const double ci = static_cast<double>(i) + s, cj = static_cast<double>(j) + t;
      crossings.push_back(zi > zj ? Crossing{ci, cj} : Crossing{cj, ci});
    }
  }
  const int m = static_cast<int>(crossings.size());
  if (m <= 1) return 1;  // a diagram of at most one crossing: no knot
  std::vector<double> unders;
  for (const Crossing& c : crossings) unders.push_back(c.under);
  std::sort(unders.begin(), unders.end());
  const auto arc_from = [&](double at) {  // the arc (between under-crossings) that holds `at`
    const auto k = std::upper_bound(unders.begin(), unders.end(), at) - unders.begin() - 1;
    return static_cast<int>((k + m) % m);
  };
  Eigen::MatrixXd rows = Eigen::MatrixXd::Zero(m, m);
  for (int r = 0; r < m; ++r) {
    const int k = static_cast<int>(std::lower_bound(unders.begin(), unders.end(),
                                                    crossings[static_cast<std::size_t>(r)].under) -
                                   unders.begin());
    rows(r, arc_from(crossings[static_cast<std::size_t>(r)].over)) += 2.0;
    rows(r, (k - 1 + m) % m) -= 1.0;
    rows(r, k) -= 1.0;
  }
  const int det =
      static_cast<int>(std::lround(std::abs(rows.bottomRightCorner(m - 1, m - 1).determinant())));
  return det;
}

/// An overhand knot laid open: the trefoil (sin t + 2 sin 2t, cos t − 2 cos 2t, −sin 3t) · scale,
/// cut open at the tip of one lobe (0.35 rad each side of it), with a straight tail of `tail`
/// leaving each cut end outwards at 45° to the lobe's tangent, as a dense polyline.
std::vector<Vec3> open_overhand_knot(double scale, double tail) {
  const auto trefoil = [&](double t) -> Vec3 {
    return scale * Vec3(std::sin(t) + 2.0 * std::sin(2.0 * t),
                        std::cos(t) - 2.0 * std::cos(2.0 * t), -std::sin(3.0 * t));
  };
  double tip = 0.0, reach = 0.0;
  for (int i = 0; i < 10000; ++i) {
    const double t = 2.0 * std::numbers::pi * i / 10000.0;
    if (const double r = trefoil(t).head<2>().norm(); r > reach) {
      reach = r;
      tip = t;
    }
  }
  const double gap = 0.35;
  const Vec3 at = trefoil(tip);
  const Vec3 radial = Vec3(at.x(), at.y(), 0.0).normalized();
  const Vec3 tangent = (trefoil(tip + 1e-4) - trefoil(tip - 1e-4)).normalized();
  const Vec3 first = trefoil(tip + gap), last = trefoil(tip - gap);
  const auto outwards = [&](const Vec3& end) {
    return ((end - at).dot(tangent) > 0.0 ? Vec3(radial + tangent) : Vec3(radial - tangent))
        .normalized();
  };
  std::vector<Vec3> line;
  for (int i = 200; i > 0; --i) line.push_back(first + (tail * i / 200.0) * outwards(first));
  for (int i = 0; i <= 4000; ++i)
    line.push_back(trefoil(tip + gap + (2.0 * std::numbers::pi - 2.0 * gap) * i / 4000.0));
  for (int i = 1; i <= 200; ++i) line.push_back(last + (tail * i / 200.0) * outwards(last));
  return line;
}

/// Nodes along `line` each exactly `l0` from the one before (its chords: a thread laid at rest,
/// every segment at its rest length).
std::vector<Vec3> nodes_along(const std::vector<Vec3>& line, double l0, int segments) {
  std::vector<Vec3> nodes{line.front()};
  std::size_t j = 0;
  for (int k = 1; k <= segments; ++k) {
    const Vec3 from = nodes.back();
    while (j + 1 < line.size() && (line[j + 1] - from).norm() < l0) ++j;
    if (j + 1 >= line.size()) break;
    const Vec3 a = line[j], d = line[j + 1] - line[j];
    double lo = 0.0, hi = 1.0;  // the chord's end on [a, a + d], by bisection
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      ((a + mid * d - from).norm() < l0 ? lo : hi) = mid;
    }
    nodes.push_back(a + hi * d);
  }
  return nodes;
}

/// What a pull of the knot gave.
struct KnotPull {
  int determinant_at_start[3]{};
  int determinant_at_end[3]{};
  double pulled_at = -1.0;      ///< When the ends' mean pull reached the target (s), or −1.
  double held_force_min = 0.0;  ///< The smallest 50 ms mean pull while held (N).
  double knot_length = 0.0;     ///< Length minus the ends' distance at the end (m).
  double late_min = 0.0, late_max = 0.0;  ///< The 50 ms mean pull's range over the last 0.5 s (N).
  double closest_strands = 0.0;  ///< Least distance of nodes ≥ 3 apart along it, at the end (m).
  int self_contacts = 0;         ///< At the end.
  int unconverged_steps = 0;     ///< Steps whose Newton iteration ran out (ThreadOutput::converged).
  bool ran_out_at_six = true;    ///< Each of them took all 6 iterations.
  bool broke = false, finite = true;
};

/// A 3-0 silk thread (the defaults but its self contact, drag and friction) in 0.25 mm segments
/// laid as the open overhand knot (scale 1.5 mm, 20 mm tails), its ends tied to two bodies the test
/// moves apart along the line through them at 10 mm/s each until the ends' pull, averaged over 50
/// ms, reaches `pull`; then the bodies stop and the knot is held for `hold` s. Self contact with
/// the thread's material pair of stiffness `self_stiffness` and Coulomb μ `self_friction`.
KnotPull pull_knot(bool self_contact, double self_stiffness, double drag, double pull, double hold,
                   double self_friction = 0.0) {
  const double l0 = 0.25e-3;
  const std::vector<Vec3> line = open_overhand_knot(1.5e-3, 20e-3);
  double length = 0.0;
  for (std::size_t i = 1; i < line.size(); ++i) length += (line[i] - line[i - 1]).norm();
  core::ThreadModel th;
  th.name = "suture";
  th.segments =
      static_cast<int>(std::floor(length / l0)) - 2;  // the chords are shorter than the arc
  th.length = th.segments * l0;
  th.damping = drag;
  th.self_contact = self_contact;
  th.self_friction = self_friction;
  const std::vector<Vec3> nodes = nodes_along(line, l0, th.segments);
  EXPECT_EQ(static_cast<int>(nodes.size()), th.segments + 1);
  th.start = nodes.front();
  const core::Model m = test::thread_model(th, [&](core::Model& mm) {
    mm.material_pairs[0].stiffness = self_stiffness;
    for (const Vec3& end : {nodes.front(), nodes.back()})  // the hands: bodies the test moves
      test::add_thread_test_body(mm, 1.0, 1e-3, end, 0.0);
    mm.threads[0].tie_start = core::ThreadTie{0, Vec3::Zero()};
    mm.threads[0].tie_end = core::ThreadTie{1, Vec3::Zero()};
  });
  core::Data d = core::make_data(m);
  core::ThreadState& s = d.threads[0];
  for (std::size_t i = 0; i < nodes.size(); ++i) s.position[i] = nodes[i];
  KnotPull out;
  for (int v = 0; v < 3; ++v) out.determinant_at_start[v] = knot_determinant(s.position, 0.7 * v);
  const Vec3 apart = (nodes.front() - nodes.back()).normalized();
  Vec3 left = nodes.front(), right = nodes.back();
  const double speed = 0.01;
  double mean_pull = 0.0, end_time = 10.0;

  out.held_force_min = 1e9;
  out.late_min = 1e9;
  for (int k = 0; k * m.dt < end_time; ++k) {
    const double t = k * m.dt;
    const Vec3 v = out.pulled_at < 0.0 ? Vec3(speed * apart) : Vec3::Zero();  // then held still
    left += m.dt * v;
    right -= m.dt * v;
    d.bodies[0].position = left;
    d.bodies[1].position = right;
    d.bodies[0].linear_velocity = v;
    d.bodies[1].linear_velocity = -v;
    d.bodies[0].angular_velocity.setZero();
    d.bodies[1].angular_velocity.setZero();
    core::step(m, d);
    out.finite = out.finite && !(d.status & core::kNonFinite);
    out.broke = out.broke || s.broken_segment >= 0;
    if (!s.output.converged) {
      ++out.unconverged_steps;
      out.ran_out_at_six = out.ran_out_at_six && s.output.iterations == 6;
    }
    mean_pull += (s.output.tie_wrench_start.force.norm() - mean_pull) * m.dt / 0.05;
    if (out.pulled_at < 0.0 && mean_pull >= pull) {
      out.pulled_at = t;
      end_time = t + hold;
    }
    if (out.pulled_at >= 0.0 && t > out.pulled_at + 0.05)
      out.held_force_min = std::min(out.held_force_min, mean_pull);
    if (out.pulled_at >= 0.0 && t >= end_time - 0.5) {
      out.late_min = std::min(out.late_min, mean_pull);
      out.late_max = std::max(out.late_max, mean_pull);
    }
  }
  for (int v = 0; v < 3; ++v) out.determinant_at_end[v] = knot_determinant(s.position, 0.7 * v);
  out.knot_length = th.length - (s.position.back() - s.position.front()).norm();
  out.closest_strands = 1.0;
  for (std::size_t i = 0; i < s.position.size(); ++i)
    for (std::size_t j = i + 3; j < s.position.size(); ++j)
      out.closest_strands = std::min(out.closest_strands, (s.position[i] - s.position[j]).norm());
  out.self_contacts = s.output.self_contacts;
  return out;
}

// The invariant itself: the laid knot (its first 300 chords of 0.25 mm, the tail it ends on cut
// short) is a trefoil (3) in every view; a straight thread, and a loop that crosses itself once,
// no knot (1).
TEST(ThreadKnot, TheKnotDeterminantTellsAKnotFromNone) {
  const std::vector<Vec3> line = nodes_along(open_overhand_knot(1.5e-3, 20e-3), 0.25e-3, 300);
  ASSERT_EQ(line.size(), 301u);
  for (int v = 0; v < 3; ++v) EXPECT_EQ(knot_determinant(line, 0.7 * v), 3) << "view " << v;
  std::vector<Vec3> straight;
  for (int i = 0; i <= 100; ++i) straight.push_back(Vec3(1e-3 * i, 0.0, 0.0));
  EXPECT_EQ(knot_determinant(straight, 0.0), 1);
  std::vector<Vec3> loop;  // a loop that crosses itself once and is pulled apart: no knot
  for (int i = 0; i <= 400; ++i) {
    const double t = 2.0 * std::numbers::pi * i / 400.0;
    loop.push_back(Vec3(20e-3 * (i / 400.0 - 0.5) + 3e-3 * std::sin(t), 3e-3 * (1.0 - std::cos(t)),
                        1e-3 * std::sin(t / 2)));
  }
  EXPECT_EQ(knot_determinant(loop, 0.3), 1);
}

// An overhand knot pulled tight by the two hands at 10 mm/s each until their pull is 2 N, then
// held still 2 s: it is still a trefoil in every view, the pull stays at or above 1.9 N and
// steady (a knot that slipped through itself leaves the thread straight and slack between the
// hands), the strands' nodes are never closer than their diameter less a tenth, and nothing
// breaks. Stated conditions (docs/thread.md "A knot"): the self contact's stiffness 1e5 N/m
// (at the material's default 1e4 N/m the strands pull through each other, below), and the
// thread's drag 100 N·s/m², an overdamped thread: at a drag of 3 N·s/m² and below the slack,
// light thread's Newton iteration does not converge and the knot comes apart or breaks.
TEST(ThreadKnot, AnOverhandKnotPulledTightHoldsTwoNewtons) {
  NUMEN_SKIP_UNDER_SANITIZER(
      "pulls a 313-segment knot through 4 s of simulated time, a figure of the thread's solve, not "
      "what a sanitizer checks; the self contact's path runs there in "
      "Thread.SelfContactKeepsStrandsApart");
  const KnotPull r = pull_knot(true, 1e5, 100.0, 2.0, 2.0);
  for (int v = 0; v < 3; ++v) {
    EXPECT_EQ(r.determinant_at_start[v], 3) << "view " << v;
    EXPECT_EQ(r.determinant_at_end[v], 3) << "view " << v;
  }
  EXPECT_GT(r.pulled_at, 1.0);  // the knot's slack taken up first: ~40 mm at 20 mm/s
  EXPECT_GE(r.held_force_min, 1.9);
  EXPECT_LT(r.late_max - r.late_min, 0.5);  // steady, not chattering
  EXPECT_GT(r.knot_length, 1e-3);           // the knot takes thread: not pulled straight
  EXPECT_GT(r.closest_strands, 0.9 * 2.0 * core::ThreadModel{}.radius);
  EXPECT_GT(r.self_contacts, 4);
  EXPECT_FALSE(r.broke);
  EXPECT_TRUE(r.finite);
  EXPECT_TRUE(r.ran_out_at_six);
  std::printf(
      "knot: pulled to 2 N at %.3f s; held still 2 s: pull at least %.3f N, %.3f-%.3f N over the "
      "last 0.5 s; knot length %.2f mm; closest strands %.3f mm (diameter %.3f mm); %d self "
      "contacts; Newton ran out in %d steps\n",
      r.pulled_at, r.held_force_min, r.late_min, r.late_max, r.knot_length * 1e3,
      r.closest_strands * 1e3, 2e3 * core::ThreadModel{}.radius, r.self_contacts, r.unconverged_steps);
}

// Friction between the strands (ThreadModel::self_friction, μ = 0.3) holds back the strands
// sliding through the knot as it tightens: at the same 2 N the knot is looser (takes over twice
// the thread the frictionless knot does) and still a trefoil.
TEST(ThreadKnot, FrictionBetweenTheStrandsResistsTheKnotsTightening) {
  NUMEN_SKIP_UNDER_SANITIZER("two pulls of the knot as above, figures of the thread's solve");
  const KnotPull frictionless = pull_knot(true, 1e5, 100.0, 2.0, 0.5);
  const KnotPull rough = pull_knot(true, 1e5, 100.0, 2.0, 0.5, 0.3);
  for (int v = 0; v < 3; ++v) EXPECT_EQ(rough.determinant_at_end[v], 3) << "view " << v;
  EXPECT_GT(rough.knot_length, 2.0 * frictionless.knot_length);
  EXPECT_FALSE(rough.broke);
  std::printf(
      "knot at 2 N: %.2f mm of thread frictionless, %.2f mm with mu 0.3 between the strands\n",
      1e3 * frictionless.knot_length, 1e3 * rough.knot_length);
}

// The same pull without self contact, and with the material's default stiffness (1e4 N/m): the
// strands pass through each other and the knot comes undone (determinant 1).
TEST(ThreadKnot, WithoutAStiffSelfContactTheKnotComesUndone) {
  NUMEN_SKIP_UNDER_SANITIZER("two pulls of the knot as above, figures of the thread's solve");
  for (const auto& [self, stiffness] : {std::pair{false, 1e5}, std::pair{true, 1e4}}) {
    const KnotPull r = pull_knot(self, stiffness, 100.0, 2.0, 0.5);
    for (int v = 0; v < 3; ++v)
      EXPECT_EQ(r.determinant_at_end[v], 1) << "self contact " << self << ", k " << stiffness;
  }
}

// The knot across the self contact's stiffness and the thread's drag (docs/thread.md "A
// knot"; label figures, ~30 s): the rig above pulled to 2 N and held 1 s at each of 1e5, 3e5 and
// 1e6 N/m and a drag of 1e-3 (the default), 3, 10 and 100 N·s/m². Printed as a table: whether it
// is still a trefoil and whole, and the held pull's range over the last 0.5 s. Checked: at 100 it
// holds at every stiffness; at 3 and at the default drag it holds at none (the limit the docs
// state: a change that lifts it fails here, and the docs are to be measured again).
TEST(ThreadKnotFigures, TheKnotAcrossSelfContactStiffnessAndDrag) {
  NUMEN_SKIP_UNDER_SANITIZER("twelve pulls of the knot, figures of the thread's solve");
  const double stiffness[] = {1e5, 3e5, 1e6};
  const double drag[] = {1e-3, 3.0, 10.0, 100.0};
  std::printf(
      "| self contact (N/m) | drag (N s/m^2) | a trefoil, whole | pulled to 2 N at (s) | held "
      "pull, last 0.5 s (N) | Newton ran out (steps) |\n");
  for (const double k : stiffness)
    for (const double c : drag) {
      const KnotPull r = pull_knot(true, k, c, 2.0, 1.0);
      bool trefoil = !r.broke && r.finite;
      for (int v = 0; v < 3; ++v) trefoil = trefoil && r.determinant_at_end[v] == 3;
      if (r.pulled_at >= 0.0) {
        std::printf("| %.0e | %g | %s | %.3f | %.3f-%.3f | %d |\n", k, c, trefoil ? "yes" : "no",
                    r.pulled_at, r.late_min, r.late_max, r.unconverged_steps);
      } else {
        std::printf("| %.0e | %g | %s | never | - | %d |\n", k, c, trefoil ? "yes" : "no", r.unconverged_steps);
      }
      EXPECT_TRUE(r.ran_out_at_six) << "k " << k << ", drag " << c << ": a step flagged before its 6 iterations";
      if (c >= 100.0) {
        EXPECT_TRUE(trefoil) << "k " << k << ", drag " << c;
      }
      if (c <= 3.0) {
        EXPECT_FALSE(trefoil) << "k " << k << ", drag " << c
                              << ": the limit is lifted; measure the docs again";
      }
    }
}

}  // namespace
}  // namespace numen
