/// @file mjcf_translation.cpp
/// core::Model → MJCF text (see the header for the mapping).

#include "mjcf_translation.hpp"

#include <cstdio>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "numen/core/data.hpp"
#include "numen/core/joint.hpp"
#include "soft_constraint_mapping.hpp"

namespace numen::peer {
namespace {

using core::Quat;
using core::Vec3;

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

/// `prefix` + index + "_" + `name` (element names unique per index).
std::string indexed(const char* prefix, std::size_t i, const std::string& name) {
  std::string s(prefix);
  s += std::to_string(i);
  s += '_';
  s += name;
  return s;
}

std::string vec(const Vec3& v) { return num(v.x()) + " " + num(v.y()) + " " + num(v.z()); }

/// MuJoCo quaternion order: w x y z.
std::string quat(const Quat& q) {
  return num(q.w()) + " " + num(q.x()) + " " + num(q.y()) + " " + num(q.z());
}

std::string soft_attrs(const SoftConstraint& s) {
  return "solref=\"" + num(-s.stiffness) + " " + num(-s.damping) + "\" solimp=\"" +
         num(s.impedance) + " " + num(s.impedance) + " 0.001 0.5 2\"";
}

core::BodyState initial_state(const core::BodyModel& b) {
  core::BodyState s;
  s.position = b.initial_pose.position;
  s.orientation = b.initial_pose.orientation.normalized();
  return s;
}

}  // namespace

const char* to_string(Drive drive) noexcept {
  return drive == Drive::kMocapWeld ? "mocap weld" : "PD xfrc_applied";
}

MjcfTranslation translate_to_mjcf(const core::Model& model, Drive drive,
                                  const std::vector<int>& held_bodies) {
  if (model.num_nets() > 0)
    throw std::invalid_argument(
        "mjcf: deformable nets have no translation (MuJoCo 2.2 has no "
        "mass-spring shell tied to a rigid body)");
  const int nb = model.num_bodies();
  MjcfTranslation out;
  out.body_names.resize(static_cast<std::size_t>(nb));
  out.weld_names.resize(static_cast<std::size_t>(nb));
  out.mocap_names.resize(static_cast<std::size_t>(nb));
  out.prescribed_names.resize(static_cast<std::size_t>(model.num_joints()));
  out.coordinate_offset.assign(static_cast<std::size_t>(model.num_joints()), 0.0);
  for (int b = 0; b < nb; ++b)
    out.body_names[static_cast<std::size_t>(b)] =
        indexed("b", static_cast<std::size_t>(b), model.bodies[static_cast<std::size_t>(b)].name);

  // Contact parameters: one set per body geom (its material against the obstacles').
  int obstacle_material = -1;
  for (const core::Obstacle& o : model.obstacles) {
    if (obstacle_material >= 0 && (model.material_pair(0, o.material).stiffness !=
                                       model.material_pair(0, obstacle_material).stiffness ||
                                   model.material_pair(0, o.material).damping !=
                                       model.material_pair(0, obstacle_material).damping))
      throw std::invalid_argument("mjcf: obstacle '" + o.name +
                                  "' has other contact parameters than the first obstacle; a "
                                  "MuJoCo geom carries one set (use <pair> per geom pair)");
    if (obstacle_material < 0) obstacle_material = o.material;
  }

  // Joint tree: the joint whose child is each body.
  std::vector<int> parent_joint(static_cast<std::size_t>(nb), -1);
  for (int j = 0; j < model.num_joints(); ++j)
    parent_joint[static_cast<std::size_t>(model.joints[static_cast<std::size_t>(j)].child)] = j;
  std::vector<std::vector<int>> children(static_cast<std::size_t>(nb));
  std::vector<int> roots;
  for (int b = 0; b < nb; ++b) {
    const int j = parent_joint[static_cast<std::size_t>(b)];
    const int p = j >= 0 ? model.joints[static_cast<std::size_t>(j)].parent : -1;
    if (p >= 0)
      children[static_cast<std::size_t>(p)].push_back(b);
    else
      roots.push_back(b);
  }

  std::ostringstream x;
  x << "<mujoco model=\"numen_peer\">\n";
  x << "  <compiler angle=\"radian\" inertiafromgeom=\"false\" boundmass=\"0\" "
       "boundinertia=\"0\"/>\n";
  x << "  <option timestep=\"" << num(model.dt) << "\" gravity=\"" << vec(model.gravity)
    << "\" integrator=\"Euler\"/>\n";
  x << "  <size njmax=\"6000\" nconmax=\"2000\"/>\n";
  x << "  <worldbody>\n";

  // Static obstacles (priority 0: the body geoms' parameters are used in every contact).
  for (std::size_t i = 0; i < model.obstacles.size(); ++i) {
    const core::Obstacle& o = model.obstacles[i];
    const std::string name = indexed("o", i, o.name);
    const std::string pose =
        "pos=\"" + vec(o.pose.position) + "\" quat=\"" + quat(o.pose.orientation) + "\"";
    switch (o.type) {
      case core::ShapeType::kPlane:
        x << "    <geom name=\"" << name << "\" type=\"plane\" size=\"0 0 1\" " << pose << "/>\n";
        break;
      case core::ShapeType::kBox:
        x << "    <geom name=\"" << name << "\" type=\"box\" size=\"" << vec(o.half_extents)
          << "\" " << pose << "/>\n";
        break;
      case core::ShapeType::kSphere:
        x << "    <geom name=\"" << name << "\" type=\"sphere\" size=\"" << num(o.radius) << "\" "
          << pose << "/>\n";
        break;
      case core::ShapeType::kCapsule:
        x << "    <geom name=\"" << name << "\" type=\"capsule\" size=\"" << num(o.radius) << " "
          << num(o.half_length) << "\" " << pose << "/>\n";
        break;
      case core::ShapeType::kSphereSet:
        for (int s = o.sphere_begin; s < o.sphere_begin + o.sphere_count; ++s) {
          const core::Sphere& sp = model.static_spheres[static_cast<std::size_t>(s)];
          x << "    <geom name=\"" << name << "_" << (s - o.sphere_begin)
            << "\" type=\"sphere\" size=\"" << num(sp.radius) << "\" pos=\"" << vec(sp.center)
            << "\"/>\n";
        }
        break;
      case core::ShapeType::kMesh:
        throw std::invalid_argument("mjcf: obstacle '" + o.name +
                                    "' is a mesh: the peer scenes have none, and it is not "
                                    "translated");
    }
  }

  // Bodies, nested along the joints.
  std::function<void(int, int)> write_body = [&](int b, int depth) {
    const core::BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
    const std::string ind(static_cast<std::size_t>(2 * depth + 4), ' ');
    const int j = parent_joint[static_cast<std::size_t>(b)];
    const int p = j >= 0 ? model.joints[static_cast<std::size_t>(j)].parent : -1;
    Vec3 pos = bm.initial_pose.position;
    Quat q = bm.initial_pose.orientation.normalized();
    if (p >= 0) {  // pose relative to the parent body's frame
      const core::BodyModel& pm = model.bodies[static_cast<std::size_t>(p)];
      const Quat qp = pm.initial_pose.orientation.normalized();
      pos = qp.conjugate() * (bm.initial_pose.position - pm.initial_pose.position);
      q = qp.conjugate() * q;
    }
    x << ind << "<body name=\"" << out.body_names[static_cast<std::size_t>(b)] << "\" pos=\""
      << vec(pos) << "\" quat=\"" << quat(q) << "\">\n";
    if (j < 0) {
      x << ind << "  <freejoint name=\"free_" << b << "\"/>\n";
    } else {
      const core::JointModel& jm = model.joints[static_cast<std::size_t>(j)];
      const std::string at = "pos=\"" + vec(jm.frame_child.position) + "\" axis=\"" +
                             vec(jm.frame_child.orientation.normalized() * Vec3::UnitZ()) + "\"";
      const std::string jn = indexed("j", static_cast<std::size_t>(j), jm.name);
      switch (jm.type) {
        case core::JointType::kFixed:
          break;
        case core::JointType::kRevolute:
          x << ind << "  <joint name=\"" << jn << "\" type=\"hinge\" " << at << "/>\n";
          break;
        case core::JointType::kPrismatic:
          x << ind << "  <joint name=\"" << jn << "\" type=\"slide\" " << at << "/>\n";
          break;
        case core::JointType::kCylindrical:
          x << ind << "  <joint name=\"" << jn << "_slide\" type=\"slide\" " << at << "/>\n";
          x << ind << "  <joint name=\"" << jn << "\" type=\"hinge\" " << at << "/>\n";
          break;
        case core::JointType::kSpherical:
          x << ind << "  <joint name=\"" << jn << "\" type=\"ball\" pos=\""
            << vec(jm.frame_child.position) << "\"/>\n";
          break;
        case core::JointType::kTrocar:
          throw std::invalid_argument("mjcf: joint '" + jm.name +
                                      "' is a trocar (remote centre of motion): no single MuJoCo "
                                      "joint; model it as a ball at the trocar point + a slide");
      }
      if (jm.prescribed) {
        const core::BodyState child = initial_state(bm);
        core::BodyState parent;
        if (p >= 0) parent = initial_state(model.bodies[static_cast<std::size_t>(p)]);
        out.coordinate_offset[static_cast<std::size_t>(j)] =
            core::joint_coordinate(jm, p >= 0 ? &parent : nullptr, child);
        out.prescribed_names[static_cast<std::size_t>(j)] = "prescribed_" + jn;
      }
    }
    const Eigen::Matrix3d& I = bm.inertia_body;
    x << ind << "  <inertial pos=\"0 0 0\" mass=\"" << num(bm.mass) << "\" fullinertia=\""
      << num(I(0, 0)) << " " << num(I(1, 1)) << " " << num(I(2, 2)) << " " << num(I(0, 1)) << " "
      << num(I(0, 2)) << " " << num(I(1, 2)) << "\"/>\n";
    if (bm.sphere_count > 0) {
      const int mat_b = obstacle_material >= 0 ? obstacle_material : bm.material;
      const core::MaterialPair& mp = model.material_pair(bm.material, mat_b);
      const SoftConstraint sc = match_spring(mp.stiffness, mp.damping, bm.mass, model.dt);
      const std::string fr = mp.friction > 0.0
                                 ? "condim=\"3\" friction=\"" + num(mp.friction) + " 0.005 0.0001\""
                                 : "condim=\"1\"";
      for (int s = bm.sphere_begin; s < bm.sphere_begin + bm.sphere_count; ++s) {
        const core::Sphere& sp = model.body_spheres[static_cast<std::size_t>(s)];
        x << ind << "  <geom type=\"sphere\" size=\"" << num(sp.radius) << "\" pos=\""
          << vec(sp.center) << "\" priority=\"1\" " << fr << " " << soft_attrs(sc) << "/>\n";
      }
    }
    for (int c : children[static_cast<std::size_t>(b)]) write_body(c, depth + 1);
    x << ind << "</body>\n";
  };
  for (int r : roots) write_body(r, 0);

  // Mocap bodies: one per held body, placed at its initial pose (weld relpose = identity).
  if (drive == Drive::kMocapWeld) {
    for (int b : held_bodies) {
      if (b < 0 || b >= nb) continue;
      const core::BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
      out.mocap_names[static_cast<std::size_t>(b)] =
          indexed("mocap", static_cast<std::size_t>(b), bm.name);
      out.weld_names[static_cast<std::size_t>(b)] =
          indexed("weld", static_cast<std::size_t>(b), bm.name);
      x << "    <body name=\"" << out.mocap_names[static_cast<std::size_t>(b)]
        << "\" mocap=\"true\" pos=\"" << vec(bm.initial_pose.position) << "\" quat=\""
        << quat(bm.initial_pose.orientation.normalized()) << "\"/>\n";
    }
  }
  x << "  </worldbody>\n";

  // Bodies of one articulation never collide with each other (numen: same body_tree).
  x << "  <contact>\n";
  for (int a = 0; a < nb; ++a)
    for (int b = a + 1; b < nb; ++b)
      if (model.articulation.body_tree[static_cast<std::size_t>(a)] ==
          model.articulation.body_tree[static_cast<std::size_t>(b)])
        x << "    <exclude body1=\"" << out.body_names[static_cast<std::size_t>(a)] << "\" body2=\""
          << out.body_names[static_cast<std::size_t>(b)] << "\"/>\n";
  x << "  </contact>\n";

  x << "  <equality>\n";
  if (drive == Drive::kMocapWeld) {
    for (int b : held_bodies) {
      if (b < 0 || b >= nb) continue;
      const core::BodyModel& bm = model.bodies[static_cast<std::size_t>(b)];
      if (!(bm.coupling.k_t > 0.0))
        throw std::invalid_argument("mjcf: body '" + bm.name +
                                    "' is held but has no coupling stiffness");
      const SoftConstraint sc =
          match_spring(bm.coupling.k_t, bm.coupling.gamma_t, bm.mass, model.dt);
      x << "    <weld name=\"" << out.weld_names[static_cast<std::size_t>(b)] << "\" body1=\""
        << out.body_names[static_cast<std::size_t>(b)] << "\" body2=\""
        << out.mocap_names[static_cast<std::size_t>(b)] << "\" relpose=\"0 0 0 1 0 0 0\" active=\""
        << (b == model.initial_held_body ? "true" : "false") << "\" " << soft_attrs(sc) << "/>\n";
    }
  }
  for (int j = 0; j < model.num_joints(); ++j) {
    const core::JointModel& jm = model.joints[static_cast<std::size_t>(j)];
    if (!jm.prescribed) continue;
    // numen holds a prescribed row with Baumgarte terms at ω = 1/Δt (hard); MuJoCo's stiffest
    // safe reference is timeconst = 2Δt, critically damped.
    x << "    <joint name=\"" << out.prescribed_names[static_cast<std::size_t>(j)]
      << "\" joint1=\"j" << j << "_" << jm.name << "\" polycoef=\"0 0 0 0 0\" solref=\""
      << num(2.0 * model.dt) << " 1\"/>\n";
  }
  x << "  </equality>\n";
  x << "</mujoco>\n";
  out.xml = x.str();

  // What differs.
  out.differences.push_back(
      "contact softness per body geom: rest stiffness and damping ratio of numen's penalty "
      "spring, impedance d from MuJoCo's time-constant rule (docs/peer.md)");
  bool friction = false;
  for (const core::MaterialPair& mp : model.material_pairs)
    friction = friction || mp.friction > 0.0;
  if (friction)
    out.differences.push_back(
        "tangential friction: numen viscous (N·s/m), MuJoCo Coulomb cone with the same number as "
        "coefficient");
  if (model.articulation.num_trees > 1 && nb > 1)
    out.differences.push_back(
        "body-body contacts use each body's own mass in the mapping (A = 1/m): "
        "for two equal bodies MuJoCo's rest stiffness is half numen's");
  if (model.num_joints() > 0)
    out.differences.push_back(
        "joints: MuJoCo reduced coordinates (exact), numen maximal coordinates with "
        "Baumgarte drift correction");
  if (drive == Drive::kMocapWeld) {
    out.differences.push_back(
        "mocap weld: translation matched to the coupling k_t, γ_t; the rotation rows "
        "share the same solref (numen's k_r, γ_r are not used)");
    bool others = false;
    for (int b = 0; b < nb; ++b)
      for (int h : held_bodies)
        others =
            others || (h != b && model.bodies[static_cast<std::size_t>(b)].coupling.k_r > 0.0 &&
                       model.articulation.body_tree[static_cast<std::size_t>(b)] ==
                           model.articulation.body_tree[static_cast<std::size_t>(h)]);
    if (others)
      out.differences.push_back(
          "mocap weld: only the held body is welded; the other bodies' own targets "
          "(Eq. 6) are not used (their joints carry them)");
  }
  return out;
}

}  // namespace numen::peer
