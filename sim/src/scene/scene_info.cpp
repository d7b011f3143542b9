/// @file scene_info.cpp
/// `numen info`: a scene's stages, sizes, capacities and bytes (scene_info.hpp).

#include "numen/sim/scene/scene_info.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <nlohmann/json.hpp>

#include "numen/core/capacity.hpp"
#include "numen/core/data.hpp"
#include "numen/core/features.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/net_surface_map.hpp"
#include "numen/core/step_stages.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {
namespace {

/// "12.3 KiB" style, with the exact byte count.
std::string bytes(std::size_t n) {
  std::ostringstream os;
  os << n << " B";
  if (n >= 1024) os << " (" << std::fixed << std::setprecision(1) << n / 1024.0 << " KiB)";
  return os.str();
}

/// {group: heap bytes, ...} in the groups' order.
template <std::size_t N>
nlohmann::ordered_json json_groups(const std::array<core::BufferGroupBytes, N>& groups) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  for (const core::BufferGroupBytes& g : groups) j[g.group] = g.heap_bytes;
  return j;
}

/// The line of a mesh obstacle's or body's shape.
MeshLine shape_line(const char* kind, const std::string& name, const core::MeshShape& s) {
  MeshLine l;
  l.kind = kind;
  l.name = name;
  l.triangles = s.num_triangles();
  l.vertices = static_cast<int>(s.vertices.size());
  l.heap = s.memory_bytes();
  l.band_heap = core::mesh_band_bytes(s.band);
  l.band_width_m = s.band.width;
  l.band_note = s.band.note;
  return l;
}

/// Heap bytes of net `n`'s fine-surface map in `m` (MeshLine::map_heap).
std::size_t map_bytes(const core::Model& m, const core::NetModel& n) {
  if (n.surface_point_count == 0) return 0;
  std::size_t lists = 0;  // the net's triangles' rows of net_face_surface_begin / _faces / _cluster
  if (m.net_face_surface_begin.size() > static_cast<std::size_t>(n.face_begin + n.face_count)) {
    const auto b = [&](int f) { return m.net_face_surface_begin[static_cast<std::size_t>(f)]; };
    const auto entries = static_cast<std::size_t>(b(n.face_begin + n.face_count) - b(n.face_begin));
    lists = (static_cast<std::size_t>(n.face_count) + entries) * sizeof(std::int32_t);
    if (m.net_face_surface_cluster.size() == m.net_face_surface_faces.size()) lists += entries * sizeof(std::int32_t);
  }
  for (const core::NetSurfaceCluster& c : m.net_surface_clusters)  // its patches' records
    if (c.face >= n.face_begin && c.face < n.face_begin + n.face_count) lists += sizeof(c);
  return static_cast<std::size_t>(n.surface_point_count) * sizeof(core::NetSurfacePoint) +
         static_cast<std::size_t>(n.surface_face_count) * sizeof(m.net_surface_faces[0]) + lists;
}

/// Every mesh of `scene`'s model (SceneInfo::meshes).
std::vector<MeshLine> mesh_lines(const Scene& scene) {
  const core::Model& m = scene.model;
  std::vector<MeshLine> out;
  for (const core::Obstacle& o : m.obstacles)
    if (o.type == core::ShapeType::kMesh)
      out.push_back(shape_line("obstacle", o.name, m.meshes[static_cast<std::size_t>(o.mesh)]));
  for (const core::BodyModel& b : m.bodies)
    if (b.mesh >= 0)
      out.push_back(shape_line("body", b.name, m.meshes[static_cast<std::size_t>(b.mesh)]));
  for (std::size_t k = 0; k < m.nets.size(); ++k) {
    const core::NetModel& n = m.nets[k];
    if (n.face_count == 0) continue;
    MeshLine l;
    l.kind = "net";
    l.name = n.name;
    l.triangles = n.face_count;
    l.vertices = n.node_count;
    l.heap = static_cast<std::size_t>(n.face_count) * sizeof(m.net_faces[0]);
    if (k < scene.net_loads.size()) {
      const NetLoad& load = scene.net_loads[k];
      l.simplified = load.simplified;
      l.nodes_from = load.nodes_from;
      l.mesh_vertices = load.mesh_vertices;
      l.mesh_triangles = load.mesh_triangles;
      l.simplify_cpu_s = load.simplify_seconds;
      l.cache_loaded = load.cache_loaded;
      l.material = load.material;
      l.interior_nodes = load.interior_nodes;
      l.tetrahedra = load.tetrahedra;
      l.material_constants = load.material_constants;
      l.vertices -= load.interior_nodes;
    }
    l.fine_vertices = n.surface_point_count;
    l.fine_triangles = n.surface_face_count;
    if constexpr (core::kWithDeformable)  // net_surface_map.cpp is built with the nets only
      l.fine_max_distance_m = core::net_surface_max_offset(m, static_cast<int>(k));
    l.map_heap = map_bytes(m, n);
    out.push_back(std::move(l));
  }
  return out;
}

}  // namespace

SceneInfo describe_scene(const Scene& scene) {
  const core::Model& m = scene.model;
  SceneInfo info;
  info.name = scene.name;
  info.file = scene.file;
  info.integrator = to_string(m.integrator);
  info.coupling = to_string(m.coupling_mode);
  info.dt_s = m.dt;
  info.bodies = m.num_bodies();
  info.joints = m.num_joints();
  info.joint_rows = m.articulation.num_rows;
  info.nets = m.num_nets();
  info.nodes = m.num_nodes();
  info.net_springs = static_cast<int>(m.net_springs.size());
  info.obstacles = static_cast<int>(m.obstacles.size());
  info.body_spheres = static_cast<int>(m.body_spheres.size());
  info.static_spheres = static_cast<int>(m.static_spheres.size());
  info.materials = m.num_materials();
  const std::uint32_t compiled = m.stage_plan;  // finalize_model() computed it
  for (const core::StageDescription& s : core::step_stage_table()) {
    const bool runs = (compiled & s.stage) != 0;
    std::string why;
    if (!runs) why = s.skipped_why != nullptr ? s.skipped_why : "";
    // With nets the joints go through the net solve (net_solve.hpp), not the tree solve.
    if (!runs && s.stage == core::kStageJointSolve && info.joints > 0) why = "joints solved with the nets";
    info.stages.push_back(StageLine{s.name, runs, why});
  }
  info.max_contacts = core::kMaxContacts;
  info.contact_capacity = core::contact_capacity(m);
  info.cross_contact_capacity = core::cross_contact_capacity(m);
  const core::Data data = core::make_data(m);
  info.node_contact_capacity = static_cast<int>(data.node_contacts.size());
  info.model_bytes = core::model_footprint(m);
  info.meshes = mesh_lines(scene);
  info.data_bytes = core::data_footprint(data);
  const hal::DeviceConfig& device = scene.device;
  info.device_name = device.name;
  info.device_kind = hal::to_string(device.kind);
  info.device_managed = device.canopen.managed;
  for (const hal::AxisConfig& a : device.axes) info.device_axes.push_back({a.name, a.rated_torque});
  info.device_loop = scene.plant ? "closed" : "replay";
  info.passivity_lint = scene.passivity_lint;
  if (device.canopen.managed) {
    for (std::size_t a = 0; a < device.canopen.axes.size(); ++a) {
      const hal::CanopenAxisConfig& c = device.canopen.axes[a];
      auto node = std::find_if(info.device_nodes.begin(), info.device_nodes.end(),
                               [&](const DeviceNodeLine& n) { return n.node_id == c.node_id; });
      if (node == info.device_nodes.end()) {
        DeviceNodeLine n;
        n.node_id = c.node_id;
        if (c.dcf) n.dcf = std::filesystem::absolute(c.dcf->path).lexically_normal().string();
        info.device_nodes.push_back(std::move(n));
        node = info.device_nodes.end() - 1;
      }
      node->axes.push_back(static_cast<int>(a));
    }
  }
  info.devices = device_lines(scene);
  return info;
}

std::vector<DeviceLine> device_lines(const Scene& scene) {
  std::vector<DeviceLine> lines;
  const core::Model& m = scene.model;
  for (std::size_t d = 0; d < num_devices(scene); ++d) {
    const hal::DeviceConfig& config = d == 0 ? scene.device : scene.extra_devices[d - 1].device;
    const platform::DeviceBinding& binding = d == 0 ? scene.binding : scene.extra_devices[d - 1].binding;
    DeviceLine l;
    l.name = config.name;
    l.kind = hal::to_string(config.kind);
    l.axes = static_cast<int>(config.axes.size());
    if (config.canopen.managed)
      for (const hal::CanopenAxisConfig& c : config.canopen.axes) l.node_ids.push_back(c.node_id);
    if (d == 0 && m.initial_held_body >= 0) l.bodies.push_back(m.bodies[static_cast<std::size_t>(m.initial_held_body)].name);
    for (const platform::LinkBinding& b : binding.links) {
      if (b.body < 0) continue;
      const std::string& name = m.bodies[static_cast<std::size_t>(b.body)].name;
      if (std::find(l.bodies.begin(), l.bodies.end(), name) == l.bodies.end()) l.bodies.push_back(name);
    }
    for (std::size_t g = 0; g < m.grasps.size(); ++g)
      if (grasper_device(scene, static_cast<int>(g)) == static_cast<int>(d)) l.graspers.push_back(m.grasps[g].name);
    lines.push_back(std::move(l));
  }
  return lines;
}

std::string format_scene_info(const SceneInfo& i) {
  std::ostringstream os;
  os << "scene " << i.name << " (" << i.file << ")\n";
  os << "  integrator " << i.integrator << ", coupling " << i.coupling << ", dt " << i.dt_s * 1e3
     << " ms\n";
  os << "  sizes: " << i.bodies << " bodies (" << i.body_spheres << " spheres), " << i.joints
     << " joints (" << i.joint_rows << " rows), " << i.nets << " nets (" << i.nodes << " nodes, "
     << i.net_springs << " springs), " << i.obstacles << " obstacles (" << i.static_spheres
     << " static spheres), " << i.materials << " materials\n";
  if (i.load_wall_s >= 0.0) {
    int simplified = 0, cached = 0;
    for (const MeshLine& l : i.meshes) {
      simplified += l.simplified ? 1 : 0;
      cached += l.simplified && l.cache_loaded ? 1 : 0;
    }
    os << "  load: " << std::fixed << std::setprecision(3) << i.load_wall_s << std::defaultfloat
       << " s wall clock";
    if (simplified > 0)
      os << "; organ nets simplified from a mesh file: " << simplified << ", of which " << cached
         << " read from " << (cached == 1 ? "its" : "their") << " cache file";
    os << "\n";
  }
  os << "  stages of step(), in order:\n";
  int k = 1;
  for (const StageLine& s : i.stages) {
    os << "    " << std::setw(2) << k++ << ". " << s.name;
    if (!s.runs) os << "  -- skipped: " << s.skipped_why;
    os << "\n";
  }
  os << "  capacities: contacts " << i.contact_capacity << " (compiled max " << i.max_contacts
     << "), body-body contacts " << i.cross_contact_capacity << ", node contacts "
     << i.node_contact_capacity << "\n";
  os << "  Model: sizeof " << bytes(i.model_bytes.sizeof_model) << ", heap "
     << bytes(i.model_bytes.heap_bytes()) << "\n";
  for (const core::BufferGroupBytes& g : i.model_bytes.groups)
    os << "    " << std::left << std::setw(24) << g.group << std::right << bytes(g.heap_bytes) << "\n";
  for (const MeshLine& l : i.meshes) {
    os << "  mesh " << l.kind << " " << l.name << ": " << l.triangles << " triangles, "
       << l.vertices << (l.kind == "net" ? " nodes, " : " vertices, ") << bytes(l.heap);
    if (l.kind == "net")
      os << " of triangles (no narrow band: the surface moves)";
    else if (l.band_width_m > 0.0)
      os << ", of which narrow band " << bytes(l.band_heap) << " (width " << l.band_width_m * 1e3
         << " mm)";
    else
      os << ", " << (l.band_note.empty() ? "no narrow band" : l.band_note);
    os << "\n";
    if (l.kind == "net" && l.simplified)
      os << "    simplified from its mesh file (" << l.mesh_vertices << " vertices, "
         << l.mesh_triangles << " triangles) to " << l.vertices << " nodes ("
         << (l.nodes_from == "default" ? "the default net size" : l.nodes_from) << ")"
         << (l.cache_loaded ? ", read from its cache file," : "") << " in "
         << std::fixed << std::setprecision(3) << l.simplify_cpu_s << std::defaultfloat
         << " s of CPU; fine surface " << l.fine_vertices << " vertices, " << l.fine_triangles
         << " triangles, up to " << std::fixed << std::setprecision(3)
         << l.fine_max_distance_m * 1e3 << std::defaultfloat << " mm off the net; map "
         << bytes(l.map_heap) << "\n";
    else if (l.kind == "net")
      os << "    its mesh as it is (" << l.mesh_vertices << " vertices, not simplified), no fine "
            "surface\n";
    if (l.material) {
      const core::MaterialNetConstants& c = l.material_constants;
      os << "    given by its material (docs/tissue.md): " << l.interior_nodes
         << " interior nodes, " << l.tetrahedra << " tetrahedra, " << std::setprecision(4)
         << c.volume * 1e6 << " cm^3, " << c.mass * 1e3 << " g; E_net " << c.net_modulus * 1e-3
         << " kPa, springs " << c.spring_stiffness_min << " to " << c.spring_stiffness_max
         << " N/m, ties " << c.tie_stiffness << " N/m per node; symplectic Euler step at most "
         << c.explicit_step_limit << " s; contact E* " << c.contact_modulus * 1e-3
         << " kPa, strain stiffening b " << c.strain_stiffening << ", load patch radius "
         << c.load_patch_radius * 1e3 << " mm" << std::defaultfloat
         << std::setprecision(6) << "\n";
    }
  }
  os << "  Data: sizeof " << bytes(i.data_bytes.sizeof_data) << " (contact array "
     << i.max_contacts << " x " << sizeof(core::Contact) << " B inside), heap "
     << bytes(i.data_bytes.heap_bytes()) << "\n";
  for (const core::BufferGroupBytes& g : i.data_bytes.groups)
    os << "    " << std::left << std::setw(24) << g.group << std::right << bytes(g.heap_bytes) << "\n";
  os << "  device " << i.device_name << ": " << i.device_kind << ", " << i.device_axes.size()
     << " axes, " << (i.device_managed ? "managed CANopen stack" : "minimal protocol") << "\n";
  for (const DeviceNodeLine& n : i.device_nodes) {
    os << "    node " << n.node_id << ":";
    for (int a : n.axes) os << " " << i.device_axes[static_cast<std::size_t>(a)].name;
    os << (n.dcf.empty() ? " (no DCF)" : ", DCF " + n.dcf) << "\n";
  }
  os << "  device loop: " << i.device_loop << "\n";
  os << "  devices: " << i.devices.size() << "\n";
  for (const DeviceLine& d : i.devices) {
    os << "    " << d.name << ": " << d.kind << ", " << d.axes << " axes";
    if (!d.node_ids.empty()) {
      os << ", nodes";
      for (int n : d.node_ids) os << " " << n;
    }
    os << "; drives";
    for (const std::string& b : d.bodies) os << " " << b;
    if (d.bodies.empty()) os << " nothing";
    for (const std::string& g : d.graspers) os << "; grasper " << g;
    os << "\n";
  }
  for (const PassivityLintRow& r : i.passivity_lint)
    os << "    passivity of " << r.axis_name << ": K " << r.stiffness << ", B " << r.damping
       << " rendered at T " << r.period_s << " s; b " << r.device_damping << " against K T/2 + |B| "
       << r.stiffness * r.period_s / 2.0 + std::abs(r.damping)
       << " (Colgate & Schenkel), K against max(2b/T, 2 f_c/Δ) " << r.abbott_okamura_bound
       << " (Abbott & Okamura): " << (r.passes ? "passive" : "NOT PASSIVE") << "\n";
  return os.str();
}

std::string format_scene_info_json(const SceneInfo& i) {
  nlohmann::ordered_json j;  // keys in insertion order
  j["name"] = i.name;
  j["file"] = i.file;
  j["integrator"] = i.integrator;
  j["coupling"] = i.coupling;
  j["dt_s"] = i.dt_s;
  j["sizes"] = {{"bodies", i.bodies},
                {"body_spheres", i.body_spheres},
                {"joints", i.joints},
                {"joint_rows", i.joint_rows},
                {"nets", i.nets},
                {"nodes", i.nodes},
                {"net_springs", i.net_springs},
                {"obstacles", i.obstacles},
                {"static_spheres", i.static_spheres},
                {"materials", i.materials}};
  nlohmann::ordered_json stages = nlohmann::ordered_json::array();
  for (const StageLine& s : i.stages)
    stages.push_back({{"name", s.name}, {"runs", s.runs}, {"skipped_why", s.skipped_why}});
  j["stages"] = std::move(stages);
  j["capacities"] = {{"max_contacts", i.max_contacts},
                     {"contacts", i.contact_capacity},
                     {"body_contacts", i.cross_contact_capacity},
                     {"node_contacts", i.node_contact_capacity}};
  j["model_bytes"] = {{"sizeof", i.model_bytes.sizeof_model},
                      {"heap", i.model_bytes.heap_bytes()},
                      {"groups", json_groups(i.model_bytes.groups)}};
  nlohmann::ordered_json meshes = nlohmann::ordered_json::array();
  for (const MeshLine& l : i.meshes) {
    meshes.push_back({{"kind", l.kind},
                      {"name", l.name},
                      {"triangles", l.triangles},
                      {"vertices", l.vertices},
                      {"heap", l.heap},
                      {"band_heap", l.band_heap},
                      {"band_width_m", l.band_width_m},
                      {"band_note", l.band_note}});
    if (l.kind == "net")
      meshes.back()["net_load"] = {{"simplified", l.simplified},
                                   {"nodes_from", l.nodes_from},
                                   {"mesh_vertices", l.mesh_vertices},
                                   {"mesh_triangles", l.mesh_triangles},
                                   {"fine_vertices", l.fine_vertices},
                                   {"fine_triangles", l.fine_triangles},
                                   {"fine_max_distance_m", l.fine_max_distance_m},
                                   {"simplify_cpu_s", l.simplify_cpu_s},
                                   {"cache_loaded", l.cache_loaded},
                                   {"map_heap", l.map_heap}};
    if (l.material) {
      const core::MaterialNetConstants& c = l.material_constants;
      meshes.back()["material"] = {{"interior_nodes", l.interior_nodes},
                                   {"tetrahedra", l.tetrahedra},
                                   {"volume_m3", c.volume},
                                   {"mass_kg", c.mass},
                                   {"net_modulus_pa", c.net_modulus},
                                   {"spring_stiffness_min_n_per_m", c.spring_stiffness_min},
                                   {"spring_stiffness_max_n_per_m", c.spring_stiffness_max},
                                   {"tie_stiffness_n_per_m", c.tie_stiffness},
                                   {"tie_damping_ns_per_m", c.tie_damping},
                                   {"explicit_step_limit_s", c.explicit_step_limit},
                                   {"contact_modulus_pa", c.contact_modulus},
                                   {"strain_stiffening", c.strain_stiffening},
                                   {"load_patch_radius_m", c.load_patch_radius}};
    }
  }
  j["meshes"] = std::move(meshes);
  j["data_bytes"] = {{"sizeof", i.data_bytes.sizeof_data},
                     {"heap", i.data_bytes.heap_bytes()},
                     {"groups", json_groups(i.data_bytes.groups)}};
  nlohmann::ordered_json axes = nlohmann::ordered_json::array();
  for (const DeviceAxisLine& a : i.device_axes) axes.push_back({{"name", a.name}, {"rated_torque", a.rated_torque}});
  nlohmann::ordered_json nodes = nlohmann::ordered_json::array();
  for (const DeviceNodeLine& n : i.device_nodes)
    nodes.push_back({{"node_id", n.node_id}, {"dcf", n.dcf}, {"axes", n.axes}});
  j["device"] = {{"name", i.device_name},
                 {"kind", i.device_kind},
                 {"managed", i.device_managed},
                 {"axes", std::move(axes)},
                 {"nodes", std::move(nodes)},
                 {"loop", i.device_loop}};
  nlohmann::ordered_json devices = nlohmann::ordered_json::array();
  for (const DeviceLine& d : i.devices)
    devices.push_back({{"name", d.name},
                       {"kind", d.kind},
                       {"axes", d.axes},
                       {"node_ids", d.node_ids},
                       {"bodies", d.bodies},
                       {"graspers", d.graspers}});
  j["devices"] = std::move(devices);
  nlohmann::ordered_json lint = nlohmann::ordered_json::array();
  for (const PassivityLintRow& r : i.passivity_lint)
    lint.push_back({{"axis", r.axis_name},
                    {"period_s", r.period_s},
                    {"stiffness", r.stiffness},
                    {"damping", r.damping},
                    {"device_damping", r.device_damping},
                    {"coulomb", r.coulomb},
                    {"resolution", r.resolution},
                    {"colgate_margin", r.colgate_margin},
                    {"abbott_okamura_bound", r.abbott_okamura_bound},
                    {"passive", r.passes}});
  j["passivity_lint"] = std::move(lint);
  if (i.load_wall_s >= 0.0) {
    int simplified = 0, cached = 0;
    for (const MeshLine& l : i.meshes) {
      simplified += l.simplified ? 1 : 0;
      cached += l.simplified && l.cache_loaded ? 1 : 0;
    }
    j["load"] = {
        {"wall_s", i.load_wall_s}, {"nets_simplified", simplified}, {"nets_from_cache", cached}};
  }
  // A scene's file name may hold bytes that are not UTF-8: replaced by U+FFFD instead of throwing.
  return j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace numen::sim
