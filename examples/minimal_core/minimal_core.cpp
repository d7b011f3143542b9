/// @file minimal_core.cpp
/// numen's core from code alone: one rigid body (a 10 mm sphere, 0.1 kg) held by the
/// device's coupling spring above a floor plane (z = 0, solid below). The device target
/// moves from 20 mm above the floor to 5 mm below it in 0.5 s and stays there: the
/// god-object stops on the floor, penetrating it by about coupling force / contact
/// stiffness, while the target goes through, and the feedback force pushes the hand back up.
/// Prints, every 100 steps, the target and body heights (m), the penetration (m) and the
/// feedback force (N, world); exit status 1 if the model is refused.

#include <cstdio>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/step.hpp"

namespace core = numen::core;

int main() {
  core::Model model;
  model.dt = 1e-3;                                // s
  model.gravity = core::Vec3::Zero();             // the hand carries the tool's weight
  model.material_names = {"default"};
  model.material_pairs = {core::MaterialPair{}};  // 1e4 N/m, 10 N·s/m, no friction

  core::BodyModel tool;
  tool.name = "tool";
  tool.mass = 0.1;                                          // kg
  tool.inertia_body = 4e-6 * core::Mat3::Identity();        // kg·m², (2/5) m r²
  tool.coupling = core::CouplingGains{100.0, 5.0, 0.1, 0.005};  // k_t N/m, γ_t N·s/m, k_r, γ_r
  tool.sphere_begin = 0;
  tool.sphere_count = 1;
  tool.initial_pose.position = core::Vec3(0.0, 0.0, 0.020);
  model.bodies.push_back(tool);
  model.body_spheres.push_back(core::Sphere{core::Vec3::Zero(), 0.010});

  core::Obstacle floor;
  floor.name = "floor";
  floor.type = core::ShapeType::kPlane;  // through pose.position, normal +z
  model.obstacles.push_back(floor);

  model.feedback = core::FeedbackGains{100.0, 1.0, 0.0, 0.0, 10.0, 1.0};  // Eq. 8, 10 N clamp
  model.initial_held_body = 0;
  if (const std::string err = core::finalize_model(model); !err.empty()) {
    std::fprintf(stderr, "minimal_core: %s\n", err.c_str());
    return 1;
  }

  core::Data data = core::make_data(model);  // every buffer allocated here, none in step()
  const double z0 = 0.020, z1 = -0.005, travel_time = 0.5;
  for (int k = 1; k <= 1000; ++k) {
    const double t = k * model.dt;
    const double s = t < travel_time ? t / travel_time : 1.0;
    data.target.position = core::Vec3(0.0, 0.0, z0 + s * (z1 - z0));
    data.target_twist.linear =
        core::Vec3(0.0, 0.0, t < travel_time ? (z1 - z0) / travel_time : 0.0);
    core::step(model, data);
    if (k % 100 == 0) {
      std::printf("t %.3f  target z %+.6f  body z %+.6f  penetration %.6f  feedback %+.4f %+.4f %+.4f\n",
                  t, data.target.position.z(), data.bodies[0].position.z(),
                  data.max_penetration, data.feedback_wrench.force.x(),
                  data.feedback_wrench.force.y(), data.feedback_wrench.force.z());
    }
  }
  std::printf("final penetration %.6f m, feedback z %+.4f N\n", data.max_penetration,
              data.feedback_wrench.force.z());
  return 0;
}
