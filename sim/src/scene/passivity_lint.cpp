/// @file passivity_lint.cpp
/// The passivity lint of a closed-loop scene (passivity_lint.hpp).

#include "numen/sim/scene/passivity_lint.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/trajectory_motion.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

std::vector<PassivityLintRow> passivity_lint(const Scene& scene) {
  std::vector<PassivityLintRow> rows;
  if (!scene.plant) return rows;
  const core::Model& m = scene.model;
  core::Vec6 k, c;
  if (m.coupling_mode == core::CouplingMode::kDirect) {
    double stiffest = 0.0;
    for (int a = 0; a < m.num_materials(); ++a)
      for (int b = 0; b < m.num_materials(); ++b)
        stiffest = std::max(stiffest, m.material_pair(a, b).stiffness);
    k << stiffest, stiffest, stiffest, 0.0, 0.0, 0.0;
    c.setZero();
  } else {
    const core::FeedbackGains& f = m.feedback;
    k << f.k_t, f.k_t, f.k_t, f.k_r, f.k_r, f.k_r;
    c << f.gamma_t, f.gamma_t, f.gamma_t, f.gamma_r, f.gamma_r, f.gamma_r;
  }
  const auto kinematics = hal::make_kinematics(scene.device);
  const int n = kinematics->num_axes();
  std::vector<double> k_axis(static_cast<std::size_t>(n), 0.0), b_axis(k_axis);
  // The trajectory's poses, about 500 of them.
  const std::size_t samples = std::max<std::size_t>(scene.trajectory.size(), 1);
  const std::size_t stride = std::max<std::size_t>(samples / 500, 1);
  const double dt = m.dt;
  for (std::size_t s = 0; s < samples; s += stride) {
    const hal::AxisVector q =
        instrument_axes(scene.device, *kinematics, scene.trajectory.at(static_cast<double>(s) * dt));
    const hal::Jacobian j = kinematics->jacobian(q);
    for (int i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      k_axis[u] = std::max(k_axis[u], j.col(i).cwiseAbs2().dot(k));
      b_axis[u] = std::max(b_axis[u], j.col(i).cwiseAbs2().dot(c));
    }
  }
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const AxisPlantSettings& p = scene.plant->axes[u];
    const hal::AxisConfig& a = scene.device.axes[u];
    if (p.inertia == 0.0 || a.drive_cob_id == 0) continue;  // follows the hand / no drive
    PassivityLintRow r;
    r.axis = i;
    r.axis_name = a.name;
    r.period_s = dt;
    r.stiffness = k_axis[u];
    r.damping = b_axis[u];
    r.device_damping = p.damping;
    r.coulomb = p.coulomb;
    r.resolution = 1.0 / a.counts_per_unit;
    r.colgate_margin = p.damping - (r.stiffness * dt / 2.0 + std::abs(r.damping));
    r.abbott_okamura_bound = std::max(2.0 * p.damping / dt, 2.0 * p.coulomb / r.resolution);
    r.passes = r.colgate_margin > 0.0 || r.stiffness <= r.abbott_okamura_bound;
    rows.push_back(r);
  }
  return rows;
}

std::string passivity_lint_warning(const PassivityLintRow& r) {
  std::ostringstream os;
  os << std::setprecision(3) << "device axis \"" << r.axis_name << "\": the feedback coupling "
     << "([device.feedback]) renders K = " << r.stiffness << ", B = " << r.damping
     << " on it at T = " << r.period_s << " s, and its plant ([device.plant] damping["
     << r.axis << "] = " << r.device_damping << ", coulomb[" << r.axis << "] = " << r.coulomb
     << ", encoder count " << r.resolution << ") meets neither b > K T/2 + |B| = "
     << r.stiffness * r.period_s / 2.0 + std::abs(r.damping)
     << " (Colgate & Schenkel 1997) nor K <= max(2b/T, 2 f_c/Δ) = " << r.abbott_okamura_bound
     << " (Abbott & Okamura 2005): the haptic loop may not be passive (docs/device_plant.md, "
        "\"Passivity lint\")";
  return os.str();
}

}  // namespace numen::sim
