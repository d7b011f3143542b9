/// @file scene_model.cpp
/// Scene file → core::Model (bodies, sphere sets, obstacles, materials).

#include "scene_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <utility>

#include <Eigen/Eigenvalues>

#include "scene_mesh.hpp"

namespace numen::sim {
namespace {

using core::Quat;
using core::Sphere;
using core::Vec3;

// ---------- materials and contact pairs ----------

int material_index(const TomlTable& t, std::string_view key, const core::Model& m) {
  if (!t.has(key)) return 0;
  const std::string name = t.string(key);
  for (int i = 0; i < m.num_materials(); ++i)
    if (m.material_names[static_cast<std::size_t>(i)] == name) return i;
  std::string list;
  for (const auto& n : m.material_names) list += (list.empty() ? "" : ", ") + n;
  t.fail(key, "unknown material \"" + name + "\" (declared: " + list + ")");
}

core::MaterialPair parse_pair(const TomlTable& t, const core::MaterialPair& fallback) {
  core::MaterialPair p;
  p.stiffness = t.number_in("stiffness", 0.0, kInf, fallback.stiffness);
  p.damping = t.number_in("damping", 0.0, kInf, fallback.damping);
  p.friction = t.number_in("friction", 0.0, kInf, fallback.friction);
  p.onset_depth = t.number_in("onset_depth", 0.0, kInf, fallback.onset_depth);
  return p;
}

void parse_materials(const TomlTable& root, core::Model& m) {
  m.material_names.clear();
  for (const TomlTable& t : root.tables("material")) {
    t.allow_only({"name", "description"});
    const std::string name = t.string("name");
    for (const auto& n : m.material_names)
      if (n == name) t.fail("name", "material \"" + name + "\" declared twice");
    m.material_names.push_back(name);
  }
  if (m.material_names.empty()) m.material_names.push_back("default");
  core::MaterialPair fallback;
  if (auto d = root.table("contact_default")) {
    d->allow_only({"stiffness", "damping", "friction", "onset_depth"});
    fallback = parse_pair(*d, fallback);
  }
  const auto n = static_cast<std::size_t>(m.num_materials());
  m.material_pairs.assign(n * n, fallback);
  for (const TomlTable& t : root.tables("contact")) {
    t.allow_only({"materials", "stiffness", "damping", "friction", "onset_depth"});
    const toml::node* node = t.node("materials");
    const toml::array* arr = node ? node->as_array() : nullptr;
    if (!arr || arr->size() != 2 || !arr->get(0)->is_string() || !arr->get(1)->is_string())
      t.fail("materials", "expected two material names, e.g. [\"steel\", \"tissue\"]");
    int idx[2];
    for (int k = 0; k < 2; ++k) {
      const std::string name = arr->get(static_cast<std::size_t>(k))->as_string()->get();
      idx[k] = -1;
      for (int i = 0; i < m.num_materials(); ++i)
        if (m.material_names[static_cast<std::size_t>(i)] == name) idx[k] = i;
      if (idx[k] < 0) t.fail("materials", "unknown material \"" + name + "\"");
    }
    const core::MaterialPair p = parse_pair(t, fallback);
    m.material_pairs[static_cast<std::size_t>(idx[0]) * n + static_cast<std::size_t>(idx[1])] = p;
    m.material_pairs[static_cast<std::size_t>(idx[1]) * n + static_cast<std::size_t>(idx[0])] = p;
  }
}

// ---------- sphere sets ----------

/// [[x, y, z, r], ...] under `key`.
void parse_sphere_list(const TomlTable& t, std::string_view key, std::vector<Sphere>& out) {
  const toml::node* node = t.node(key);
  if (!node) return;
  const toml::array* arr = node->as_array();
  if (!arr) t.fail(key, "expected an array of [x, y, z, radius]");
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const std::string k = t.key_path(key) + "[" + std::to_string(i) + "]";
    const toml::array* s = arr->get(i)->as_array();
    if (!s || s->size() != 4) t.fail_at(arr->get(i), k, "expected [x, y, z, radius]");
    double v[4];
    for (std::size_t j = 0; j < 4; ++j) {
      auto d = s->get(j)->value<double>();
      if (!d || !std::isfinite(*d)) t.fail_at(s->get(j), k, "expected finite numbers");
      v[j] = *d;
    }
    if (!(v[3] > 0.0)) t.fail_at(arr->get(i), k, "radius must be > 0");
    out.push_back(Sphere{Vec3(v[0], v[1], v[2]), v[3]});
  }
}

/// [[sphere_line]]: `count` spheres evenly from `from` to `to`.
void parse_sphere_lines(const TomlTable& t, std::vector<Sphere>& out) {
  for (const TomlTable& l : t.tables("sphere_line")) {
    l.allow_only({"from", "to", "radius", "count"});
    const Vec3 a = l.vec3("from"), b = l.vec3("to");
    const double r = l.number_in("radius", 1e-9, kInf, std::nullopt);
    const auto n = l.integer("count");
    if (n < 1 || n > 100000) l.fail("count", "must be in [1, 100000]");
    for (std::int64_t i = 0; i < n; ++i) {
      const double s = n == 1 ? 0.5 : static_cast<double>(i) / static_cast<double>(n - 1);
      out.push_back(Sphere{a + s * (b - a), r});
    }
  }
}

/// [[sphere_grid]]: a counts[0]×counts[1]×counts[2] lattice filling a box.
void parse_sphere_grids(const TomlTable& t, std::vector<Sphere>& out) {
  for (const TomlTable& g : t.tables("sphere_grid")) {
    g.allow_only({"center", "half_extents", "counts", "radius"});
    const Vec3 c = g.vec3_or("center", Vec3::Zero());
    const Vec3 h = g.vec3("half_extents");
    const double r = g.number_in("radius", 1e-9, kInf, std::nullopt);
    const auto counts = g.numbers("counts", 3);
    int n[3];
    for (int k = 0; k < 3; ++k) {
      if (counts[k] < 1 || counts[k] > 1000 || counts[k] != std::floor(counts[k]))
        g.fail("counts", "each count must be a whole number in [1, 1000]");
      n[k] = static_cast<int>(counts[k]);
    }
    if (static_cast<double>(n[0]) * n[1] * n[2] > 1e6)
      g.fail("counts", "more than a million spheres in one grid");
    for (int i = 0; i < n[0]; ++i)
      for (int j = 0; j < n[1]; ++j)
        for (int k = 0; k < n[2]; ++k) {
          auto at = [](int idx, int cnt, double half) {
            return cnt == 1 ? 0.0 : -half + 2.0 * half * idx / (cnt - 1);
          };
          out.push_back(Sphere{c + Vec3(at(i, n[0], h.x()), at(j, n[1], h.y()), at(k, n[2], h.z())), r});
        }
  }
}

/// [ellipsoid]: spheres on a cubic lattice of pitch `spacing` whose centres
/// lie inside the ellipsoid of semi-axes `radii` shrunk by `sphere_radius`,
/// so the union of spheres approximates the solid ellipsoid (organ model).
void parse_ellipsoid(const TomlTable& t, std::vector<Sphere>& out, std::vector<std::string>& warnings) {
  auto e = t.table("ellipsoid");
  if (!e) return;
  e->allow_only({"center", "radii", "spacing", "sphere_radius"});
  const Vec3 c = e->vec3_or("center", Vec3::Zero());
  const Vec3 radii = e->vec3("radii");
  if (!(radii.minCoeff() > 0.0)) e->fail("radii", "semi-axes must be > 0");
  const double pitch = e->number_in("spacing", 1e-6, kInf, std::nullopt);
  const double r = e->number_in("sphere_radius", 1e-6, kInf, std::nullopt);
  if (r < 0.5 * std::sqrt(3.0) * pitch) {
    std::ostringstream os;
    os << e->file() << ":" << e->node("sphere_radius")->source().begin.line << ": "
       << e->key_path("sphere_radius") << ": " << r << " m < spacing·√3/2 = " << 0.5 * std::sqrt(3.0) * pitch
       << " m leaves holes at the lattice cell centres (the sphere set is porous)";
    warnings.push_back(os.str());
  }
  const Vec3 inner = (radii.array() - r).matrix();
  if (!(inner.minCoeff() > 0.0)) e->fail("sphere_radius", "must be smaller than every semi-axis");
  const Eigen::Vector3i n = (inner / pitch).array().floor().cast<int>().matrix();
  if (static_cast<double>(2 * n.x() + 1) * (2 * n.y() + 1) * (2 * n.z() + 1) > 2e6)
    e->fail("spacing", "too fine: more than 2 million lattice points");
  const std::size_t before = out.size();
  for (int i = -n.x(); i <= n.x(); ++i)
    for (int j = -n.y(); j <= n.y(); ++j)
      for (int k = -n.z(); k <= n.z(); ++k) {
        const Vec3 p(i * pitch, j * pitch, k * pitch);
        if (p.cwiseQuotient(inner).squaredNorm() <= 1.0) out.push_back(Sphere{c + p, r});
      }
  if (out.size() == before) e->fail("spacing", "no sphere fits: reduce spacing or sphere_radius");
}

void transform_spheres(std::vector<Sphere>& s, std::size_t begin, const Vec3& p, const Quat& q) {
  for (std::size_t i = begin; i < s.size(); ++i) s[i].center = p + q * s[i].center;
}

// ---------- bodies ----------

/// Inertia about the body origin of point masses m/n at the sphere centres,
/// each a solid ball (2/5 m r²): the default when a body gives none.
core::Mat3 inertia_from_spheres(double mass, const std::vector<Sphere>& s, std::size_t begin,
                                std::size_t end) {
  core::Mat3 inertia = core::Mat3::Zero();
  const double mi = mass / static_cast<double>(end - begin);
  for (std::size_t i = begin; i < end; ++i) {
    const Vec3& c = s[i].center;
    inertia += mi * (c.squaredNorm() * core::Mat3::Identity() - c * c.transpose());
    inertia += 0.4 * mi * s[i].radius * s[i].radius * core::Mat3::Identity();
  }
  return inertia;
}

core::Mat3 parse_inertia(const TomlTable& t, double mass, const std::vector<Sphere>& s,
                         std::size_t begin, std::size_t end) {
  if (!t.has("inertia")) {
    if (begin == end) t.fail("inertia", "missing: a body without spheres needs an inertia");
    return inertia_from_spheres(mass, s, begin, end);
  }
  const toml::node* n = t.node("inertia");
  const toml::array* arr = n->as_array();
  const std::size_t len = arr ? arr->size() : 0;
  if (len != 3 && len != 6)
    t.fail("inertia", "expected [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (kg·m², body frame at the COM)");
  const auto v = t.numbers("inertia", static_cast<int>(len));
  core::Mat3 inertia = core::Mat3::Zero();
  inertia.diagonal() << v[0], v[1], v[2];
  if (len == 6) {
    inertia(0, 1) = inertia(1, 0) = v[3];
    inertia(0, 2) = inertia(2, 0) = v[4];
    inertia(1, 2) = inertia(2, 1) = v[5];
  }
  Eigen::SelfAdjointEigenSolver<core::Mat3> eig(inertia, Eigen::EigenvaluesOnly);
  if (!(eig.eigenvalues().minCoeff() > 0.0)) t.fail("inertia", "must be positive definite");
  return inertia;
}

/// Paper §3: 1.4 <= γ / √(m k) <= 2 (damping ratio 0.7–1). Default ratio 0.85.
constexpr double kDefaultDampingRatio = 0.85;

double parse_damping(const TomlTable& c, std::string_view damping_key, std::string_view ratio_key,
                     double inertia, double stiffness, std::vector<std::string>& warnings) {
  if (c.has(damping_key) && c.has(ratio_key))
    c.fail(ratio_key, "give either " + std::string(damping_key) + " or " + std::string(ratio_key) + ", not both");
  double gamma;
  if (c.has(damping_key)) {
    gamma = c.number_in(damping_key, 0.0, kInf, std::nullopt);
  } else {
    const double zeta = c.number_in(ratio_key, 0.0, kInf, kDefaultDampingRatio);
    gamma = core::damping_from_ratio(zeta, inertia, stiffness);
  }
  if (stiffness > 0.0) {
    const double rule = gamma / std::sqrt(inertia * stiffness);
    if (rule < 1.4 - 1e-9 || rule > 2.0 + 1e-9) {
      const std::string_view given = c.has(damping_key) ? damping_key : ratio_key;
      std::ostringstream os;
      os << c.file();
      if (const toml::node* n = c.node(given)) os << ":" << n->source().begin.line;
      os << ": " << c.key_path(given) << ": γ/√(m k) = " << rule
         << " is outside the paper's 1.4–2 (damping ratio 0.7–1)";
      warnings.push_back(os.str());
    }
  }
  return gamma;
}

core::CouplingGains parse_coupling(const TomlTable& body, double mass, const core::Mat3& inertia,
                                   std::vector<std::string>& warnings) {
  core::CouplingGains g;
  auto c = body.table("coupling");
  if (!c) return g;
  c->allow_only({"stiffness", "damping", "damping_ratio", "rotational_stiffness",
                 "rotational_damping", "rotational_damping_ratio"});
  g.k_t = c->number_in("stiffness", 0.0, kInf, 0.0);
  g.gamma_t = parse_damping(*c, "damping", "damping_ratio", mass, g.k_t, warnings);
  g.k_r = c->number_in("rotational_stiffness", 0.0, kInf, 0.0);
  // Rotational ratio against the largest principal moment (the slowest mode).
  Eigen::SelfAdjointEigenSolver<core::Mat3> eig(inertia, Eigen::EigenvaluesOnly);
  g.gamma_r = parse_damping(*c, "rotational_damping", "rotational_damping_ratio",
                            eig.eigenvalues().maxCoeff(), g.k_r, warnings);
  return g;
}

void parse_bodies(const TomlTable& root, core::Model& m, std::vector<std::string>& warnings) {
  for (const TomlTable& t : root.tables("body")) {
    t.allow_only({"name", "mass", "inertia", "material", "position", "orientation",
                  "linear_velocity", "angular_velocity", "spheres", "sphere_line",
                  "sphere_grid", "coupling", "link", "link_offset", "device", "anchored", "mesh"});
    core::BodyModel b;
    b.name = t.string("name");
    for (const auto& other : m.bodies)
      if (other.name == b.name) t.fail("name", "body \"" + b.name + "\" declared twice");
    b.mass = t.number_in("mass", 1e-12, kInf, std::nullopt);
    b.material = material_index(t, "material", m);
    const std::size_t begin = m.body_spheres.size();
    parse_sphere_list(t, "spheres", m.body_spheres);
    parse_sphere_lines(t, m.body_spheres);
    parse_sphere_grids(t, m.body_spheres);
    b.sphere_begin = static_cast<int>(begin);
    b.sphere_count = static_cast<int>(m.body_spheres.size() - begin);
    b.inertia_body = parse_inertia(t, b.mass, m.body_spheres, begin, m.body_spheres.size());
    b.initial_pose.position = t.vec3_or("position", Vec3::Zero());
    b.initial_pose.orientation = t.quaternion_or("orientation", Quat::Identity());
    b.initial_twist.linear = t.vec3_or("linear_velocity", Vec3::Zero());
    b.initial_twist.angular = t.vec3_or("angular_velocity", Vec3::Zero());
    b.coupling = parse_coupling(t, b.mass, b.inertia_body, warnings);
    b.anchored = t.boolean_or("anchored", false);
    if (b.anchored) {  // a static body: nothing drives or moves it
      for (const char* key : {"link", "device", "coupling", "linear_velocity", "angular_velocity"})
        if (t.has(key))
          t.fail(key, "body \"" + b.name + "\" is anchored (a static body held where it starts): "
                      "it takes no " + key);
    }
    m.bodies.push_back(std::move(b));
  }
}

// ---------- obstacles ----------

/// Rotation taking +z onto the unit vector `dir`.
Quat z_onto(const Vec3& dir) { return core::rotation_between(Vec3::UnitZ(), dir.normalized()); }

/// A mesh obstacle: the closed mesh of `file`, scaled (`units`, `scale`), built into
/// m.meshes in its own frame (add_mesh_shape(), with its warnings); the obstacle's pose places it.
void parse_mesh_obstacle(const TomlTable& t, const std::filesystem::path& scene_dir,
                         core::Obstacle& o, core::Model& m, std::vector<std::string>& warnings) {
  t.allow_only({"name", "type", "material", "file", "units", "scale", "position", "orientation",
                "cache"});
  o.type = core::ShapeType::kMesh;
  o.pose.position = t.vec3_or("position", Vec3::Zero());
  o.pose.orientation = t.quaternion_or("orientation", Quat::Identity());
  o.mesh = add_mesh_shape(t, scene_dir, m, warnings);
}

/// The [body.mesh] tables (docs/meshes.md, "Mesh bodies"): each body's closed mesh built into
/// m.meshes like a mesh obstacle's (after every body, so that its narrow band covers every
/// sphere), placed in the body frame by the table's `position` and `orientation`.
void parse_body_meshes(const TomlTable& root, const std::filesystem::path& scene_dir, core::Model& m,
                       std::vector<std::string>& warnings) {
  const std::vector<TomlTable> bodies = root.tables("body");
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const std::optional<TomlTable> t = bodies[i].table("mesh");
    if (!t) continue;
    t->allow_only({"file", "units", "scale", "position", "orientation", "cache"});
    core::BodyModel& b = m.bodies[i];
    b.mesh_pose.position = t->vec3_or("position", Vec3::Zero());
    b.mesh_pose.orientation = t->quaternion_or("orientation", Quat::Identity());
    b.mesh = add_mesh_shape(*t, scene_dir, m, warnings);
  }
}

void parse_obstacles(const TomlTable& root, const std::filesystem::path& scene_dir, core::Model& m,
                     std::vector<std::string>& warnings) {
  for (const TomlTable& t : root.tables("obstacle")) {
    core::Obstacle o;
    o.name = t.string("name");
    for (const auto& other : m.obstacles)
      if (other.name == o.name) t.fail("name", "obstacle \"" + o.name + "\" declared twice");
    const std::string type =
        t.choice("type", {"plane", "box", "sphere", "capsule", "sphere-set", "mesh"}, std::nullopt);
    o.material = material_index(t, "material", m);
    if (type == "plane") {
      t.allow_only({"name", "type", "material", "point", "normal"});
      o.type = core::ShapeType::kPlane;
      o.pose.position = t.vec3_or("point", Vec3::Zero());
      const Vec3 n = t.vec3_or("normal", Vec3::UnitZ());
      if (n.norm() < 1e-12) t.fail("normal", "must not be zero");
      o.pose.orientation = z_onto(n);
    } else if (type == "box") {
      t.allow_only({"name", "type", "material", "position", "orientation", "half_extents"});
      o.type = core::ShapeType::kBox;
      o.pose.position = t.vec3_or("position", Vec3::Zero());
      o.pose.orientation = t.quaternion_or("orientation", Quat::Identity());
      o.half_extents = t.vec3("half_extents");
      if (!(o.half_extents.minCoeff() > 0.0)) t.fail("half_extents", "must all be > 0");
    } else if (type == "sphere") {
      t.allow_only({"name", "type", "material", "position", "radius"});
      o.type = core::ShapeType::kSphere;
      o.pose.position = t.vec3_or("position", Vec3::Zero());
      o.radius = t.number_in("radius", 1e-9, kInf, std::nullopt);
    } else if (type == "capsule") {
      t.allow_only({"name", "type", "material", "from", "to", "radius"});
      o.type = core::ShapeType::kCapsule;
      const Vec3 a = t.vec3("from"), b = t.vec3("to");
      if ((b - a).norm() < 1e-12) t.fail("to", "must differ from 'from'");
      o.pose.position = 0.5 * (a + b);
      o.pose.orientation = z_onto(b - a);
      o.half_length = 0.5 * (b - a).norm();
      o.radius = t.number_in("radius", 1e-9, kInf, std::nullopt);
    } else if (type == "mesh") {
      parse_mesh_obstacle(t, scene_dir, o, m, warnings);
    } else {
      t.allow_only({"name", "type", "material", "position", "orientation", "spheres", "ellipsoid",
                    "sphere_line", "sphere_grid"});
      o.type = core::ShapeType::kSphereSet;
      o.pose.position = t.vec3_or("position", Vec3::Zero());
      o.pose.orientation = t.quaternion_or("orientation", Quat::Identity());
      const std::size_t begin = m.static_spheres.size();
      parse_sphere_list(t, "spheres", m.static_spheres);
      parse_ellipsoid(t, m.static_spheres, warnings);
      parse_sphere_lines(t, m.static_spheres);
      parse_sphere_grids(t, m.static_spheres);
      if (m.static_spheres.size() == begin)
        t.fail("spheres", "a sphere set needs spheres (spheres, ellipsoid, sphere_line or sphere_grid)");
      transform_spheres(m.static_spheres, begin, o.pose.position, o.pose.orientation);
      o.sphere_begin = static_cast<int>(begin);
      o.sphere_count = static_cast<int>(m.static_spheres.size() - begin);
    }
    m.obstacles.push_back(std::move(o));
  }
}

}  // namespace

core::Model parse_scene_model(const TomlTable& root, const std::filesystem::path& scene_dir,
                              std::vector<std::string>& warnings) {
  core::Model m;
  m.dt = root.number_in("dt", 1e-7, 1.0, 1e-3);
  m.gravity = root.vec3_or("gravity", Vec3(0.0, 0.0, -9.81));
  const std::string integrator = root.choice(
      "integrator", {"implicit-euler", "symplectic-euler", "trapezoidal", "tr-bdf2"},
      "implicit-euler");
  m.integrator = integrator == "implicit-euler"     ? core::Integrator::kLinearlyImplicitEuler
                 : integrator == "symplectic-euler" ? core::Integrator::kSymplecticEuler
                 : integrator == "trapezoidal"      ? core::Integrator::kTrapezoidal
                                                    : core::Integrator::kTrBdf2;
  const std::string coupling =
      root.choice("coupling", {"god-object", "first-order", "direct", "admittance"}, "god-object");
  m.coupling_mode = coupling == "god-object"    ? core::CouplingMode::kGodObject
                    : coupling == "first-order" ? core::CouplingMode::kFirstOrder
                    : coupling == "direct"      ? core::CouplingMode::kDirect
                                                : core::CouplingMode::kAdmittance;
  if (auto s = root.table("solver")) {
    s->allow_only({"max_iterations", "tolerance", "error_tolerance", "error_estimate_delay",
                   "contact_max_omega_dt", "node_contact_max_omega_dt"});
    const auto it = s->integer_or("max_iterations", m.solver.max_iterations);
    if (it < 1 || it > 100000) s->fail("max_iterations", "must be in [1, 100000]");
    m.solver.max_iterations = static_cast<int>(it);
    const auto delay = s->integer_or("error_estimate_delay", m.solver.error_estimate_delay);
    if (delay < 0 || delay > core::kMaxErrorEstimateDelay)
      s->fail("error_estimate_delay",
              "must be in [0, " + std::to_string(core::kMaxErrorEstimateDelay) + "]");
    m.solver.error_estimate_delay = static_cast<int>(delay);
    m.solver.tolerance = s->number_in("tolerance", 1e-300, 1.0, m.solver.tolerance);
    if (s->has("error_tolerance"))
      m.solver.error_tolerance = s->number_in("error_tolerance", 1e-300, 1.0, std::nullopt);
    m.solver.contact_max_omega_dt =
        s->number_in("contact_max_omega_dt", 1e-3, kInf, m.solver.contact_max_omega_dt);
    m.solver.node_contact_max_omega_dt = s->number_in("node_contact_max_omega_dt", 1e-3, kInf,
                                                      m.solver.node_contact_max_omega_dt);
  }
  parse_materials(root, m);
  parse_bodies(root, m, warnings);
  parse_body_meshes(root, scene_dir, m, warnings);
  parse_obstacles(root, scene_dir, m, warnings);
  m.initial_held_body = -1;  // set by the device section (scene.cpp), which finalizes
  return m;
}

}  // namespace numen::sim
