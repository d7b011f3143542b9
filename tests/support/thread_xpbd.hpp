#pragma once
/// @file thread_xpbd.hpp
/// The candidate the thread's model was measured against (docs/thread.md, "Which model:
/// measured"): a position-based thread stepped by XPBD (Macklin, Müller & Chentanez 2016,
/// "XPBD: position-based simulation of compliant constrained dynamics", Eq. 18 and 26):
/// distance constraints between neighbouring nodes of compliance α = l0 / (E A), bending as
/// distance constraints between nodes two apart of compliance l0³ / (E I), Gauss–Seidel
/// iterations in node order, one substep. Minimal, for the comparison only (no contacts).
/// Header-only.

#include <cmath>
#include <vector>

#include "numen/core/thread.hpp"

namespace numen::test {

struct XpbdThread {
  std::vector<core::Vec3> x, v, p, f;  ///< Positions, velocities, predictions, external forces.
  std::vector<double> w;               ///< Inverse masses (0: pinned).
  double l0 = 0.0, alpha_stretch = 0.0, alpha_bend = 0.0, drag = 0.0;
  int iterations = 10;

  /// The straight thread of `t` along its direction from its start, node 0 pinned.
  explicit XpbdThread(const core::ThreadModel& t, int iterations) : iterations(iterations) {
    const auto n = static_cast<std::size_t>(t.segments + 1);
    const core::Vec3 dir = t.direction.normalized();
    l0 = t.length / t.segments;
    const double area = M_PI * t.radius * t.radius;
    const double inertia = M_PI * std::pow(t.radius, 4) / 4.0;
    alpha_stretch = l0 / (t.young_modulus * area);
    alpha_bend = std::pow(l0, 3) / (t.young_modulus * inertia);
    drag = t.damping * l0;
    const double m = t.density * area * l0;
    for (std::size_t i = 0; i < n; ++i) {
      x.push_back(t.start + (static_cast<double>(i) * l0) * dir);
      v.push_back(core::Vec3::Zero());
      f.push_back(core::Vec3::Zero());
      w.push_back(i == 0 ? 0.0 : (i + 1 == n ? 2.0 : 1.0) / m);
    }
    p = x;
  }

  void project(std::size_t i, std::size_t j, double rest, double alpha, double h, double& lambda) {
    const double wsum = w[i] + w[j];
    if (wsum == 0.0) return;
    const core::Vec3 d = p[i] - p[j];
    const double l = d.norm();
    if (l == 0.0) return;
    const double at = alpha / (h * h);
    const double dl = (-(l - rest) - at * lambda) / (wsum + at);
    lambda += dl;
    p[i] += (w[i] * dl / l) * d;
    p[j] -= (w[j] * dl / l) * d;
  }

  void step(double h, const core::Vec3& gravity) {
    const std::size_t n = x.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (w[i] > 0.0) {
        const double m = 1.0 / w[i];
        v[i] += h * (gravity + w[i] * (f[i] - drag * v[i]));
        (void)m;
      }
      p[i] = x[i] + h * v[i];
    }
    std::vector<double> ls(n, 0.0), lb(n, 0.0);
    for (int k = 0; k < iterations; ++k) {
      for (std::size_t i = 0; i + 1 < n; ++i) project(i, i + 1, l0, alpha_stretch, h, ls[i]);
      for (std::size_t i = 0; i + 2 < n; ++i) project(i, i + 2, 2.0 * l0, alpha_bend, h, lb[i]);
    }
    for (std::size_t i = 0; i < n; ++i) {
      v[i] = (p[i] - x[i]) / h;
      x[i] = p[i];
    }
  }

  double max_stretch() const {
    double s = 0.0;
    for (std::size_t i = 0; i + 1 < x.size(); ++i) s = std::max(s, (x[i + 1] - x[i]).norm() / l0 - 1.0);
    return s;
  }
};

}  // namespace numen::test
