/// @file net_material.cpp
/// A material net (net_material.hpp): the springs, ties and masses of a tetrahedral mesh
/// derived from the tissue's Young's modulus, Poisson's ratio, density and Rayleigh damping.

#include "numen/core/net_material.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/core/net_tissue_contact.hpp"

namespace numen::core {
namespace {

/// Signed volume of the tetrahedron (a, b, c, d) (m³): positive when d lies on the side of
/// (b − a) × (c − a).
double signed_volume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) noexcept {
  return tetrahedron_six_volume(a, b, c, d) / 6.0;
}

}  // namespace

double default_load_patch_radius(double surface_area) noexcept {
  return kLoadPatchEdges * std::sqrt(2.0 * surface_area / (std::sqrt(3.0) * kLoadPatchCoarsestNodes));
}

std::string validate_material(const NetMaterial& m, const char** key) {
  const auto bad = [key](const char* k, const char* message) {
    if (key) *key = k;
    return std::string(message);
  };
  if (!(std::isfinite(m.youngs_modulus) && m.youngs_modulus > 0.0))
    return bad("youngs_modulus_kpa", "Young's modulus must be finite and > 0");
  if (!(std::isfinite(m.poisson_ratio) && m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5))
    return bad("poisson_ratio",
               "Poisson's ratio must be in (-1, 0.5): 0.5 (incompressible) has no formulation "
               "here; near-incompressible tissue takes 0.45 to 0.49");
  if (!(std::isfinite(m.density) && m.density > 0.0))
    return bad("density", "the density must be finite and > 0 kg/m^3");
  if (!(std::isfinite(m.rayleigh_stiffness) && m.rayleigh_stiffness >= 0.0))
    return bad("rayleigh_stiffness", "the Rayleigh damping coefficient must be finite and >= 0 s");
  if (!(std::isfinite(m.support_length) && m.support_length > 0.0))
    return bad("support_length", "the support length must be finite and > 0 m");
  if (!(std::isfinite(m.strain_stiffening) && m.strain_stiffening >= 0.0 &&
        m.strain_stiffening <= kMaxStrainStiffening))
    return bad("strain_stiffening",
               "the strain stiffening b must be in [0, 4]: the contact law's half-space is "
               "tabulated to b = 4 (docs/tissue.md, \"The contact\")");
  return "";
}

namespace {

/// The settings' and the mesh's checks of add_material_net(): "" or the error (without the
/// net's name).
std::string validate_material_net(const Model& model, const TetrahedralMesh& mesh,
                                  const MaterialNetSettings& settings) {
  if (const std::string err = validate_net_owner(model, settings.body, settings.material); !err.empty())
    return err;
  const char* key = "";
  if (const std::string err = validate_material(settings.tissue, &key); !err.empty())
    return key + std::string(": ") + err;
  if (!(std::isfinite(settings.node_radius) && settings.node_radius >= 0.0))
    return "node_radius must be finite and >= 0";
  if (!(std::isfinite(settings.rest_speed) && settings.rest_speed >= 0.0))
    return "rest_speed must be finite and >= 0";
  if (!(std::isfinite(settings.load_patch_radius) && settings.load_patch_radius >= 0.0))
    return "load_patch_radius must be finite and >= 0";
  if (const std::string err = validate_mesh(mesh.surface); !err.empty()) return "surface: " + err;
  for (std::size_t j = 0; j < mesh.interior.size(); ++j)
    if (!mesh.interior[j].allFinite())
      return "interior node " + std::to_string(mesh.surface.num_vertices() + static_cast<int>(j)) +
             " is not finite";
  if (mesh.tetrahedra.empty()) return "the mesh has no tetrahedron";
  return "";
}

/// The tetrahedra's volumes: per node its lumped volume (a quarter of each tetrahedron at it),
/// per edge (a < b, local indices) Σ V_t of the tetrahedra holding it, and the whole volume (m³).
struct LumpedVolumes {
  std::vector<double> node;
  std::map<std::pair<int, int>, double> edge;
  double total = 0.0;
};

/// Sums `out` over the mesh's tetrahedra; "" or the error (a node index out of range or
/// repeated, a degenerate tetrahedron, a node in no tetrahedron).
std::string lump_volumes(const TetrahedralMesh& mesh, LumpedVolumes& out) {
  const int n = mesh.num_nodes();
  out.node.assign(static_cast<std::size_t>(n), 0.0);
  for (std::size_t t = 0; t < mesh.tetrahedra.size(); ++t) {
    const auto& q = mesh.tetrahedra[t];
    for (int c = 0; c < 4; ++c) {
      if (q[static_cast<std::size_t>(c)] < 0 || q[static_cast<std::size_t>(c)] >= n)
        return "tetrahedron " + std::to_string(t) + " has node index " +
               std::to_string(q[static_cast<std::size_t>(c)]) + " out of range [0, " +
               std::to_string(n) + ")";
      for (int d = 0; d < c; ++d)
        if (q[static_cast<std::size_t>(c)] == q[static_cast<std::size_t>(d)])
          return "tetrahedron " + std::to_string(t) + " repeats node " +
                 std::to_string(q[static_cast<std::size_t>(c)]);
    }
    const double v = std::abs(signed_volume(mesh.node(q[0]), mesh.node(q[1]), mesh.node(q[2]),
                                            mesh.node(q[3])));
    if (!(v > 0.0) || !std::isfinite(v))
      return "tetrahedron " + std::to_string(t) + " has zero or non-finite volume";
    out.total += v;
    for (int c = 0; c < 4; ++c) {
      out.node[static_cast<std::size_t>(q[static_cast<std::size_t>(c)])] += 0.25 * v;
      for (int d = c + 1; d < 4; ++d) {
        const int a = std::min(q[static_cast<std::size_t>(c)], q[static_cast<std::size_t>(d)]);
        const int b = std::max(q[static_cast<std::size_t>(c)], q[static_cast<std::size_t>(d)]);
        out.edge[{a, b}] += v;
      }
    }
  }
  for (int i = 0; i < n; ++i)
    if (!(out.node[static_cast<std::size_t>(i)] > 0.0))
      return "node " + std::to_string(i) + " is in no tetrahedron";
  return "";
}

/// The springs of the net's edges and, per node, what its sphere radius and step bound need.
struct MaterialSprings {
  std::vector<NetSpring> springs;
  std::vector<double> incident_length;  ///< Σ rest length of the node's springs (m).
  std::vector<int> incident_count;      ///< The node's springs.
  std::vector<double> stiffness_sum;    ///< Σ stiffness of the node's springs (N/m).
  double k_min = HUGE_VAL, k_max = 0.0;
};

/// An edge's spring k = E_net Σ V_t / ℓ² (net_material.hpp), damped by Rayleigh's β k; "" or
/// the error (an edge of zero length).
std::string make_material_springs(const TetrahedralMesh& mesh, const LumpedVolumes& volumes,
                                  int node_begin, double net_modulus, double rayleigh_stiffness,
                                  MaterialSprings& out) {
  const auto n = static_cast<std::size_t>(mesh.num_nodes());
  out.springs.reserve(volumes.edge.size());
  out.incident_length.assign(n, 0.0);
  out.incident_count.assign(n, 0);
  out.stiffness_sum.assign(n, 0.0);
  for (const auto& [edge, v] : volumes.edge) {
    NetSpring s;
    s.node_a = node_begin + edge.first;
    s.node_b = node_begin + edge.second;
    s.rest_length = (mesh.node(edge.second) - mesh.node(edge.first)).norm();
    if (!(s.rest_length > 0.0) || !std::isfinite(s.rest_length))
      return "edge " + std::to_string(edge.first) + "-" + std::to_string(edge.second) +
             " has zero or non-finite length";
    s.stiffness = net_modulus * v / (s.rest_length * s.rest_length);
    s.damping = rayleigh_stiffness * s.stiffness;
    out.k_min = std::min(out.k_min, s.stiffness);
    out.k_max = std::max(out.k_max, s.stiffness);
    for (const int i : {edge.first, edge.second}) {
      out.incident_length[static_cast<std::size_t>(i)] += s.rest_length;
      ++out.incident_count[static_cast<std::size_t>(i)];
      out.stiffness_sum[static_cast<std::size_t>(i)] += s.stiffness;
    }
    out.springs.push_back(s);
  }
  return "";
}

/// Each node's mass ρ V_i and sphere radius (the settings' or its springs' mean length / √3),
/// the net's mass, and the largest ω² = (tie + 4 Σ k) / m of the explicit step bound; "" or the
/// error.
std::string lump_masses(const MaterialNetSettings& settings, const LumpedVolumes& volumes,
                        const MaterialSprings& springs, NetModel& net, std::vector<double>& mass,
                        std::vector<double>& radius, double& omega2_max) {
  const int n = static_cast<int>(volumes.node.size());
  mass.resize(static_cast<std::size_t>(n));
  radius.resize(static_cast<std::size_t>(n));
  omega2_max = 0.0;
  for (int i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    mass[u] = settings.tissue.density * volumes.node[u];
    radius[u] = settings.node_radius > 0.0
                    ? settings.node_radius
                    : springs.incident_length[u] / std::max(1, springs.incident_count[u]) / std::sqrt(3.0);
    if (!(mass[u] > 0.0) || !std::isfinite(mass[u]) || !(radius[u] > 0.0) || !std::isfinite(radius[u]))
      return "node " + std::to_string(i) + " gets a mass or sphere radius that is not finite and > 0";
    omega2_max = std::max(omega2_max, (net.tie_scale[u] * net.tie_stiffness + 4.0 * springs.stiffness_sum[u]) / mass[u]);
    net.mass += mass[u];
  }
  return "";
}

/// Six times the signed volume the surface encloses (Σ a · (b × c)): negative when its triangles are wound
/// inward.
double enclosed_volume_sign(const TriangleMesh& surface) noexcept {
  double enclosed = 0.0;
  for (const auto& t : surface.triangles)
    enclosed += surface.vertices[static_cast<std::size_t>(t[0])].dot(
        surface.vertices[static_cast<std::size_t>(t[1])].cross(
            surface.vertices[static_cast<std::size_t>(t[2])]));
  return enclosed;
}

/// The contact law's constants on `net`: E* = E / (1 − ν²), the surface nodes' areas and
/// outward normals, the load patch's radius; returns the surface's mean edge (m).
double set_contact_constants(const TriangleMesh& surface, const MaterialNetSettings& settings,
                             double enclosed, NetModel& net) {
  const double nu = settings.tissue.poisson_ratio;
  net.contact_modulus = settings.tissue.youngs_modulus / (1.0 - nu * nu);
  net.contact_poisson_ratio = nu;
  net.contact_stiffening = settings.tissue.strain_stiffening;
  net.surface_node_area.assign(static_cast<std::size_t>(surface.num_vertices()), 0.0);
  net.surface_node_normal.assign(static_cast<std::size_t>(surface.num_vertices()), Vec3::Zero());
  double area = 0.0, edge_sum = 0.0;
  for (const auto& t : surface.triangles) {
    const Vec3& a = surface.vertices[static_cast<std::size_t>(t[0])];
    const Vec3& b = surface.vertices[static_cast<std::size_t>(t[1])];
    const Vec3& c = surface.vertices[static_cast<std::size_t>(t[2])];
    const double at = 0.5 * (b - a).cross(c - a).norm();
    area += at;
    edge_sum += (b - a).norm() + (c - b).norm() + (a - c).norm();
    const Vec3 outward = (enclosed < 0.0 ? -0.5 : 0.5) * (b - a).cross(c - a);  // area × normal
    for (const int v : t) {
      net.surface_node_area[static_cast<std::size_t>(v)] += at / 3.0;
      net.surface_node_normal[static_cast<std::size_t>(v)] += outward;
    }
  }
  for (Vec3& normal : net.surface_node_normal) {
    const double len = normal.norm();
    if (len > 0.0) normal /= len;
  }
  net.load_patch_radius = settings.load_patch_radius > 0.0 ? settings.load_patch_radius
                                                           : default_load_patch_radius(area);
  // Every edge is in two triangles of a closed surface: the mean edge is Σ / (3 T).
  return edge_sum / (3.0 * std::max(1, surface.num_triangles()));
}

/// The tetrahedra whose inversion the net reports (kInversionWatchQuality), as global node
/// indices from `node_begin`, each ordered to a positive volume at rest (lump_volumes() refused
/// a flat one).
std::vector<std::array<int, 4>> watched_tetrahedra(const TetrahedralMesh& mesh, int node_begin) {
  std::vector<std::array<int, 4>> out;
  for (const auto& q : mesh.tetrahedra) {
    const Vec3 &a = mesh.node(q[0]), &b = mesh.node(q[1]), &c = mesh.node(q[2]), &d = mesh.node(q[3]);
    const double l_max = std::sqrt(std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (d - a).squaredNorm(),
                                             (c - b).squaredNorm(), (d - b).squaredNorm(), (d - c).squaredNorm()}));
    const double v = signed_volume(a, b, c, d);
    if (!(6.0 * std::sqrt(2.0) * std::abs(v) >= kInversionWatchQuality * l_max * l_max * l_max)) continue;
    std::array<int, 4> t{node_begin + q[0], node_begin + q[1], node_begin + q[2], node_begin + q[3]};
    if (v < 0.0) std::swap(t[2], t[3]);
    out.push_back(t);
  }
  return out;
}

/// The net's nodes, springs, outward-wound triangles and `watched` tetrahedra appended to the
/// model, the net last.
void append_material_net(Model& model, const TetrahedralMesh& mesh, NetModel&& net,
                         const std::vector<NetSpring>& springs, const std::vector<double>& mass,
                         const std::vector<double>& radius, double enclosed,
                         const std::vector<std::array<int, 4>>& watched) {
  const int net_index = model.num_nets();
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    model.node_rest.push_back(mesh.node(i));
    model.node_mass.push_back(mass[static_cast<std::size_t>(i)]);
    model.node_radius.push_back(radius[static_cast<std::size_t>(i)]);
    model.node_net.push_back(net_index);
  }
  model.net_springs.insert(model.net_springs.end(), springs.begin(), springs.end());
  model.net_tetrahedra.insert(model.net_tetrahedra.end(), watched.begin(), watched.end());
  for (const auto& t : mesh.surface.triangles)
    model.net_faces.push_back(enclosed < 0.0
                                  ? std::array<int, 3>{net.node_begin + t[0], net.node_begin + t[2],
                                                       net.node_begin + t[1]}
                                  : std::array<int, 3>{net.node_begin + t[0], net.node_begin + t[1],
                                                       net.node_begin + t[2]});
  model.nets.push_back(std::move(net));
}

}  // namespace

std::string add_material_net(Model& model, const TetrahedralMesh& mesh,
                             const MaterialNetSettings& settings, MaterialNetConstants* constants) {
  const std::string where = "net '" + settings.name + "': ";
  if (const std::string err = validate_material_net(model, mesh, settings); !err.empty())
    return where + err;
  const int n = mesh.num_nodes();
  const NetMaterial& mat = settings.tissue;
  const double nu = mat.poisson_ratio;
  const double net_modulus =
      kNetAffineCorrection * (15.0 / 16.0) * mat.youngs_modulus / (1.0 - nu * nu);
  LumpedVolumes volumes;
  if (const std::string err = lump_volumes(mesh, volumes); !err.empty()) return where + err;
  const double volume = volumes.total;

  NetModel net;
  net.name = settings.name;
  net.body = settings.body;
  net.material = settings.material;
  net.rest_speed = settings.rest_speed;
  net.node_begin = model.num_nodes();
  net.node_count = n;
  net.spring_begin = static_cast<int>(model.net_springs.size());
  const double kappa = net_modulus / (mat.support_length * mat.support_length);
  net.tie_stiffness = kappa * volume / n;
  net.tie_damping = mat.rayleigh_stiffness * net.tie_stiffness;
  if (!(net.tie_stiffness > 0.0) || !std::isfinite(net.tie_stiffness))
    return where + "the ties' stiffness " + std::to_string(net.tie_stiffness) +
           " N/m is not finite and > 0 (a degenerate volume?)";
  // The ties are a stiffness per volume: node i's is κ V_i (its lumped volume, as its mass).
  net.tie_scale.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    net.tie_scale[static_cast<std::size_t>(i)] = volumes.node[static_cast<std::size_t>(i)] * n / volume;

  MaterialSprings springs;
  if (const std::string err = make_material_springs(mesh, volumes, net.node_begin, net_modulus,
                                                    mat.rayleigh_stiffness, springs);
      !err.empty())
    return where + err;
  net.structural_count = static_cast<int>(springs.springs.size());
  net.bending_count = 0;
  std::vector<double> mass, radius;
  double omega2_max = 0.0;
  if (const std::string err = lump_masses(settings, volumes, springs, net, mass, radius, omega2_max);
      !err.empty())
    return where + err;

  const double enclosed = enclosed_volume_sign(mesh.surface);  // wound outward as add_net() does
  net.face_begin = static_cast<int>(model.net_faces.size());
  net.face_count = mesh.surface.num_triangles();
  const std::vector<std::array<int, 4>> watched = watched_tetrahedra(mesh, net.node_begin);
  net.tetrahedron_begin = static_cast<int>(model.net_tetrahedra.size());
  net.tetrahedron_count = static_cast<int>(watched.size());
  const double mean_edge = set_contact_constants(mesh.surface, settings, enclosed, net);

  if (constants) {
    constants->net_modulus = net_modulus;
    constants->volume = volume;
    constants->mass = net.mass;
    constants->tie_stiffness = net.tie_stiffness;
    constants->tie_damping = net.tie_damping;
    constants->spring_stiffness_min = springs.springs.empty() ? 0.0 : springs.k_min;
    constants->spring_stiffness_max = springs.k_max;
    constants->springs = static_cast<int>(springs.springs.size());
    const double omega_max = std::sqrt(omega2_max);
    const double zeta = 0.5 * mat.rayleigh_stiffness * omega_max;  // β ω / 2
    constants->explicit_step_limit =
        omega2_max > 0.0 ? 2.0 / omega_max * (std::sqrt(1.0 + zeta * zeta) - zeta) : HUGE_VAL;
    constants->contact_modulus = net.contact_modulus;
    constants->strain_stiffening = net.contact_stiffening;
    constants->load_patch_radius = net.load_patch_radius;
    constants->surface_mean_edge = mean_edge;
  }
  append_material_net(model, mesh, std::move(net), springs.springs, mass, radius, enclosed, watched);
  return "";
}

}  // namespace numen::core
