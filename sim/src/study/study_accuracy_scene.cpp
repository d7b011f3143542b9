/// @file study_accuracy_scene.cpp
/// Cases "articulated" and "deformable" of the accuracy study: a shipped scene's god-object
/// driven by its recorded trajectory, straight into core::step (no bus, no encoder
/// quantisation: the integrator's error alone).
///
/// Input. The recording gives tool poses (sim/data, JIGSAWS at 30 Hz, interpolated linearly by the
/// trajectory): piecewise linear, so its velocity jumps at every sample and the coupling damping
/// force γ (v_t − v) with it — a jump a one-step method integrates with an O(h) error whatever
/// its order. The case therefore takes the instrument's axis values (instrument_axes(), the
/// encoder values of the simulated instrument) every 40 ms and joins them by a C¹ cubic
/// (Catmull–Rom: Hermite with tangents (q_{k+1} − q_{k−1}) / 2Δ), then gives every bound body
/// its link's pose and twist J_l(q) q̇ through the same binding rules as platform::ControlLoop
/// (platform::bound_body(), body_target_of(), set_body_target()) and
/// every prescribed joint (the jaws) its axis value (at the step's start) and rate.
///
/// Solver. The linear solves run to a relative residual of 1e-9 (at most 1000 iterations)
/// instead of the scene's tolerance, so that the CPU times are those of a tight solve.
///
/// Start. At the window's start t0 every bound body is placed at its target with its target
/// twist, every net node at its rest position on its rigid component, moving with it.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "numen/core/data.hpp"
#include "numen/hal/device/kinematics.hpp"
#include "numen/hal/device/kinematics_factory.hpp"
#include "numen/sim/device/simulated_instrument.hpp"
#include "numen/sim/scene/scene.hpp"
#include "study_accuracy_cases.hpp"

namespace numen::sim::accuracy {
namespace {

using core::Vec3;

constexpr double kKnotSpacing = 0.04;  // s
/// Relative residual of the linear solves in the study: far below the integrators' errors, so
/// that the error measured is the integrator's, not the solver's (with the shipped deformable
/// scene's 1e-3, the trapezoidal rule's error stops falling at ~7e-6 mm below h = 0.2 ms).
constexpr double kSolverTolerance = 1e-9;

class SceneCase final : public AccuracyCase {
 public:
  SceneCase(const std::string& path, double t0, double horizon, double step_cost)
      : scene_(load_scene(path)),
        kinematics_(hal::make_kinematics(scene_.device)),
        t0_(t0),
        horizon_(horizon),
        step_cost_(step_cost) {
    binding_ = scene_.binding;
    if (binding_.links.empty()) binding_ = platform::DeviceBinding::rigid();
    explicit_bound_ = platform::explicitly_bound_bodies(binding_, scene_.model.num_bodies());
    // Knots t0 + (k − 2) Δ, k = 0 … K, covering [t0 − 2Δ, t0 + horizon + 2Δ].
    const int knots = static_cast<int>(std::ceil(horizon / kKnotSpacing)) + 5;
    for (int k = 0; k < knots; ++k) {
      const double t = t0 + (k - 2) * kKnotSpacing;
      hal::AxisVector q = instrument_axes(scene_.device, *kinematics_, scene_.trajectory.at(t));
      if (!knots_.empty()) {  // unwrap angles (linear axes move far less than π per knot)
        const hal::AxisVector& prev = knots_.back();
        for (int a = 0; a < q.size(); ++a)
          q(a) = prev(a) + std::remainder(q(a) - prev(a), 2.0 * std::numbers::pi);
      }
      knots_.push_back(q);
    }
  }

  double default_horizon() const override { return horizon_; }
  double step_cost() const override { return step_cost_; }

  Samples simulate(core::Integrator integrator, double dt, double horizon) const override {
    if (horizon > horizon_ + 1e-9)
      throw std::invalid_argument("accuracy study: horizon beyond the case's input window");
    core::Model tight = scene_.model;
    tight.solver.tolerance = std::min(tight.solver.tolerance, kSolverTolerance);
    if (tight.solver.error_tolerance > 0.0)
      tight.solver.error_tolerance = std::min(tight.solver.error_tolerance, kSolverTolerance);
    tight.solver.max_iterations = std::max(tight.solver.max_iterations, 1000);
    const core::Model model = with_scheme(tight, integrator, dt);
    core::Data data = core::make_data(model);
    data.held_body = model.initial_held_body;
    apply_inputs(0.0, 0.0, data);
    place_at_targets(model, data);
    const int nb = model.num_bodies();
    const int nn = model.num_nodes();
    return run_stepping(
        model, data, horizon,
        [&](double t, double t_in, core::Data& d) noexcept { apply_inputs(t, t_in, d); },
        [nb, nn](const core::Data& d, Samples& s) {
          for (int i = 0; i < nb; ++i) {
            s.points.push_back(d.bodies[static_cast<std::size_t>(i)].position);
            s.frames.push_back(d.bodies[static_cast<std::size_t>(i)].orientation);
          }
          for (int i = 0; i < nn; ++i)
            s.points.push_back(d.nodes[static_cast<std::size_t>(i)].position);
        },
        nb + nn, nb);
  }

 private:
  /// Axis values and rates at case time t (trajectory time t0 + t): Catmull–Rom.
  void axes_at(double t, hal::AxisVector& q, hal::AxisVector& qdot) const noexcept {
    const double x = t / kKnotSpacing + 2.0;  // knot coordinate
    int k = static_cast<int>(std::floor(x));
    k = std::max(1, std::min(k, static_cast<int>(knots_.size()) - 3));
    const double u = x - k;
    const auto& q0 = knots_[static_cast<std::size_t>(k)];
    const auto& q1 = knots_[static_cast<std::size_t>(k + 1)];
    const hal::AxisVector m0 = 0.5 * (q1 - knots_[static_cast<std::size_t>(k - 1)]);
    const hal::AxisVector m1 = 0.5 * (knots_[static_cast<std::size_t>(k + 2)] - q0);
    const double u2 = u * u, u3 = u2 * u;
    q = (2 * u3 - 3 * u2 + 1) * q0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * q1 +
        (u3 - u2) * m1;
    qdot = ((6 * u2 - 6 * u) * q0 + (3 * u2 - 4 * u + 1) * m0 + (-6 * u2 + 6 * u) * q1 +
            (3 * u2 - 2 * u) * m1) /
           kKnotSpacing;
  }

  /// Targets of the bound bodies at t_in, prescribed joints' values at t and rates at t_in.
  void apply_inputs(double t, double t_in, core::Data& d) const noexcept {
    hal::AxisVector q, qdot;
    axes_at(t_in, q, qdot);
    for (const platform::LinkBinding& b : binding_.links) {
      const int body = platform::bound_body(b, d, explicit_bound_);
      if (body < 0) continue;
      const core::Pose link = kinematics_->link_pose(b.link, q);
      const core::Vec6 lt = kinematics_->link_jacobian(b.link, q) * qdot;
      core::Twist link_twist;
      link_twist.linear = lt.head<3>();
      link_twist.angular = lt.tail<3>();
      core::Pose pose;
      core::Twist twist;
      platform::body_target_of(b, link, link_twist, pose, twist);
      platform::set_body_target(d, body, pose, twist);
    }
    if (binding_.prescriptions.empty()) return;
    hal::AxisVector q_start = q, qdot_start = qdot;
    if (t != t_in) axes_at(t, q_start, qdot_start);
    for (const platform::AxisPrescription& p : binding_.prescriptions) {
      core::JointPrescription& jp = d.joint_prescribed[static_cast<std::size_t>(p.joint)];
      jp.value = p.scale * q_start(p.axis) + p.offset;
      jp.rate = p.scale * qdot(p.axis);
    }
  }

  /// Bodies at their targets, nodes at rest on their rigid components (rigid velocity).
  static void place_at_targets(const core::Model& model, core::Data& d) {
    for (int i = 0; i < model.num_bodies(); ++i) {
      const auto b = static_cast<std::size_t>(i);
      const core::BodyTarget* t = nullptr;
      core::BodyTarget held;
      if (i == d.held_body) {
        held.pose = d.target;
        held.twist = d.target_twist;
        t = &held;
      } else if (d.body_targets[b].enabled) {
        t = &d.body_targets[b];
      }
      if (!t) continue;
      d.bodies[b].position = t->pose.position;
      d.bodies[b].orientation = t->pose.orientation;
      d.bodies[b].linear_velocity = t->twist.linear;
      d.bodies[b].angular_velocity = t->twist.angular;
    }
    for (const core::NetModel& net : model.nets) {
      const core::BodyState& b = d.bodies[static_cast<std::size_t>(net.body)];
      for (int i = net.node_begin; i < net.node_begin + net.node_count; ++i) {
        const auto n = static_cast<std::size_t>(i);
        const Vec3 r = b.orientation * model.node_rest[n];
        d.nodes[n].position = b.position + r;
        d.nodes[n].velocity = b.linear_velocity + b.angular_velocity.cross(r);
      }
    }
  }

  Scene scene_;
  std::unique_ptr<hal::Kinematics> kinematics_;
  platform::DeviceBinding binding_;
  std::vector<std::uint8_t> explicit_bound_;
  std::vector<hal::AxisVector> knots_;
  double t0_;
  double horizon_;
  double step_cost_;
};

}  // namespace

std::unique_ptr<AccuracyCase> make_scene_case(const std::string& scene_path, double t0,
                                              double horizon, double step_cost) {
  return std::make_unique<SceneCase>(scene_path, t0, horizon, step_cost);
}

}  // namespace numen::sim::accuracy
