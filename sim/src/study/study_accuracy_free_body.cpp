/// @file study_accuracy_free_body.cpp
/// Case "free-body" of the accuracy study: the coupled rigid body in free space against the
/// closed form of the damped oscillator (paper Eq. 1–2; docs/accuracy.md).
///
/// One body, no gravity, no contact, a fixed target. Translation: m ẍ + γ_t ẋ + k_t x = 0 per
/// axis (x the offset from the target). Rotation about the body's principal axis z: the angle
/// θ of q q_t⁻¹ about a = q_t · z obeys I_zz θ̈ + γ_r θ̇ + k_r θ = 0 exactly (the coupling
/// torque k_r θu is linear in θ about a fixed axis, and ω × Iω = 0 for ω along a principal
/// axis). Both are underdamped: ζ_t = 0.7, ζ_r = 0.3.

#include <Eigen/Geometry>
#include <cmath>

#include "numen/core/data.hpp"
#include "numen/core/rigid_body.hpp"
#include "study_accuracy_cases.hpp"

namespace numen::sim::accuracy {
namespace {

using core::Quat;
using core::Vec3;

constexpr double kMass = 0.1;         // kg
constexpr double kInertiaZ = 4e-5;    // kg·m², principal axis z
constexpr double kStiffness = 200.0;  // N/m (ω_n = 44.7 rad/s)
constexpr double kDampingRatio = 0.7;
constexpr double kRotStiffness = 0.05;  // N·m/rad (ω_n = 35.4 rad/s)
constexpr double kRotDampingRatio = 0.3;
constexpr double kAngle0 = 0.05;  // rad

/// x(t) of m ẍ + γ ẋ + k x = 0, x(0) = x0, ẋ(0) = 0, underdamped (ζ < 1).
double oscillator(double m, double k, double zeta, double x0, double t) noexcept {
  const double wn = std::sqrt(k / m);
  const double wd = wn * std::sqrt(1.0 - zeta * zeta);
  return std::exp(-zeta * wn * t) * x0 * (std::cos(wd * t) + zeta * wn / wd * std::sin(wd * t));
}

class FreeBodyCase final : public AccuracyCase {
 public:
  FreeBodyCase() {
    model_.gravity = Vec3::Zero();
    model_.material_pairs = {core::MaterialPair{}};
    core::BodyModel b;
    b.name = "tool";
    b.mass = kMass;
    b.inertia_body = Vec3(2e-5, 3e-5, kInertiaZ).asDiagonal();
    b.coupling.k_t = kStiffness;
    b.coupling.gamma_t = core::damping_from_ratio(kDampingRatio, kMass, kStiffness);
    b.coupling.k_r = kRotStiffness;
    b.coupling.gamma_r = core::damping_from_ratio(kRotDampingRatio, kInertiaZ, kRotStiffness);
    target_.position = Vec3(0.05, -0.02, 0.1);
    target_.orientation = Quat(Eigen::AngleAxisd(0.4, Vec3(1.0, 2.0, 3.0).normalized()));
    axis_ = target_.orientation * Vec3::UnitZ();
    b.initial_pose.position = target_.position + offset_;
    b.initial_pose.orientation = Quat(Eigen::AngleAxisd(kAngle0, axis_)) * target_.orientation;
    model_.bodies = {b};
    model_.initial_held_body = 0;
  }

  double default_horizon() const override { return 1.0; }
  bool has_closed_form() const override { return true; }

  Samples simulate(core::Integrator integrator, double dt, double horizon) const override {
    const core::Model model = with_scheme(model_, integrator, dt);
    core::Data data = core::make_data(model);
    data.target = target_;
    data.target_twist = core::Twist{};
    return run_stepping(
        model, data, horizon, [](double, double, core::Data&) noexcept {},
        [](const core::Data& d, Samples& s) {
          s.points.push_back(d.bodies[0].position);
          s.frames.push_back(d.bodies[0].orientation);
        },
        1, 1);
  }

  Samples exact(double horizon) const override {
    Samples s;
    s.points_per_sample = 1;
    s.frames_per_sample = 1;
    const auto n = static_cast<int>(std::lround(horizon / kSamplePeriod));
    for (int k = 1; k <= n; ++k) {
      const double t = k * kSamplePeriod;
      Vec3 x;
      for (int j = 0; j < 3; ++j)
        x(j) = oscillator(kMass, kStiffness, kDampingRatio, offset_(j), t);
      const double th = oscillator(kInertiaZ, kRotStiffness, kRotDampingRatio, kAngle0, t);
      s.points.push_back(target_.position + x);
      s.frames.push_back(Quat(Eigen::AngleAxisd(th, axis_)) * target_.orientation);
    }
    return s;
  }

 private:
  core::Model model_;
  core::Pose target_;
  Vec3 axis_ = Vec3::UnitZ();
  Vec3 offset_ = Vec3(0.010, -0.006, 0.004);  // m
};

}  // namespace

std::unique_ptr<AccuracyCase> make_free_body_case() { return std::make_unique<FreeBodyCase>(); }

}  // namespace numen::sim::accuracy
