#pragma once
/// @file organ_indentation.hpp
/// Deformable organs for the tests (docs/organs.md, "Organs"): a net tied to an anchored
/// rigid component (core::BodyModel::anchored) and a one-sphere tool, the shipped organ mesh
/// (sim/data/organ_lobe.obj, read here without the sim layer), a flat patch, and the
/// force–indentation curve of the tool pushed into the organ at constant speed. Header-only;
/// needs numen::core only.

#include <algorithm>
#include <array>
#include <cstdio>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "numen/core/data.hpp"
#include "numen/core/mesh.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_material.hpp"
#include "numen/core/step.hpp"

#include "mesh/mesh_shape_query.hpp"

namespace numen::test::organ {

using core::Vec3;

/// The shipped organ's constants (sim/scenes/default.toml), per spring and per node.
struct OrganParams {
  double node_mass = 7e-5;  ///< kg per node (the net's mass is node_mass × nodes).
  double k = 200.0, gamma = 0.1;
  double k_bend = 50.0, gamma_bend = 0.03;
  double k_tie = 100.0, gamma_tie = 0.17;
};

/// The vertices and triangles of a Wavefront OBJ of `v x y z` and `f a b c` lines (1-based),
/// as make_organ_mesh.py writes them; an empty mesh when the file cannot be read.
inline core::TriangleMesh read_simple_obj(const std::string& path) {
  core::TriangleMesh m;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      Vec3 v;
      s >> v.x() >> v.y() >> v.z();
      m.vertices.push_back(v);
    } else if (tag == "f") {
      std::array<int, 3> t{};
      s >> t[0] >> t[1] >> t[2];
      m.triangles.push_back({t[0] - 1, t[1] - 1, t[2] - 1});
    }
  }
  return m;
}

/// The shipped organ mesh (1002 vertices, metres, the organ's frame).
inline core::TriangleMesh shipped_organ_mesh() {
  return read_simple_obj(std::string(NUMEN_SOURCE_DIR) + "/sim/data/organ_lobe.obj");
}

/// A flat square patch in the plane z = 0: (n + 1)² vertices `spacing` apart, centred on the
/// origin, two triangles per cell, normals +z (an open surface).
inline core::TriangleMesh flat_patch(int n, double spacing) {
  core::TriangleMesh m;
  const double half = 0.5 * n * spacing;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.push_back(Vec3(i * spacing - half, j * spacing - half, 0.0));
  auto id = [n](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

/// "organ_core": the organ's rigid component, 0.1 kg, anchored at the origin, no spheres,
/// material 1 ("tissue").
inline core::BodyModel organ_core_body() {
  core::BodyModel anchor;
  anchor.name = "organ_core";
  anchor.mass = 0.1;
  anchor.inertia_body = 1e-4 * core::Mat3::Identity();
  anchor.material = 1;
  anchor.anchored = true;
  return anchor;
}

/// The start of a flat-patch rig (grasping, puncture, a thread through tissue): implicit Euler
/// at 1 ms, no gravity, the solve to 1e-6 in at most 200 iterations, materials "steel" and
/// "tissue" (every pair 2e4 N/m, 10 N·s/m, no friction), body 0 organ_core_body(); the caller
/// adds its net (organ_net_settings() of a flat_patch()), its bodies and finalizes.
inline core::Model patch_rig_start() {
  core::Model m;
  m.dt = 1e-3;
  m.gravity = core::Vec3::Zero();
  m.solver.tolerance = 1e-6;
  m.solver.max_iterations = 200;
  m.material_names = {"steel", "tissue"};
  m.material_pairs.assign(4, core::MaterialPair{2e4, 10.0, 0.0});
  m.bodies.push_back(organ_core_body());
  return m;
}

/// Net "organ" of `mesh` on body 0, material 1, with the constants `p` per spring and per node.
inline core::NetSettings organ_net_settings(const core::TriangleMesh& mesh, const OrganParams& p) {
  core::NetSettings s;
  s.name = "organ";
  s.body = 0;
  s.material = 1;
  s.mass = p.node_mass * mesh.num_vertices();
  s.stiffness = p.k;
  s.damping = p.gamma;
  s.bending_stiffness = p.k_bend;
  s.bending_damping = p.gamma_bend;
  s.tie_stiffness = p.k_tie;
  s.tie_damping = p.gamma_tie;
  return s;
}

/// Body 0: "organ_core", anchored at the origin (no spheres), without its net yet; body 1: "tool", one sphere of `tool_radius` at its COM, 50 g, held by the device from
/// `tool_start` (kDirect: imposed; kGodObject: coupled at 1000 N/m, ζ = 0.85). Materials "steel"
/// (tool) and "tissue" (net): 2e4 N/m, 10 N·s/m, no friction. Implicit Euler, no gravity.
/// Feedback gains 300 N/m, 1 N·s/m (as the shipped scenes).
/// With `handle`, body 2 "handle" (100 g, 40 mm behind the tool along −z) is the held body, the
/// tool on a revolute joint under it (axis x): the instrument's joints, which take the nets' solve
/// to the arrowhead preconditioner (docs/net-solver.md).
inline core::Model organ_bodies(double dt, core::CouplingMode mode, double tool_radius,
                                const Vec3& tool_start, bool handle = false) {
  core::Model m;
  m.dt = dt;
  m.gravity = Vec3::Zero();
  m.integrator = core::Integrator::kLinearlyImplicitEuler;
  m.coupling_mode = mode;
  m.solver.tolerance = 3e-4;
  m.solver.max_iterations = 200;
  m.material_names = {"steel", "tissue"};
  m.material_pairs.assign(4, core::MaterialPair{2e4, 10.0, 0.0});
  const core::BodyModel anchor = organ_core_body();
  core::BodyModel tool;
  tool.name = "tool";
  tool.mass = 0.05;
  tool.inertia_body = 1e-5 * core::Mat3::Identity();
  tool.material = 0;
  tool.sphere_begin = 0;
  tool.sphere_count = 1;
  tool.initial_pose.position = tool_start;
  tool.coupling = core::CouplingGains{1000.0, core::damping_from_ratio(0.85, 0.05, 1000.0), 1.0,
                                      core::damping_from_ratio(0.85, 1e-5, 1.0)};
  m.body_spheres = {core::Sphere{Vec3::Zero(), tool_radius}};
  m.bodies = {anchor, tool};
  m.initial_held_body = 1;
  if (handle) {
    core::BodyModel h = tool;
    h.name = "handle";
    h.mass = 0.1;
    h.sphere_count = 0;
    h.initial_pose.position = tool_start - Vec3(0.0, 0.0, 0.04);
    m.bodies.push_back(h);
    m.initial_held_body = 2;
    core::JointModel j;
    j.name = "wrist";
    j.type = core::JointType::kRevolute;
    j.parent = 2;
    j.child = 1;
    j.frame_parent = core::Pose{Vec3(0.0, 0.0, 0.04), core::Quat(Eigen::AngleAxisd(std::acos(0.0), Vec3::UnitY()))};
    j.frame_child = core::Pose{Vec3::Zero(), core::Quat(Eigen::AngleAxisd(std::acos(0.0), Vec3::UnitY()))};
    m.joints = {j};
  }
  m.feedback.k_t = 300.0;
  m.feedback.gamma_t = 1.0;
  return m;
}

/// organ_bodies() with net "organ" from `mesh`, the constants `p` per spring and per node.
inline core::Model organ_model(const core::TriangleMesh& mesh, const OrganParams& p, double dt,
                               core::CouplingMode mode, double tool_radius, const Vec3& tool_start,
                               bool handle = false) {
  core::Model m = organ_bodies(dt, mode, tool_radius, tool_start, handle);
  EXPECT_EQ(core::add_net(m, mesh, organ_net_settings(mesh, p)), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// organ_bodies() with net "organ" given by its material (core::add_material_net()) on `mesh`.
inline core::Model tissue_model(const core::TetrahedralMesh& mesh, const core::NetMaterial& tissue,
                                double dt, core::CouplingMode mode, double tool_radius,
                                const Vec3& tool_start) {
  core::Model m = organ_bodies(dt, mode, tool_radius, tool_start);
  core::MaterialNetSettings s;
  s.name = "organ";
  s.body = 0;
  s.material = 1;
  s.tissue = tissue;
  EXPECT_EQ(core::add_material_net(m, mesh, s), "");
  EXPECT_EQ(core::finalize_model(m), "");
  return m;
}

/// The smallest s in [0, 0.2] m at which `touches(s)` turns true, scanned in 0.05 mm steps and
/// then bisected (+∞ when it never does): where a sphere moved along a path first touches.
template <typename Touches>
inline double first_true_along(Touches touches) {
  double lo = 0.0;
  for (double s = 0.0; s < 0.2; s += 5e-5) {
    if (touches(s)) {
      double hi = s;
      for (int i = 0; i < 60; ++i) (touches(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
      return hi;
    }
    lo = s;
  }
  return std::numeric_limits<double>::infinity();
}

/// Distance along unit `dir` from `from` at which a sphere of `radius` first touches the organ's
/// rest shape (+∞ if it never does within 0.2 m): its surface triangles (the organ's contacts
/// with the tool, net_surface.hpp; scanned in 0.05 mm steps, then bisected), or its node spheres
/// for a net without faces.
inline double first_touch(const core::Model& m, const Vec3& from, const Vec3& dir, double radius) {
  double best = std::numeric_limits<double>::infinity();
  if (m.nets[0].face_count > 0) {
    const core::Pose& pose = m.bodies[0].initial_pose;
    const auto touches = [&](double s) {
      const Vec3 p = from + s * dir;
      for (const auto& t : m.net_faces) {
        int feature = 0;
        const Vec3 q = core::detail::closest_on_triangle(
            p, pose.position + pose.orientation * m.node_rest[static_cast<std::size_t>(t[0])],
            pose.position + pose.orientation * m.node_rest[static_cast<std::size_t>(t[1])],
            pose.position + pose.orientation * m.node_rest[static_cast<std::size_t>(t[2])], feature);
        if ((p - q).norm() < radius) return true;
      }
      return false;
    };
    return first_true_along(touches);
  }
  for (int i = 0; i < m.num_nodes(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Vec3 c = m.bodies[0].initial_pose.position + m.bodies[0].initial_pose.orientation * m.node_rest[k];
    const double r = radius + m.node_radius[k];
    const Vec3 w = from - c;
    const double b = w.dot(dir), q = w.squaredNorm() - r * r;
    const double disc = b * b - q;
    if (disc < 0.0) continue;
    const double s = -b - std::sqrt(disc);
    if (s >= 0.0) best = std::min(best, s);
  }
  return best;
}

/// The tool's force along −`dir` from the organ's node contacts (N): Σ node contact forces on
/// the nodes it touches (a triangle contact's shares included), projected on `dir` (their
/// reaction on the tool is the opposite).
inline double organ_force_on_tool(const core::Data& d, const Vec3& dir) {
  double f = 0.0;
  for (int c = 0; c < d.num_node_contacts; ++c)
    if (d.node_contacts[static_cast<std::size_t>(c)].body_b == 1)
      f += d.node_contacts[static_cast<std::size_t>(c)].force.dot(dir);
  return f;
}

/// One sample of a force–indentation curve.
struct IndentationSample {
  double depth = 0.0;  ///< m: how far the tool has gone past its first touch of the rest shape.
  double force = 0.0;  ///< N: organ_force_on_tool(), the mean over the sample's steps.
  /// Net 0's tetrahedra inside out at the sample's last step (core::NetOutput::inverted_tetrahedra).
  int inverted_tetrahedra = 0;
};

/// Pushes the imposed tool (a kDirect model of organ_model()) from `from` along unit `dir` at
/// `speed` (m/s) until it is `max_depth` past its first touch; returns one sample per `every`
/// steps, its force the mean over those steps (the impulse the tool took over the sample's
/// period, per second: at dt and dt/10 with every = 1 and 10 the samples cover the same
/// periods, and the fine run's fast node oscillations, which the coarse implicit step damps,
/// average out).
/// Fails the test on a step that is not kStepOk.
/// `touch_at`: the first touch's distance from `from` when given (a net carrying a fine surface
/// is touched where that surface is, not where its own triangles are), else first_touch()'s.
inline std::vector<IndentationSample> indentation_curve(
    const core::Model& m, const Vec3& from, const Vec3& dir, double speed, double max_depth,
    int every, double touch_at = std::numeric_limits<double>::quiet_NaN()) {
  core::Data d = core::make_data(m);
  const double touch =
      std::isnan(touch_at) ? first_touch(m, from, dir, m.body_spheres[0].radius) : touch_at;
  EXPECT_TRUE(std::isfinite(touch)) << "the tool's path misses the organ";
  std::vector<IndentationSample> out;
  double window = 0.0;  // Σ of the force over the steps since the last sample
  const auto steps =
      every * static_cast<long>(std::ceil((touch + max_depth) / speed / (every * m.dt) - 1e-9));
  for (long k = 0; k <= steps; ++k) {
    const double s = speed * static_cast<double>(k) * m.dt;
    d.target.position = from + s * dir;
    d.target.orientation = core::Quat::Identity();
    d.target_twist.linear = speed * dir;
    d.target_twist.angular.setZero();
    core::step(m, d);
    EXPECT_EQ(d.status, core::kStepOk) << "step " << k;
    window += organ_force_on_tool(d, dir);
    if (k % every == 0) {
      out.push_back({s - touch, window / (k == 0 ? 1 : every), d.nets.empty() ? 0 : d.nets[0].inverted_tetrahedra});
      window = 0.0;
    }
  }
  return out;
}

/// `curve` averaged over consecutive blocks of `n` samples (the last partial block dropped):
/// the mean force over n periods, at the block's last depth.
inline std::vector<IndentationSample> block_means(const std::vector<IndentationSample>& curve, int n) {
  std::vector<IndentationSample> out;
  for (std::size_t i = 0; i + static_cast<std::size_t>(n) <= curve.size(); i += static_cast<std::size_t>(n)) {
    double f = 0.0;
    for (int j = 0; j < n; ++j) f += curve[i + static_cast<std::size_t>(j)].force;
    out.push_back({curve[i + static_cast<std::size_t>(n) - 1].depth, f / n});
  }
  return out;
}

/// Compares the force–indentation curves `coarse` and `fine` (same sample times) over 5-sample
/// means; prints a few samples and the largest difference under `label`; returns the largest
/// difference (N) and sets `peak` (N) to the fine curve's largest mean force.
inline double compare_curves(const char* label, const std::vector<IndentationSample>& coarse,
                             const std::vector<IndentationSample>& fine, double& peak) {
  EXPECT_EQ(coarse.size(), fine.size());
  const auto a = block_means(coarse, 5), b = block_means(fine, 5);
  peak = 0.0;
  double worst = 0.0;
  std::size_t at_worst = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    EXPECT_NEAR(a[i].depth, b[i].depth, 1e-12);
    peak = std::max(peak, b[i].force);
    if (std::abs(a[i].force - b[i].force) > worst) worst = std::abs(a[i].force - b[i].force), at_worst = i;
  }
  for (std::size_t i = 0; i < a.size(); i += std::max<std::size_t>(1, a.size() / 8))
    if (a[i].depth > 0.0)
      std::printf("[%s] depth %5.2f mm: force %7.4f N (dt 1 ms), %7.4f N (0.1 ms)\n", label,
                  1e3 * a[i].depth, a[i].force, b[i].force);
  std::printf("[%s] peak %.4f N; largest difference %.4f N (%.2f %% of the peak) at %.2f mm\n",
              label, peak, worst, 100.0 * worst / peak, 1e3 * a[at_worst].depth);
  return worst;
}

}  // namespace numen::test::organ
