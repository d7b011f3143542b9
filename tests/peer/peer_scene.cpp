/// @file peer_scene.cpp
/// The scenes of the peer comparison.

#include "peer_scene.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "numen/core/data.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::peer {

PeerScene make_wall_scene(double duration_s) {
  PeerScene s;
  s.name = "wall";
  s.description = "ball pushed 50 mm into a wall at 0.2 m/s (step_test)";
  core::Model& m = s.model;
  m.dt = 1e-3;
  m.gravity = core::Vec3::Zero();
  const double k_c = 1e5, k_t = 1000.0, mass = 0.05;
  m.material_names = {"default"};
  m.material_pairs = {core::MaterialPair{k_c, 50.0, 0.0}};
  core::Obstacle wall;
  wall.name = "wall";
  wall.type = core::ShapeType::kPlane;
  wall.pose.orientation = core::rotation_between(core::Vec3::UnitZ(), -core::Vec3::UnitX());
  m.obstacles = {wall};
  m.body_spheres = {core::Sphere{core::Vec3::Zero(), 0.01}};
  core::BodyModel b;
  b.name = "tool";
  b.mass = mass;
  b.inertia_body = core::Mat3::Identity() * 2e-6;
  b.sphere_count = 1;
  b.coupling = {k_t, core::damping_from_ratio(0.85, mass, k_t), 0.0, 0.0};
  b.initial_pose.position = core::Vec3(-0.05, 0.0, 0.0);
  m.bodies = {b};
  m.initial_held_body = 0;
  const std::string err = core::finalize_model(m);
  if (!err.empty()) throw std::logic_error("wall scene: " + err);

  const int steps = static_cast<int>(std::llround((duration_s < 0.0 ? 3.0 : duration_s) / m.dt));
  const double x_end = 0.05, speed = 0.2;
  s.inputs.reserve(static_cast<std::size_t>(steps));
  for (int i = 0; i < steps; ++i) {
    const double t = m.dt * i;  // the same schedule as the core test
    StepInput in;
    in.held_body = 0;
    const double x = -0.05 + speed * t;
    in.target.position = core::Vec3(std::min(x, x_end), 0.0, 0.0);
    in.target_twist.linear = core::Vec3(x < x_end ? speed : 0.0, 0.0, 0.0);
    in.body_targets.resize(1);
    s.inputs.push_back(std::move(in));
  }
  return s;
}

PeerScene load_recorded_scene(const std::string& name, const std::string& relative_path,
                              double duration_s) {
  const sim::Scene scene = sim::load_scene(std::string(NUMEN_SOURCE_DIR) + "/" + relative_path);
  PeerScene s;
  s.name = name;
  s.description = scene.description;
  s.model = scene.model;
  const double d = duration_s < 0.0 ? scene.duration_s : duration_s;
  s.inputs = record_scene_inputs(scene, static_cast<int>(std::llround(d / scene.model.dt)));
  return s;
}

std::vector<PeerScene> comparison_scenes(double duration_s) {
  std::vector<PeerScene> scenes;
  scenes.push_back(make_wall_scene(duration_s));
  scenes.push_back(load_recorded_scene("construction", "sim/scenes/construction.toml", duration_s));
  scenes.push_back(load_recorded_scene("instrument", "sim/scenes/lattice.toml", duration_s));
  return scenes;
}

}  // namespace numen::peer
