/// @file model.cpp
/// Validation and derived fields of core::Model.

#include "numen/core/model.hpp"

#include <cmath>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "numen/core/collision.hpp"
#include "numen/core/features.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/net_model.hpp"
#include "numen/core/net_tissue_contact.hpp"
#include "numen/core/step_stages.hpp"

namespace numen::core {
namespace {

/// Model::articulation of a build without the articulation solve
/// (NUMEN_WITH_ARTICULATION=OFF): what build_articulation_topology() derives
/// for a model without joints — every body a one-node tree of its own.
[[maybe_unused]] void set_unjointed_topology(Model& model) {
  ArticulationTopology& t = model.articulation;
  const int nb = model.num_bodies();
  t = ArticulationTopology{};
  for (int b = 0; b < nb; ++b) {
    t.nodes.push_back(ArticulationNode{false, b, -1});
    t.body_node.push_back(b);
    t.body_tree.push_back(b);
  }
  t.num_trees = nb;
}

bool finite(const Vec3& v) { return v.allFinite(); }

/// Consistency of the net arrays (filled by add_net(), or by hand in tests).
std::string validate_nets(const Model& model) {
  const std::size_t n = model.node_rest.size();
  if (model.node_mass.size() != n || model.node_radius.size() != n || model.node_net.size() != n)
    return "nets: node_rest, node_mass, node_radius and node_net must have the same size";
  int next_node = 0;
  int next_spring = 0;
  int next_face = 0;
  int next_tetrahedron = 0;
  for (int k = 0; k < model.num_nets(); ++k) {
    const NetModel& net = model.nets[static_cast<std::size_t>(k)];
    const std::string who = "net '" + net.name + "'";
    if (net.body < 0 || net.body >= model.num_bodies()) return who + ": rigid component out of range";
    if (net.material < 0 || net.material >= model.num_materials())
      return who + ": material index out of range";
    if (net.node_begin != next_node || net.node_count <= 0)
      return who + ": node range must follow the previous net's and be non-empty";
    if (net.spring_begin != next_spring || net.structural_count < 0 || net.bending_count < 0)
      return who + ": spring range must follow the previous net's";
    if (!(net.tie_stiffness > 0.0 && std::isfinite(net.tie_stiffness)) ||
        !(net.tie_damping >= 0.0 && std::isfinite(net.tie_damping)))
      return who + ": tie_stiffness must be finite and > 0, tie_damping finite and >= 0";
    if (!net.tie_scale.empty()) {
      if (static_cast<int>(net.tie_scale.size()) != net.node_count)
        return who + ": tie_scale must be empty or hold one entry per node";
      for (const double ts : net.tie_scale)
        if (!(ts > 0.0 && std::isfinite(ts))) return who + ": tie_scale entries must be finite and > 0";
      if (!model.bodies[static_cast<std::size_t>(net.body)].anchored)
        return who + ": tie_scale (ties per node) needs an anchored rigid component";
    }
    if (!(net.load_patch_radius >= 0.0 && std::isfinite(net.load_patch_radius)) ||
        !(net.contact_modulus >= 0.0 && std::isfinite(net.contact_modulus)) ||
        !(net.contact_poisson_ratio > -1.0 && net.contact_poisson_ratio < 0.5) ||
        !(net.contact_stiffening >= 0.0 && net.contact_stiffening <= kMaxStrainStiffening) ||
        (net.contact_modulus > 0.0 &&
         (!(net.load_patch_radius > 0.0) ||
          static_cast<int>(net.surface_node_area.size()) > net.node_count ||
          net.surface_node_normal.size() != net.surface_node_area.size())))
      return who + ": contact_modulus needs load_patch_radius > 0 and at most node_count surface "
                   "areas, one normal each; contact_poisson_ratio in (-1, 0.5); contact_stiffening in "
                   "[0, 4]";
    if (net.face_begin != next_face || net.face_count < 0)
      return who + ": face range must follow the previous net's";
    next_node += net.node_count;
    next_spring += net.structural_count + net.bending_count;
    next_face += net.face_count;
    if (net.tetrahedron_begin != next_tetrahedron || net.tetrahedron_count < 0)
      return who + ": tetrahedron range must follow the previous net's";
    next_tetrahedron += net.tetrahedron_count;
    for (int i = net.node_begin; i < next_node; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (model.node_net[u] != k || !finite(model.node_rest[u]) || !(model.node_mass[u] > 0.0) ||
          !std::isfinite(model.node_mass[u]) || !(model.node_radius[u] > 0.0) ||
          !std::isfinite(model.node_radius[u]))
        return who + ": node " + std::to_string(i - net.node_begin) +
               " needs a finite rest position, mass > 0 and radius > 0";
    }
    for (int s = net.spring_begin; s < next_spring; ++s) {
      const NetSpring& sp = model.net_springs[static_cast<std::size_t>(s)];
      if (sp.node_a < net.node_begin || sp.node_b < net.node_begin || sp.node_a >= next_node ||
          sp.node_b >= next_node || sp.node_a == sp.node_b || !(sp.rest_length > 0.0) ||
          !(sp.stiffness >= 0.0) || !(sp.damping >= 0.0) || !std::isfinite(sp.stiffness) ||
          !std::isfinite(sp.damping) || !std::isfinite(sp.rest_length))
        return who + ": spring " + std::to_string(s - net.spring_begin) +
               " needs two distinct nodes of the net, rest length > 0, finite k, γ >= 0";
    }
    for (int f = net.face_begin; f < next_face; ++f) {
      if (f >= static_cast<int>(model.net_faces.size())) return who + ": face range beyond Model::net_faces";
      const auto& t = model.net_faces[static_cast<std::size_t>(f)];
      for (int v : t)
        if (v < net.node_begin || v >= next_node)
          return who + ": face " + std::to_string(f - net.face_begin) + " names a node outside the net";
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
        return who + ": face " + std::to_string(f - net.face_begin) + " repeats a node";
    }
    for (int e = net.tetrahedron_begin; e < next_tetrahedron; ++e) {
      if (e >= static_cast<int>(model.net_tetrahedra.size()))
        return who + ": tetrahedron range beyond Model::net_tetrahedra";
      const auto& t = model.net_tetrahedra[static_cast<std::size_t>(e)];
      const std::string which = who + ": tetrahedron " + std::to_string(e - net.tetrahedron_begin);
      for (int v : t)
        if (v < net.node_begin || v >= next_node) return which + " names a node outside the net";
      const auto rest = [&](int m) -> const Vec3& { return model.node_rest[static_cast<std::size_t>(t[static_cast<std::size_t>(m)])]; };
      if (!(tetrahedron_six_volume(rest(0), rest(1), rest(2), rest(3)) > 0.0))
        return which + " needs a positive volume at rest (its nodes ordered so)";
    }
  }
  if (next_node != static_cast<int>(n) ||
      next_spring != static_cast<int>(model.net_springs.size()) ||
      next_face != static_cast<int>(model.net_faces.size()) ||
      next_tetrahedron != static_cast<int>(model.net_tetrahedra.size()))
    return "nets: node, spring, face or tetrahedron arrays hold entries no net owns";
  return "";
}

}  // namespace

double damping_from_ratio(double zeta, double mass, double stiffness) noexcept {
  return 2.0 * zeta * std::sqrt(mass * stiffness);
}

namespace {

/// finalize_model()'s checks of the step: dt, gravity, the integrator with the coupling, the
/// materials and their pairs (a model without materials gets "default"). "" or the error.
std::string check_step_settings(Model& model) {
  std::ostringstream err;
  if (!(model.dt > 0.0) || !std::isfinite(model.dt)) {
    err << "time step dt must be finite and > 0 (got " << model.dt << ")";
    return err.str();
  }
  if (!finite(model.gravity)) return "gravity must be finite";
  // Before the bodies' checks: a needle's bad shape (a wire of radius 0 has a steel mass of 0)
  // is named as the needle's.
  if (std::string e = finalize_needles(model); !e.empty()) return e;
  if (model.integrator == Integrator::kTrapezoidal &&
      model.coupling_mode == CouplingMode::kFirstOrder)
    return "integrator trapezoidal cannot run coupling first-order: the rule is not L-stable, "
           "so the massless body's twist (an algebraic unknown) would alternate sign from step "
           "to step; use implicit-euler";
  if (model.material_names.empty()) model.material_names.push_back("default");
  const auto nm = static_cast<std::size_t>(model.num_materials());
  if (model.material_pairs.size() != nm * nm) {
    err << "material_pairs has " << model.material_pairs.size() << " entries, expected "
        << nm * nm << " (num_materials²)";
    return err.str();
  }
  for (std::size_t i = 0; i < model.material_pairs.size(); ++i) {
    const MaterialPair& p = model.material_pairs[i];
    if (!(p.stiffness >= 0.0 && p.damping >= 0.0 && p.friction >= 0.0) ||
        !std::isfinite(p.stiffness) || !std::isfinite(p.damping) || !std::isfinite(p.friction)) {
      err << "material pair (" << model.material_names[i / nm] << ", "
          << model.material_names[i % nm] << "): stiffness, damping and friction must be finite and >= 0";
      return err.str();
    }
    if (!(p.onset_depth >= 0.0) || !std::isfinite(p.onset_depth)) {
      err << "material pair (" << model.material_names[i / nm] << ", "
          << model.material_names[i % nm] << "): onset_depth must be finite and >= 0";
      return err.str();
    }
  }
  return "";
}

/// Each body's mass, inertia (its inverse derived), material, spheres (its bounding radius
/// derived), coupling gains, initial pose (normalised) and twist, mesh and its pose, anchoring.
std::string finalize_bodies(Model& model) {
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    BodyModel& body = model.bodies[b];
    const std::string who = "body '" + body.name + "'";
    if (!(body.mass > 0.0) || !std::isfinite(body.mass)) return who + ": mass must be finite and > 0";
    const Mat3 sym = 0.5 * (body.inertia_body + body.inertia_body.transpose());
    if (!sym.allFinite() || (sym - body.inertia_body).norm() > 1e-12 * (1.0 + sym.norm()))
      return who + ": inertia must be finite and symmetric";
    Eigen::SelfAdjointEigenSolver<Mat3> eig(sym, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues().minCoeff() > 0.0)) return who + ": inertia must be positive definite";
    body.inertia_body_inv = sym.inverse();
    if (body.material < 0 || body.material >= model.num_materials())
      return who + ": material index out of range";
    if (body.sphere_begin < 0 || body.sphere_count < 0 ||
        static_cast<std::size_t>(body.sphere_begin + body.sphere_count) > model.body_spheres.size())
      return who + ": sphere range out of Model::body_spheres";
    body.bounding_radius = 0.0;
    for (int s = body.sphere_begin; s < body.sphere_begin + body.sphere_count; ++s) {
      const Sphere& sp = model.body_spheres[static_cast<std::size_t>(s)];
      if (!finite(sp.center) || !(sp.radius > 0.0) || !std::isfinite(sp.radius))
        return who + ": sphere " + std::to_string(s - body.sphere_begin) +
               " needs a finite centre and radius > 0";
      body.bounding_radius = std::max(body.bounding_radius, sp.center.norm() + sp.radius);
    }
    const CouplingGains& g = body.coupling;
    for (double v : {g.k_t, g.gamma_t, g.k_r, g.gamma_r})
      if (!(v >= 0.0) || !std::isfinite(v)) return who + ": coupling gains must be finite and >= 0";
    if (!finite(body.initial_pose.position) || !body.initial_pose.orientation.coeffs().allFinite() ||
        body.initial_pose.orientation.norm() < 1e-9)
      return who + ": initial pose must be finite with a non-zero quaternion";
    body.initial_pose.orientation.normalize();
    if (!finite(body.initial_twist.linear) || !finite(body.initial_twist.angular))
      return who + ": initial twist must be finite";
    if (body.mesh != -1 &&
        (body.mesh < 0 || static_cast<std::size_t>(body.mesh) >= model.meshes.size() ||
         model.meshes[static_cast<std::size_t>(body.mesh)].nodes.empty()))
      return who + ": mesh index out of Model::meshes (or a shape build_mesh_shape() did not build)";
    if (!finite(body.mesh_pose.position) || !body.mesh_pose.orientation.coeffs().allFinite() ||
        body.mesh_pose.orientation.norm() < 1e-9)
      return who + ": mesh pose must be finite with a non-zero quaternion";
    body.mesh_pose.orientation.normalize();
    if (body.anchored && (body.initial_twist.linear.squaredNorm() > 0.0 ||
                          body.initial_twist.angular.squaredNorm() > 0.0))
      return who + ": anchored (a static body) with a non-zero initial twist";
  }
  return "";
}

/// Each obstacle's material, pose (normalised), size and sphere or mesh range; the static
/// spheres.
std::string finalize_obstacles(Model& model) {
  for (const Obstacle& o : model.obstacles) {
    const std::string who = "obstacle '" + o.name + "'";
    if (o.material < 0 || o.material >= model.num_materials())
      return who + ": material index out of range";
    if (!finite(o.pose.position) || !o.pose.orientation.coeffs().allFinite() ||
        o.pose.orientation.norm() < 1e-9)
      return who + ": pose must be finite with a non-zero quaternion";
    if ((o.type == ShapeType::kSphere || o.type == ShapeType::kCapsule) &&
        (!(o.radius > 0.0) || !std::isfinite(o.radius)))
      return who + ": radius must be finite and > 0";
    if (o.type == ShapeType::kCapsule && (!(o.half_length >= 0.0) || !std::isfinite(o.half_length)))
      return who + ": half length must be finite and >= 0";
    if (o.type == ShapeType::kBox && (!finite(o.half_extents) || !(o.half_extents.minCoeff() > 0.0)))
      return who + ": half extents must be finite and > 0";
    if (o.type == ShapeType::kSphereSet &&
        (o.sphere_begin < 0 || o.sphere_count < 0 ||
         static_cast<std::size_t>(o.sphere_begin + o.sphere_count) > model.static_spheres.size()))
      return who + ": sphere range out of Model::static_spheres";
    if (o.type == ShapeType::kMesh &&
        (o.mesh < 0 || static_cast<std::size_t>(o.mesh) >= model.meshes.size() ||
         model.meshes[static_cast<std::size_t>(o.mesh)].nodes.empty()))
      return who + ": mesh index out of Model::meshes (or a shape build_mesh_shape() did not build)";
  }
  for (std::size_t i = 0; i < model.static_spheres.size(); ++i) {
    const Sphere& sp = model.static_spheres[i];
    if (!finite(sp.center) || !(sp.radius > 0.0) || !std::isfinite(sp.radius))
      return "static sphere " + std::to_string(i) + " needs a finite centre and radius > 0";
  }
  for (Obstacle& o : model.obstacles) o.pose.orientation.normalize();
  return "";
}

/// The device's side and the solver: feedback gains and saturation, the held body, the
/// solver's and Baumgarte's settings.
std::string check_device_and_solver(const Model& model) {
  for (std::size_t g = 0; g <= model.extra_feedback.size(); ++g) {
    const FeedbackGains& f = g == 0 ? model.feedback : model.extra_feedback[g - 1];
    for (double v : {f.k_t, f.gamma_t, f.k_r, f.gamma_r})
      if (!(v >= 0.0) || !std::isfinite(v)) return "feedback gains must be finite and >= 0";
    if (!(f.max_force >= 0.0) || !(f.max_torque >= 0.0)) return "feedback saturation must be >= 0";
  }
  if (model.initial_held_body < -1 || model.initial_held_body >= model.num_bodies())
    return "initial held body index out of range";
  if (model.initial_held_body >= 0 &&
      model.bodies[static_cast<std::size_t>(model.initial_held_body)].anchored)
    return "body '" + model.bodies[static_cast<std::size_t>(model.initial_held_body)].name +
           "': anchored (a static body) cannot be held by the device";
  if (model.solver.max_iterations < 1 || !(model.solver.tolerance > 0.0))
    return "solver needs max_iterations >= 1 and tolerance > 0";
  if (!std::isfinite(model.solver.error_tolerance))
    return "solver error_tolerance must be finite (<= 0: the tolerance)";
  if (model.solver.error_estimate_delay < 0 ||
      model.solver.error_estimate_delay > kMaxErrorEstimateDelay)
    return "solver error_estimate_delay must be in [0, " + std::to_string(kMaxErrorEstimateDelay) +
           "]";
  if (!(model.solver.contact_max_omega_dt > 0.0) || !(model.solver.node_contact_max_omega_dt > 0.0))
    return "solver contact_max_omega_dt and node_contact_max_omega_dt must be > 0 (inf: no "
           "contact time-constant floor)";
  const BaumgarteSettings& bg = model.baumgarte;
  if (!(bg.alpha_dt >= 0.0) || !(bg.beta_dt2 >= 0.0) || !std::isfinite(bg.alpha_dt) ||
      !std::isfinite(bg.beta_dt2))
    return "baumgarte: alpha_dt and beta_dt2 must be finite and >= 0";
  if (!(bg.alpha_dt + bg.beta_dt2 > 0.0))
    return "baumgarte: alpha_dt and beta_dt2 cannot both be 0 (the joint error would drift unchecked)";
  return "";
}

/// Each joint's frames (normalised), prescription and row count (derived), and its bodies not
/// anchored.
std::string finalize_joints(Model& model) {
  for (JointModel& j : model.joints) {
    const std::string who = "joint '" + j.name + "'";
    for (const Pose* f : {&j.frame_parent, &j.frame_child})
      if (!finite(f->position) || !f->orientation.coeffs().allFinite() || f->orientation.norm() < 1e-9)
        return who + ": frames must be finite with a non-zero quaternion";
    j.frame_parent.orientation.normalize();
    j.frame_child.orientation.normalize();
    if (j.prescribed && !joint_can_be_prescribed(j.type))
      return who + ": only revolute and prismatic joints can be prescribed (got " +
             to_string(j.type) + ")";
    j.num_rows = joint_row_count(j.type, j.prescribed);
    for (int b : {j.parent, j.child})
      if (b >= 0 && b < model.num_bodies() && model.bodies[static_cast<std::size_t>(b)].anchored)
        return who + ": body '" + model.bodies[static_cast<std::size_t>(b)].name +
               "' is anchored (a static body): it takes no joint";
  }
  return "";
}

}  // namespace

std::string finalize_model(Model& model) {
  model.stage_plan = 0;  // not finalized until the end: a refused model has no plan
  if (std::string e = check_step_settings(model); !e.empty()) return e;
  if (std::string e = finalize_bodies(model); !e.empty()) return e;
  if (std::string e = finalize_obstacles(model); !e.empty()) return e;
  if (std::string e = check_device_and_solver(model); !e.empty()) return e;
  if (std::string e = finalize_joints(model); !e.empty()) return e;
  if (std::string e = validate_nets(model); !e.empty()) return e;
  if (!kWithDeformable && !model.nets.empty())
    return "nets: this build has NUMEN_WITH_DEFORMABLE=OFF (no deformable nets)";
  if constexpr (kWithDeformable) {
    order_net_nodes(model);     // Model::node_sweep_order
    index_node_springs(model);  // Model::node_spring_begin, node_springs
  }
  if constexpr (kWithArticulation) {
    if (std::string e = build_articulation_topology(model); !e.empty()) return e;
  } else {
    if (!model.joints.empty())
      return "joints: this build has NUMEN_WITH_ARTICULATION=OFF (no joints)";
    set_unjointed_topology(model);
  }
  build_collision_structures(model);
  if (std::string e = finalize_grasps(model); !e.empty()) return e;
  for (std::size_t i = 0; i < model.threads.size(); ++i) {  // thread.hpp
    ThreadModel& t = model.threads[i];
    if (std::string e = finalize_thread(t, model.num_bodies(), model.num_materials()); !e.empty())
      return "thread " + std::to_string(i) + (t.name.empty() ? "" : " (" + t.name + ")") + ": " + e;
    t.needle = -1;  // the needle it takes punctures over from: the one its start is tied to
    for (int k = 0; k < model.num_needles(); ++k)
      if (t.tie_start.body >= 0 && model.needles[static_cast<std::size_t>(k)].body == t.tie_start.body) t.needle = k;
  }
  model.stage_plan = compiled_stages(model);  // reads the articulation's body trees: last
  return {};
}

}  // namespace numen::core
