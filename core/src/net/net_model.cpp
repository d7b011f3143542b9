/// @file net_model.cpp
/// Compiles a triangle mesh into a mass-spring net tied to a rigid component
/// (paper §4.2; Meseure & Chaillou 2000).

#include "numen/core/net_model.hpp"

#include <algorithm>
#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/cuthill_mckee_ordering.hpp>
#include <cmath>

#include "numen/core/model.hpp"

namespace numen::core {
namespace {

bool finite_nonnegative(double v) noexcept { return std::isfinite(v) && v >= 0.0; }

}  // namespace

std::string validate_net_owner(const Model& model, int body, int material) {
  if (body < 0 || body >= model.num_bodies())
    return "rigid component body index " + std::to_string(body) + " is not a body of the model";
  // A model without materials yet gets "default" from finalize_model(): material 0.
  if (material < 0 || material >= std::max(1, model.num_materials()))
    return "material index " + std::to_string(material) + " out of range";
  return "";
}

std::string add_net(Model& model, const TriangleMesh& mesh, const NetSettings& settings) {
  const std::string where = "net '" + settings.name + "': ";
  if (const std::string err = validate_net_owner(model, settings.body, settings.material); !err.empty())
    return where + err;
  if (!(std::isfinite(settings.mass) && settings.mass > 0.0))
    return where + "mass must be finite and > 0 kg";
  if (!(std::isfinite(settings.tie_stiffness) && settings.tie_stiffness > 0.0))
    return where + "tie_stiffness must be finite and > 0 N/m (the zero-length springs hold the rest shape)";
  const struct {
    const char* name;
    double value;
  } nonneg[] = {{"stiffness", settings.stiffness},
                {"damping", settings.damping},
                {"bending_stiffness", settings.bending_stiffness},
                {"bending_damping", settings.bending_damping},
                {"tie_damping", settings.tie_damping},
                {"node_radius", settings.node_radius},
                {"rest_speed", settings.rest_speed}};
  for (const auto& p : nonneg)
    if (!finite_nonnegative(p.value)) return where + p.name + " must be finite and >= 0";
  if (const std::string err = validate_mesh(mesh); !err.empty()) return where + "mesh: " + err;

  const MeshTopology topo = build_mesh_topology(mesh);
  const std::vector<double> area = vertex_areas(mesh);
  const std::vector<double> edge = mean_incident_edge_length(mesh, topo);
  double total_area = 0.0;
  for (double a : area) total_area += a;
  if (!(total_area > 0.0) || !std::isfinite(total_area))
    return where + "mesh area must be finite and > 0 (coordinates too large?)";

  // Everything is built aside first, so that a rejected net leaves the model untouched.
  NetModel net;
  net.name = settings.name;
  net.body = settings.body;
  net.material = settings.material;
  net.tie_stiffness = settings.tie_stiffness;
  net.tie_damping = settings.tie_damping;
  net.rest_speed = settings.rest_speed;
  net.node_begin = model.num_nodes();
  net.node_count = mesh.num_vertices();
  net.spring_begin = static_cast<int>(model.net_springs.size());
  std::vector<double> mass(area.size());
  for (std::size_t i = 0; i < area.size(); ++i) {
    mass[i] = settings.mass * area[i] / total_area;
    const double radius = settings.node_radius > 0.0 ? settings.node_radius : edge[i] / std::sqrt(3.0);
    if (!(mass[i] > 0.0) || !std::isfinite(mass[i]) || !(radius > 0.0) || !std::isfinite(radius))
      return where + "vertex " + std::to_string(i) +
             " gets a mass or sphere radius that is not finite and > 0";
    net.mass += mass[i];
  }
  std::vector<NetSpring> springs;
  const auto add_spring = [&](int a, int b, double k, double gamma) {
    NetSpring s;
    s.node_a = net.node_begin + a;
    s.node_b = net.node_begin + b;
    s.rest_length = (mesh.vertices[static_cast<std::size_t>(b)] -
                     mesh.vertices[static_cast<std::size_t>(a)]).norm();
    if (!std::isfinite(s.rest_length)) s.rest_length = 0.0;  // refused below
    s.stiffness = k;
    s.damping = gamma;
    springs.push_back(s);
    return s.rest_length > 0.0;
  };
  for (const auto& [a, b] : topo.edges)
    if (!add_spring(a, b, settings.stiffness, settings.damping))
      return where + "edge " + std::to_string(a) + "-" + std::to_string(b) + " has zero or non-finite length";
  net.structural_count = static_cast<int>(topo.edges.size());
  for (const auto& [a, b] : topo.bending_pairs)
    if (!add_spring(a, b, settings.bending_stiffness, settings.bending_damping))
      return where + "bending pair " + std::to_string(a) + "-" + std::to_string(b) +
             " has zero rest length (coincident vertices)";
  net.bending_count = static_cast<int>(topo.bending_pairs.size());
  // The surface triangles, wound outward (TriangleMesh): a mesh whose triangles enclose a
  // negative signed volume winds inward and is turned (the organ's surface contacts read the
  // outward side from the winding, net_surface.hpp).
  double volume = 0.0;
  for (const auto& t : mesh.triangles)
    volume += mesh.vertices[static_cast<std::size_t>(t[0])].dot(
        mesh.vertices[static_cast<std::size_t>(t[1])].cross(mesh.vertices[static_cast<std::size_t>(t[2])]));
  net.face_begin = static_cast<int>(model.net_faces.size());
  net.face_count = mesh.num_triangles();

  const int net_index = model.num_nets();
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    model.node_rest.push_back(mesh.vertices[i]);
    model.node_mass.push_back(mass[i]);
    model.node_radius.push_back(settings.node_radius > 0.0 ? settings.node_radius
                                                           : edge[i] / std::sqrt(3.0));
    model.node_net.push_back(net_index);
  }
  model.net_springs.insert(model.net_springs.end(), springs.begin(), springs.end());
  for (const auto& t : mesh.triangles)
    model.net_faces.push_back(volume < 0.0 ? std::array<int, 3>{net.node_begin + t[0], net.node_begin + t[2],
                                                                net.node_begin + t[1]}
                                           : std::array<int, 3>{net.node_begin + t[0], net.node_begin + t[1],
                                                                net.node_begin + t[2]});
  model.nets.push_back(std::move(net));
  return "";
}

void order_net_nodes(Model& model) {
  model.node_sweep_order.assign(static_cast<std::size_t>(model.num_nodes()), 0);
  using Graph =
      boost::adjacency_list<boost::vecS, boost::vecS, boost::undirectedS,
                            boost::property<boost::vertex_color_t, boost::default_color_type,
                                            boost::property<boost::vertex_degree_t, int>>>;
  for (const NetModel& net : model.nets) {
    Graph g(static_cast<std::size_t>(net.node_count));
    for (int e = net.spring_begin; e < net.spring_begin + net.structural_count + net.bending_count;
         ++e) {
      const NetSpring& sp = model.net_springs[static_cast<std::size_t>(e)];
      boost::add_edge(static_cast<std::size_t>(sp.node_a - net.node_begin),
                      static_cast<std::size_t>(sp.node_b - net.node_begin), g);
    }
    std::vector<std::size_t> order(static_cast<std::size_t>(net.node_count));
    boost::cuthill_mckee_ordering(g, order.rbegin(), boost::get(boost::vertex_color, g),
                                  boost::make_degree_map(g));
    for (std::size_t p = 0; p < order.size(); ++p)
      model.node_sweep_order[static_cast<std::size_t>(net.node_begin) + p] =
          static_cast<std::int32_t>(order[p]) + net.node_begin;
  }
}

void index_node_springs(Model& model) {
  const auto n = static_cast<std::size_t>(model.num_nodes());
  model.node_spring_begin.assign(n > 0 ? n + 1 : 0, 0);
  model.node_springs.assign(n > 0 ? 2 * model.net_springs.size() : 0, 0);
  if (n == 0) return;
  for (const NetSpring& sp : model.net_springs) {  // counts, then a prefix sum (counting sort)
    ++model.node_spring_begin[static_cast<std::size_t>(sp.node_a) + 1];
    ++model.node_spring_begin[static_cast<std::size_t>(sp.node_b) + 1];
  }
  for (std::size_t i = 0; i < n; ++i) model.node_spring_begin[i + 1] += model.node_spring_begin[i];
  std::vector<std::int32_t> fill(model.node_spring_begin.begin(), model.node_spring_begin.end() - 1);
  for (std::size_t e = 0; e < model.net_springs.size(); ++e) {
    const NetSpring& sp = model.net_springs[e];
    for (const int v : {sp.node_a, sp.node_b})
      model.node_springs[static_cast<std::size_t>(fill[static_cast<std::size_t>(v)]++)] =
          static_cast<std::int32_t>(e);
  }
}

}  // namespace numen::core
