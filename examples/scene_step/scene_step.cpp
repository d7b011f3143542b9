/// @file scene_step.cpp
/// Loads a numen scene and steps its core directly with a scripted target: the attached
/// tool's target moves on a straight line (20 mm along −z of the world in 0.5 s, then holds),
/// without the scene's recorded trajectory, device or bus. Every 100 steps it prints the
/// tool's pose (m, unit quaternion w x y z; world) and the device feedback wrench (N, N·m;
/// world), and at the end the deepest contact (m).
///
///   scene_step [SCENE.toml] [--steps N]     default: the installed default scene, 1000 steps
///
/// Exit status: 0, or 1 when the scene is refused (its located message on stderr).

#include <cstdio>
#include <cstdlib>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/version.hpp"

int main(int argc, char** argv) {
  std::string path = NUMEN_EXAMPLE_SCENE;
  int steps = 1000;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--steps" && i + 1 < argc) {
      steps = std::atoi(argv[++i]);
    } else {
      path = arg;
    }
  }

  numen::sim::Scene scene;
  try {
    scene = numen::sim::load_scene(path);
  } catch (const numen::sim::InputError& e) {
    std::fprintf(stderr, "scene_step: %s\n", e.what());
    return 1;
  }
  const numen::core::Model& model = scene.model;
  numen::core::Data data = numen::core::make_data(model);
  if (data.attached_body < 0) {
    std::fprintf(stderr, "scene_step: %s: no body is attached to the device\n", path.c_str());
    return 1;
  }
  std::printf("numen %s, scene '%s', dt %g s, %d bodies\n", NUMEN_VERSION, scene.name.c_str(),
              model.dt, model.num_bodies());

  // The scripted target: from the tool's initial pose, 20 mm down in 0.5 s, then held.
  const int tool = data.attached_body;
  const numen::core::Vec3 start = data.bodies[tool].position;
  const numen::core::Vec3 direction(0.0, 0.0, -1.0);
  const double length = 0.020, travel_time = 0.5;
  for (int k = 1; k <= steps; ++k) {
    const double t = k * model.dt;
    const double s = t < travel_time ? t / travel_time : 1.0;
    data.target.position = start + s * length * direction;
    data.target.orientation = model.bodies[tool].initial_pose.orientation;
    data.target_twist.linear = (t < travel_time ? length / travel_time : 0.0) * direction;
    numen::core::step(model, data);

    if (k % 100 == 0 || k == steps) {
      const numen::core::BodyState& b = data.bodies[tool];
      const numen::core::Wrench& f = data.feedback_wrench;
      std::printf("t %.3f  pos %+.6f %+.6f %+.6f  quat %+.6f %+.6f %+.6f %+.6f  "
                  "force %+.4f %+.4f %+.4f  torque %+.5f %+.5f %+.5f\n",
                  t, b.position.x(), b.position.y(), b.position.z(), b.orientation.w(),
                  b.orientation.x(), b.orientation.y(), b.orientation.z(), f.force.x(),
                  f.force.y(), f.force.z(), f.torque.x(), f.torque.y(), f.torque.z());
    }
  }
  std::printf("max penetration %.6f m\n", data.max_penetration);
  return 0;
}
