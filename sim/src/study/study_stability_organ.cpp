/// @file study_stability_organ.cpp
/// Case "organ-plunge" of the family "extreme" of `numen study stability` (study_stability.hpp):
/// the deformable organ of sim/scenes/default.toml (its net on its anchored core and the rigid
/// core surface under it, as shipped) and a
/// god-object of the instrument's tube (one sphere of the tube's radius and mass, the tube's
/// coupling), started 20 mm outside the organ's convex face on the organ's approach axis, whose
/// target jumps 40 mm along that axis in one period, 20 mm past the rest surface: the coupling
/// pulls with k_t × 40 mm at once (40 N for the shipped tube), far beyond what the hollow net
/// holds, so the sphere dents the organ, then slips between its nodes onto the rigid core (or,
/// in a scene without one, into the hollow net). Core driven
/// directly, gravity off. Verdict of study_stability.hpp (energy, finite states, penetration
/// bound k_t × jump / k_contact on one node contact, as the deformable jump's).
/// Case "organ-plunge-per-spring": the same surface net given the constants per spring the
/// shipped organ had before it was given its material (kShippedPerSpringOrgan, issue 67).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "numen/core/features.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/net_model.hpp"
#include "numen/sim/scene/scene.hpp"
#include "numen/sim/study/study_common.hpp"
#include "numen/sim/study/study_stability_cases.hpp"
#include "scene/net_tetrahedralize.hpp"

namespace numen::sim::stability {
namespace {

using core::Vec3;

/// The organ of `scene` (its first net on an anchored body) and a one-sphere tool with the held
/// body's mass and coupling, `radius` (m), starting at `start`: body 0 the organ's core, body 1
/// the tool (held); the scene's mesh obstacles (the organ's rigid core surface). Materials and
/// contact pairs as the scene's. The net: with `per_spring`, the organ's surface net (its
/// triangles' nodes) given those constants; else as the scene gives it, a material net rebuilt
/// from that surface and the scene's material settings as the scene loader built it
/// (tetrahedralised with interior nodes kInteriorSpacingEdges mean edges apart), or the scene's
/// own constants per spring.
core::Model plunge_model(const Scene& scene, double radius, const Vec3& start,
                         const PerSpringOrgan* per_spring) {
  const core::Model& s = scene.model;
  int k = -1;
  for (int i = 0; i < s.num_nets() && k < 0; ++i)
    if (s.bodies[static_cast<std::size_t>(s.nets[static_cast<std::size_t>(i)].body)].anchored) k = i;
  if (k < 0 || s.initial_held_body < 0)
    throw std::invalid_argument("organ-plunge: the scene has no organ (a net on an anchored body) "
                                "or no held body");
  const core::NetModel& net = s.nets[static_cast<std::size_t>(k)];
  const core::BodyModel& held = s.bodies[static_cast<std::size_t>(s.initial_held_body)];
  core::Model m;
  m.dt = s.dt;
  m.gravity = Vec3::Zero();
  m.integrator = s.integrator;
  m.solver = s.solver;
  m.material_names = s.material_names;
  m.material_pairs = s.material_pairs;
  core::BodyModel tool = held;
  tool.name = "tool";
  tool.sphere_begin = 0;
  tool.sphere_count = 1;
  tool.initial_pose = core::Pose{start, core::Quat::Identity()};
  tool.initial_twist = core::Twist{};
  tool.mesh = -1;  // a one-sphere tool
  m.body_spheres = {core::Sphere{Vec3::Zero(), radius}};
  core::BodyModel anchor = s.bodies[static_cast<std::size_t>(net.body)];
  anchor.sphere_begin = 0;  // no spheres, in this model's (one-sphere) table
  anchor.mesh = -1;         // the organ is its net and the mesh obstacles below
  m.bodies = {anchor, tool};
  m.initial_held_body = 1;
  // The scene's mesh obstacles: the organ's rigid core under its surface (default.toml).
  for (const core::Obstacle& o : s.obstacles) {
    if (o.type != core::ShapeType::kMesh) continue;
    core::Obstacle c = o;
    c.mesh = static_cast<int>(m.meshes.size());
    m.meshes.push_back(s.meshes[static_cast<std::size_t>(o.mesh)]);
    m.obstacles.push_back(c);
  }
  // The surface net: its triangles' nodes, the first of the net's (a material net's interior
  // nodes follow them).
  core::TriangleMesh mesh;
  mesh.triangles = scene.net_triangles[static_cast<std::size_t>(k)];
  int surface_nodes = 0;
  for (const auto& t : mesh.triangles)
    for (const int v : t) surface_nodes = std::max(surface_nodes, v + 1);
  for (int i = 0; i < surface_nodes; ++i)
    mesh.vertices.push_back(s.node_rest[static_cast<std::size_t>(net.node_begin + i)]);
  const NetLoad* load =
      k < static_cast<int>(scene.net_loads.size()) ? &scene.net_loads[static_cast<std::size_t>(k)] : nullptr;
#if NUMEN_WITH_DEFORMABLE
  std::string error;
  if (per_spring == nullptr && load != nullptr && load->material) {
    core::TetrahedralMesh volume;
    error = tetrahedralize_net(mesh, kInteriorSpacingEdges * mean_edge_length(mesh), volume);
    core::MaterialNetSettings settings = load->tissue;
    settings.name = net.name;
    settings.body = 0;
    settings.material = net.material;
    if (error.empty()) error = core::add_material_net(m, volume, settings);
  } else {
    core::NetSettings settings;
    settings.name = net.name;
    settings.body = 0;
    settings.material = net.material;
    if (per_spring != nullptr) {
      settings.mass = per_spring->mass;
      settings.stiffness = per_spring->stiffness;
      settings.damping = per_spring->damping;
      settings.bending_stiffness = per_spring->bending_stiffness;
      settings.bending_damping = per_spring->bending_damping;
      settings.tie_stiffness = per_spring->tie_stiffness;
      settings.tie_damping = per_spring->tie_damping;
    } else {
      const core::NetSpring& structural = s.net_springs[static_cast<std::size_t>(net.spring_begin)];
      settings.mass = net.mass;
      settings.stiffness = structural.stiffness;
      settings.damping = structural.damping;
      if (net.bending_count > 0) {
        const core::NetSpring& bending =
            s.net_springs[static_cast<std::size_t>(net.spring_begin + net.structural_count)];
        settings.bending_stiffness = bending.stiffness;
        settings.bending_damping = bending.damping;
      }
      settings.tie_stiffness = net.tie_stiffness;
      settings.tie_damping = net.tie_damping;
      settings.node_radius = s.node_radius[static_cast<std::size_t>(net.node_begin)];
    }
    error = core::add_net(m, mesh, settings);
  }
#else  // nets are compiled out: the plan skips this case before it runs (study_stability_scene.cpp)
  std::string error = "needs deformable nets: this build has NUMEN_WITH_DEFORMABLE=OFF";
  (void)per_spring;
  (void)load;
#endif
  if (error.empty()) error = core::finalize_model(m);
  if (!error.empty()) throw std::invalid_argument("organ-plunge: " + error);
  return m;
}

}  // namespace

StabilityRow organ_run(const Scene& scene, core::Integrator integrator, double h,
                       const StabilityLimits& limits, double horizon,
                       const PerSpringOrgan* per_spring) {
  constexpr double kTubeRadius = 0.0025;  // m, the shipped instrument's tube
  // The organ's approach axis (its frame's z) and its rest surface's nearest point on it.
  const core::BodyModel* core_body = nullptr;
  for (const core::BodyModel& b : scene.model.bodies)
    if (b.anchored) core_body = &b;
  if (core_body == nullptr) throw std::invalid_argument("organ-plunge: the scene has no anchored body");
  const Vec3 centre = core_body->initial_pose.position;
  const Vec3 axis = core_body->initial_pose.orientation * Vec3::UnitZ();
  double face = 0.0;  // how far the rest surface reaches towards −axis from the centre (m)
  for (const Vec3& r : scene.model.node_rest) face = std::max(face, -(core_body->initial_pose.orientation * r).dot(axis));
  const Vec3 start = centre - (face + 0.020) * axis;
  const Vec3 goal = centre - (face - 0.020) * axis;
  core::Model base = plunge_model(scene, kTubeRadius, start, per_spring);
  const core::Model model = study::with_scheme(base, integrator, h, "stability study");
  core::Data data = core::make_data(model);
  double k_contact = kInf;
  for (const core::MaterialPair& p : model.material_pairs) k_contact = std::min(k_contact, p.stiffness);
  const double jump = (goal - start).norm();
  const double static_depth = model.bodies[1].coupling.k_t * jump / k_contact;
  const auto n = std::max<std::int64_t>(1, std::llround(horizon / h));
  const std::int64_t at = std::max<std::int64_t>(1, std::llround(0.05 / h));
  Monitor monitor(limits, limits.penetration_factor * static_depth, kInf, n,
                  model.bodies[1].mass, h);
  int inverted_max = 0;  // the most tetrahedra inside out after a step (NetOutput)
  drive(
      model, data, n,
      [&](std::int64_t k, core::Data& d) noexcept {
        inverted_max = std::max(inverted_max, d.nets[0].inverted_tetrahedra);
        d.target.position = k >= at ? goal : start;
        d.target.orientation = core::Quat::Identity();
        d.target_twist = core::Twist{};
      },
      monitor);
  StabilityRow r =
      make_row("extreme", per_spring ? "organ-plunge-per-spring" : "organ-plunge", integrator, h,
               model.bodies[1].mass, model.nets[0].tie_stiffness, jump, "jump_m", kNaN);
  r.energy_ratio_max = kNaN;
  monitor.fill(r);
  inverted_max = std::max(inverted_max, data.nets[0].inverted_tetrahedra);
  char note[256];
  std::snprintf(note, sizeof note,
                "at the end: %d node contacts, organ %.3g mm from its rest shape, max strain %.3g, "
                "tool %.3g mm past the rest surface; tetrahedra inside out at most %d",
                data.num_node_contacts, 1e3 * data.nets[0].max_tie_stretch, data.nets[0].max_strain,
                1e3 * (data.bodies[1].position - start).dot(axis) - 20.0, inverted_max);
  r.note = note;
  return r;
}

}  // namespace numen::sim::stability
