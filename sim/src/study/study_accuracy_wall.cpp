/// @file study_accuracy_wall.cpp
/// Case "wall" of the accuracy study: a sphere god-object (paper Eq. 1–2) pushed into a wall
/// (penalty contact, §5) while it slides along it.
///
/// One body (m = 0.1 kg, a 10 mm sphere), no gravity, coupling k_t = 200 N/m (ζ = 0.85),
/// k_r = 1e-3 N·m/rad (ζ = 0.85). The wall is the half-space z < 0 with k = 2e4 N/m,
/// c = 10 N·s/m and viscous friction μ = 0.5 N·s/m (the friction torque turns the sphere, so
/// the orientation error is not trivially zero). The target's centre moves from (0, 0, 20) mm
/// to (30, 0, −10) mm along a quintic smoothstep over 0.6 s (C² input), then holds: the sphere
/// touches at z = 10 mm and the target ends 20 mm inside the wall (the contact carries
/// k_t · 20 mm = 4 N, about 0.2 mm of penetration). Compared with a reference run.
/// Case "wall-smoothed": the same with the smoothed C¹ onset over δ0 = kWallOnsetDepth
/// (core::MaterialPair::onset_depth; rest depth 0.25 mm).

#include <algorithm>
#include <cmath>

#include "numen/core/data.hpp"
#include "study_accuracy_cases.hpp"

namespace numen::sim::accuracy {
namespace {

using core::Vec3;

constexpr double kMove = 0.6;  // s

class WallCase final : public AccuracyCase {
 public:
  explicit WallCase(double onset_depth) {
    model_.gravity = Vec3::Zero();
    model_.material_pairs = {core::MaterialPair{2e4, 10.0, 0.5, onset_depth}};
    model_.body_spheres = {core::Sphere{Vec3::Zero(), 0.01}};
    core::BodyModel b;
    b.name = "sphere";
    b.mass = 0.1;
    b.inertia_body = 4e-6 * core::Mat3::Identity();  // 2/5 m r²
    b.sphere_begin = 0;
    b.sphere_count = 1;
    b.coupling.k_t = 200.0;
    b.coupling.gamma_t = core::damping_from_ratio(0.85, b.mass, b.coupling.k_t);
    b.coupling.k_r = 1e-3;
    b.coupling.gamma_r = core::damping_from_ratio(0.85, 4e-6, b.coupling.k_r);
    b.initial_pose.position = from_;
    model_.bodies = {b};
    core::Obstacle wall;
    wall.name = "wall";
    wall.type = core::ShapeType::kPlane;  // normal +z through the origin
    model_.obstacles = {wall};
    model_.initial_held_body = 0;
  }

  double default_horizon() const override { return 1.0; }
  double step_cost() const override { return 1.5; }

  Samples simulate(core::Integrator integrator, double dt, double horizon) const override {
    const core::Model model = with_scheme(model_, integrator, dt);
    core::Data data = core::make_data(model);
    const Vec3 delta = to_ - from_;
    return run_stepping(
        model, data, horizon,
        [&](double, double t, core::Data& d) noexcept {
          // Quintic smoothstep s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, τ = t / kMove in [0, 1].
          const double tau = std::clamp(t / kMove, 0.0, 1.0);
          const double s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
          const double ds = 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / kMove;
          d.target.position = from_ + s * delta;
          d.target_twist.linear = ds * delta;
          d.target_twist.angular.setZero();
        },
        [](const core::Data& d, Samples& s) {
          s.points.push_back(d.bodies[0].position);
          s.frames.push_back(d.bodies[0].orientation);
        },
        1, 1);
  }

 private:
  core::Model model_;
  Vec3 from_ = Vec3(0.0, 0.0, 0.02);
  Vec3 to_ = Vec3(0.03, 0.0, -0.01);
};

}  // namespace

std::unique_ptr<AccuracyCase> make_wall_case(double onset_depth) {
  return std::make_unique<WallCase>(onset_depth);
}

}  // namespace numen::sim::accuracy
