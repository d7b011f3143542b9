/// @file study_stability_articulation.cpp
/// Family "articulation" of `numen study stability` (study_stability.hpp): mass ratios inside an
/// articulated god-object (paper Eq. 4–7).
///
/// Two bodies joined by a revolute joint about z at the middle of their 10 cm separation: the
/// held one (0.1 kg, inertia 0.4 m r², r = 20 mm) on its coupling springs (k_t = 200 N/m,
/// k_r = 0.05 N·m/rad, ζ = 0.85), the other of 0.1 kg × ratio, ratio 1e-4 … 1e4, free. The
/// target is 20 mm aside (along y) and turns about z at 10 rad/s: the held body is pulled sideways
/// and spun up, the other swings about the joint and is carried round it (the joint carries its
/// centripetal load, ∝ the mass ratio). No gravity. Joint drift (Data::max_joint_drift) must stay
/// below 5 mm (10 % of the lever arm).

#include <cmath>
#include <numbers>
#include <cstdio>

#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim::stability {
namespace {

using core::Vec3;

constexpr double kRootMass = 0.1, kR = 0.02, kLever = 0.05, kSpin = 10.0;

std::vector<double> articulation_steps(const StabilityOptions& o) {
  if (o.quick) return {1e-3, 1e-2};
  return {1e-4, 1e-3, 1e-2};
}

std::vector<double> ratios(const StabilityOptions& o) {
  if (o.quick) return {1e-4, 1.0, 1e4};
  return {1e-4, 1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3, 1e4};
}

core::BodyModel body(const char* name, double m, const Vec3& at) {
  core::BodyModel b;
  b.name = name;
  b.mass = m;
  b.inertia_body = 0.4 * m * kR * kR * core::Mat3::Identity();
  b.initial_pose.position = at;
  return b;
}

StabilityRow articulation_run(core::Integrator integrator, double h, double ratio,
                              const StabilityLimits& limits, double horizon) {
  core::Model base = empty_model();
  core::BodyModel root = body("held", kRootMass, Vec3::Zero());
  root.coupling.k_t = 200.0;
  root.coupling.gamma_t = core::damping_from_ratio(0.85, kRootMass, 200.0);
  root.coupling.k_r = 0.05;
  root.coupling.gamma_r = core::damping_from_ratio(0.85, root.inertia_body(0, 0), 0.05);
  base.bodies = {root, body("swinging", kRootMass * ratio, Vec3(2.0 * kLever, 0.0, 0.0))};
  core::JointModel j;
  j.name = "hinge";
  j.type = core::JointType::kRevolute;
  j.parent = 0;
  j.child = 1;
  j.frame_parent.position = Vec3(kLever, 0.0, 0.0);
  j.frame_child.position = Vec3(-kLever, 0.0, 0.0);
  base.joints = {j};
  base.initial_held_body = 0;
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  data.target.position = Vec3(0.0, 0.02, 0.0);
  const auto n = std::max<std::int64_t>(1, std::llround(horizon / h));
  Monitor monitor(limits, kInf, kDriftBound, n);
  drive(
      model, data, n,
      [h](std::int64_t k, core::Data& d) noexcept {
        const double t = static_cast<double>(k) * h;
        d.target.orientation =
            core::Quat(Eigen::AngleAxisd(std::fmod(kSpin * t, 2.0 * std::numbers::pi), Vec3::UnitZ()));
        d.target_twist.angular = Vec3(0.0, 0.0, kSpin);
      },
      monitor);
  StabilityRow r = make_row("articulation", "revolute-pair", integrator, h, kRootMass, 200.0, ratio,
                            "mass_ratio", std::sqrt(200.0 / kRootMass) * h);
  monitor.fill(r);
  char note[96];
  std::snprintf(note, sizeof note, "final body rate %.2f rad/s, angle drift %.3g rad at the end",
                data.bodies[1].angular_velocity.norm(), data.max_joint_angle_drift);
  r.note = note;
  return r;
}

}  // namespace

void plan_articulation(const StabilityOptions& o, Plan& plan) {
  const double horizon = o.quick ? 0.3 : 1.0;
  const StabilityLimits limits = o.limits;
  for (core::Integrator integrator : integrators_of(o))
    for (double h : articulation_steps(o))
      for (double ratio : ratios(o))
        plan.add("articulation", "revolute-pair",
                 case_parameters(integrator, {{"h", h}, {"mass_ratio", ratio}}),
                 kArticulationWeight, [=](StabilityResult& r) {
                   r.rows.push_back(articulation_run(integrator, h, ratio, limits, horizon));
                 });
}

}  // namespace numen::sim::stability
