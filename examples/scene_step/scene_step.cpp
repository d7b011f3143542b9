/// @file scene_step.cpp
/// Loads a numen scene to step it from this program (SceneOverrides::caller_steps: a scene
/// without [trajectory] or [device], such as the shipped probe.toml, loads) and steps its core
/// directly with a custom target: the target of the held body's centre of mass (Data::target,
/// world; not the instrument's tool frame of the scene's trajectory) moves on a straight line,
/// 20 mm along −z of the world in 0.5 s, then holds, without the scene's trajectory, device or
/// bus. Every 100 steps it prints the held body's pose (m, unit quaternion w x y z; world) and
/// the device feedback wrench (N, N·m; world), and at the end the deepest contact (m) with the
/// obstacle (or body) it touches and the steps whose target was invalid. For a scene with a
/// trajectory it first prints how far the trajectory's sample (the tool frame: a trocar
/// instrument's tip) is from the held body's target that sample gives (sim::InstrumentTargets,
/// what `numen run` sets from the encoders).
///
///   scene_step [SCENE.toml] [--steps N]     default: the installed default scene, 1000 steps
///
/// Exit status: 0, or 1 when the scene is refused (its located message on stderr).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "numen/core/data.hpp"
#include "numen/core/step.hpp"
#include "numen/sim/device/instrument_targets.hpp"
#include "numen/sim/input/input_error.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/version.hpp"

int main(int argc, char** argv) {
  // The installed default scene: default_scene_path() finds the prefix this program was built
  // against (find_package(numen) adds the hook; shipped_files.hpp), not numen's source tree.
  std::string path = numen::sim::default_scene_path();
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
    numen::sim::SceneOverrides overrides;
    overrides.caller_steps = true;  // this program sets the targets: no trajectory needed
    scene = numen::sim::load_scene(path, overrides);
  } catch (const numen::sim::InputError& e) {
    std::fprintf(stderr, "scene_step: %s\n", e.what());
    return 1;
  }
  const numen::core::Model& model = scene.model;
  numen::core::Data data = numen::core::make_data(model);
  if (data.held_body < 0) {
    std::fprintf(stderr, "scene_step: %s: the device holds no body\n", path.c_str());
    return 1;
  }
  std::printf("numen %s, scene '%s', dt %g s, %d bodies\n", NUMEN_VERSION, scene.name.c_str(),
              model.dt, model.num_bodies());
  std::printf("default scene %s\n", numen::sim::default_scene_path().c_str());
  for (const std::string& w : scene.warnings) std::printf("warning: %s\n", w.c_str());
  if (scene.has_trajectory) {  // the trajectory's frame is not the held body's
    numen::core::Data probe = numen::core::make_data(model);
    const numen::sim::TrajectorySample tip = scene.trajectory.at(0.0);
    numen::sim::InstrumentTargets(scene).set(tip, probe);
    const double angle = 2.0 * std::acos(std::min(1.0, std::abs(tip.pose.orientation.dot(
                                                           probe.target.orientation))));
    std::printf("trajectory sample at 0 s (tool frame) to the held body's target: %.1f mm, "
                "%.1f deg\n", (tip.pose.position - probe.target.position).norm() * 1e3,
                angle * 180.0 / 3.14159265358979323846);
  }

  // The scripted target: from the tool's initial pose, 20 mm down in 0.5 s, then held.
  const int tool = data.held_body;
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
  int deepest = -1;
  for (int c = 0; c < data.num_contacts; ++c)
    if (deepest < 0 || data.contacts[c].depth > data.contacts[deepest].depth) deepest = c;
  if (deepest >= 0) {
    const numen::core::Contact& c = data.contacts[deepest];
    const std::string on = c.body_b >= 0 ? "body '" + model.bodies[c.body_b].name + "'"
                                         : "obstacle '" + model.obstacles[c.obstacle].name + "'";
    std::printf("deepest contact %.6f m: body '%s' on %s\n", c.depth,
                model.bodies[c.body_a].name.c_str(), on.c_str());
  }
  std::printf("invalid target steps %lld\n", static_cast<long long>(data.invalid_target_steps));
  return 0;
}
