/// @file study_stability_rigid.cpp
/// Families "coupling", "contact" and "boundary" of `numen study stability`: one rigid body on
/// the coupling spring of Eq. 2, alone or pushed onto a penalty plane (study_stability.hpp).

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "numen/core/contact_force.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_stability_cases.hpp"

namespace numen::sim::stability {
namespace {

using core::Vec3;

constexpr double kRadius = 0.01;           // m, sphere of the body
constexpr double kOffset = 0.01;           // m, coupling grid: initial distance to the target
constexpr double kPush = 0.02;             // m, contact sweep: target depth below the plane
constexpr double kContactOmega2 = 2000.0;  // 1/s², contact sweep: k_t / m (ω_t = 44.7 rad/s)

/// 10^(a + i / per) for i = 0 … (b − a)·per.
std::vector<double> log_grid(double a, double b, int per) {
  std::vector<double> v;
  const int n = static_cast<int>(std::lround((b - a) * per));
  for (int i = 0; i <= n; ++i) v.push_back(std::pow(10.0, a + static_cast<double>(i) / per));
  return v;
}

std::vector<double> grid_steps_list(const StabilityOptions& o) {
  if (o.quick) return {1e-4, 1e-3, 1e-2};
  return {1e-4, 3e-4, 1e-3, 3e-3, 1e-2};
}

std::int64_t grid_steps(const StabilityOptions& o) {
  return o.grid_steps > 0 ? o.grid_steps : (o.quick ? 300 : 2000);
}

core::BodyModel sphere_body(double m) {
  core::BodyModel b;
  b.name = "tool";
  b.mass = m;
  b.inertia_body = 0.4 * m * kRadius * kRadius * core::Mat3::Identity();
  return b;
}

}  // namespace

const std::vector<core::Integrator>& integrators_of(const StabilityOptions& o) {
  return o.integrators.empty() ? study::all_integrators() : o.integrators;
}

StabilityRow coupling_run(core::Integrator integrator, double h, double m, double k, double zeta,
                          std::int64_t steps, const StabilityLimits& limits, Monitor* monitor_out) {
  core::Model base = empty_model();
  core::BodyModel b = sphere_body(m);
  b.coupling.k_t = k;
  b.coupling.gamma_t = core::damping_from_ratio(zeta, m, k);
  b.initial_pose.position = Vec3(kOffset, 0.0, 0.0);
  base.bodies = {b};
  base.initial_held_body = 0;
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  data.target = core::Pose{};  // make_data puts the target on the body: pull it back to the origin
  Monitor monitor(limits, kInf, kInf, steps);
  drive(
      model, data, steps, [](std::int64_t, core::Data&) noexcept {}, monitor);
  StabilityRow row = make_row("coupling", zeta == 0.0 ? "coupling-undamped" : "coupling-damped",
                              integrator, h, m, k, zeta, "zeta", std::sqrt(k / m) * h);
  monitor.fill(row);
  if (monitor_out) *monitor_out = monitor;
  return row;
}

void plan_coupling(const StabilityOptions& o, Plan& plan) {
  const int per = o.quick ? 1 : 4;
  const std::int64_t steps = grid_steps(o);
  const StabilityLimits limits = o.limits;
  for (double zeta : {0.0, 0.85})
    for (core::Integrator integrator : integrators_of(o))
      for (double h : grid_steps_list(o))
        for (double m : log_grid(-3, 2, per))
          for (double k : log_grid(1, 8, per))
            plan.add("coupling", zeta == 0.0 ? "coupling-undamped" : "coupling-damped",
                     case_parameters(integrator, {{"h", h}, {"m", m}, {"k", k}, {"zeta", zeta}}),
                     kGridWeight, [=](StabilityResult& r) {
                       r.rows.push_back(coupling_run(integrator, h, m, k, zeta, steps, limits));
                     });
}

StabilityRow contact_run(core::Integrator integrator, double h, double m, double k_c, double zeta_c,
                         std::int64_t steps, const StabilityLimits& limits) {
  core::MaterialPair pair;
  pair.stiffness = k_c;
  pair.damping = core::damping_from_ratio(zeta_c, m, k_c);
  pair.friction = 0.0;
  core::Model base = empty_model(pair);
  base.body_spheres = {core::Sphere{Vec3::Zero(), kRadius}};
  core::BodyModel b = sphere_body(m);
  b.sphere_begin = 0;
  b.sphere_count = 1;
  b.coupling.k_t = kContactOmega2 * m;
  b.coupling.gamma_t = core::damping_from_ratio(0.85, m, b.coupling.k_t);
  b.coupling.k_r = kContactOmega2 * b.inertia_body(0, 0);
  b.coupling.gamma_r = core::damping_from_ratio(0.85, b.inertia_body(0, 0), b.coupling.k_r);
  b.initial_pose.position = Vec3(0.0, 0.0, kRadius);  // touching, at rest
  base.bodies = {b};
  core::Obstacle plane;
  plane.name = "wall";
  plane.type = core::ShapeType::kPlane;  // z < 0 is solid
  base.obstacles = {plane};
  base.initial_held_body = 0;
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  data.target.position = Vec3(0.0, 0.0, kRadius - kPush);
  const double k_t = b.coupling.k_t;
  // The stiffness the contact acts with: k_c, or its clamp by the core's time-constant floor
  // (the lever arm is along the normal: the effective mass is m).
  const double k_eff =
      std::min(k_c, core::contact_stiffness_limit(m, h, model.solver.contact_max_omega_dt));
  const double static_depth = k_t * kPush / (k_t + k_eff);
  Monitor monitor(limits, limits.penetration_factor * static_depth, kInf, steps, m, h);
  drive(
      model, data, steps, [](std::int64_t, core::Data&) noexcept {}, monitor);
  StabilityRow row =
      make_row("contact", zeta_c == 0.0 ? "contact-undamped" : "contact-damped", integrator, h, m,
               k_c, zeta_c, "contact_zeta", std::sqrt((k_c + k_t) / m) * h);
  monitor.fill(row);
  return row;
}

void plan_contact(const StabilityOptions& o, Plan& plan) {
  const int per = o.quick ? 1 : 4;
  const std::int64_t steps = grid_steps(o);
  const StabilityLimits limits = o.limits;
  for (double zeta_c : {0.0, 0.5})
    for (core::Integrator integrator : integrators_of(o))
      for (double m : {1e-3, 1e-1, 1e1})
        for (double h : grid_steps_list(o))
          for (double k_c : log_grid(2, 8, per))
            plan.add("contact", zeta_c == 0.0 ? "contact-undamped" : "contact-damped",
                     case_parameters(integrator,
                                     {{"m", m}, {"h", h}, {"k_c", k_c}, {"contact_zeta", zeta_c}}),
                     kGridWeight, [=](StabilityResult& r) {
                       r.rows.push_back(contact_run(integrator, h, m, k_c, zeta_c, steps, limits));
                     });
}

StabilityBoundary boundary_run(double zeta, bool quick, const StabilityLimits& limits) {
  constexpr double kH = 1e-3, kM = 1.0;
  constexpr std::int64_t kSteps = 4000;
  StabilityBoundary b;
  b.zeta = zeta;
  b.theory_omega_dt = 2.0 * (std::sqrt(1.0 + zeta * zeta) - zeta);
  b.verdict_theory_omega_dt = zeta == 0.0 ? 2.0 * (1.0 - 1.0 / limits.energy_factor) : kNaN;
  b.steps = kSteps;
  StabilityLimits unbounded = limits;
  unbounded.energy_factor = kInf;
  // One run at ω h = a: (growth ratio, verdict stable).
  auto run = [&](double a, bool record) {
    const double k = kM * (a / kH) * (a / kH);
    Monitor growth(unbounded, kInf, kInf, kSteps);
    const StabilityRow g = coupling_run(core::Integrator::kSymplecticEuler, kH, kM, k, zeta, kSteps,
                                        unbounded, &growth);
    const StabilityRow v =
        coupling_run(core::Integrator::kSymplecticEuler, kH, kM, k, zeta, kSteps, limits);
    if (record) {
      b.omega_dt.push_back(a);
      b.energy_ratio.push_back(g.stable ? g.energy_ratio_max : kInf);
      b.growth_ratio.push_back(growth.growth_ratio());
    }
    return std::pair<bool, bool>{growth.growth_ratio() <= 1.5, v.stable};
  };
  // Coarse sweep in ω h, then bisection of each criterion between its last pass and first fail.
  const double step = quick ? 0.05 : 0.01;
  double grow_lo = 0.0, grow_hi = kInf, ver_lo = 0.0, ver_hi = kInf;
  for (double a = step; a <= 3.0 + 1e-12; a += step) {
    const auto [bounded, stable] = run(a, true);
    if (bounded && grow_hi == kInf) grow_lo = a;
    if (!bounded && grow_hi == kInf) grow_hi = a;
    if (stable && ver_hi == kInf) ver_lo = a;
    if (!stable && ver_hi == kInf) ver_hi = a;
  }
  for (int i = 0; i < 20 && grow_hi - grow_lo > 1e-5; ++i) {
    const double mid = 0.5 * (grow_lo + grow_hi);
    (run(mid, false).first ? grow_lo : grow_hi) = mid;
  }
  for (int i = 0; i < 20 && ver_hi - ver_lo > 1e-5; ++i) {
    const double mid = 0.5 * (ver_lo + ver_hi);
    (run(mid, false).second ? ver_lo : ver_hi) = mid;
  }
  b.measured_growth_omega_dt = grow_lo;
  b.measured_verdict_omega_dt = ver_lo;
  return b;
}

void plan_boundary(const StabilityOptions& o, Plan& plan) {
  const bool quick = o.quick;
  const StabilityLimits limits = o.limits;
  for (double zeta : {0.0, 0.85})
    plan.add("boundary", zeta == 0.0 ? "boundary-undamped" : "boundary-damped",
             case_parameters(core::Integrator::kSymplecticEuler,
                             {{"h", 1e-3}, {"m", 1.0}, {"zeta", zeta}}),
             kBoundaryWeight, [=](StabilityResult& r) {
               r.boundaries.push_back(boundary_run(zeta, quick, limits));
             });
}

}  // namespace numen::sim::stability
