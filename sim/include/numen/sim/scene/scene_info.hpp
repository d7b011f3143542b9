#pragma once
/// @file scene_info.hpp
/// `numen info SCENE`: what a scene compiles to — its sizes, the stages step()
/// runs for it in step order (and why the others are skipped), the contact
/// capacities and the bytes of its Model and Data by buffer group
/// (core/step_stages.hpp, core/capacity.hpp, core/data_size.hpp).

#include <cstddef>
#include <string>
#include <vector>

#include "numen/core/net_material.hpp"
#include "numen/sim/scene/passivity_lint.hpp"

#include "numen/core/data_size.hpp"

namespace numen::sim {

struct Scene;

/// One stage of step() for the scene.
struct StageLine {
  std::string name;         ///< StageDescription::name.
  bool runs = false;        ///< Compiled for this scene (core::compiled_stages()).
  std::string skipped_why;  ///< Why not, when !runs (e.g. "no joints").
};

/// One axis of the scene's device ([[device.axis]]).
struct DeviceAxisLine {
  std::string name;           ///< [[device.axis]] name.
  double rated_torque = 0.0;  ///< N·m or N: the drive's 1000 per mille (AxisConfig::rated_torque).
};

/// One CANopen node of the scene's device in the managed stack ([device.canopen],
/// [[device.canopen.axis]]): the axes it serves, in node order of first appearance.
struct DeviceNodeLine {
  int node_id = 0;
  std::string dcf;        ///< Its DCF, an absolute path; empty without one.
  std::vector<int> axes;  ///< Indices into SceneInfo::device_axes.
};

/// One mesh of the scene and its memory (docs/meshes.md "Limits"): a mesh obstacle's or mesh
/// body's shape (core::MeshShape in Model::meshes), or a net's surface (its triangles in
/// Model::net_faces; its nodes and springs are the Model's "nets" group).
struct MeshLine {
  std::string kind;  ///< "obstacle", "body" or "net".
  std::string name;  ///< The obstacle's, body's or net's name.
  int triangles = 0;
  int vertices = 0;  ///< A net's: its surface's nodes (those of its triangles).
  /// Heap bytes: MeshShape::memory_bytes() (vertices, triangles, normals, edges, tree, grid and
  /// narrow band); a net's: its rows of Model::net_faces.
  std::size_t heap = 0;
  std::size_t band_heap = 0;  ///< Of which the narrow band (core::mesh_band_bytes()); a net: 0.
  double band_width_m = 0.0;  ///< The band's width B (m); 0: none.
  std::string band_note;      ///< Why a shape has no band (the memory cap), else "".
  /// A net's: how it was made from its mesh (Scene::net_loads; docs/fine-surface.md). Zero, false or empty for the other meshes.
  bool simplified = false;  ///< Simplified from its mesh file, whose surface rides on it.
  std::string nodes_from;   ///< NetLoad::nodes_from: "nodes", "edge_length", "default", "mesh".
  int mesh_vertices = 0;    ///< The mesh as read: its vertices (NetLoad::mesh_vertices).
  int mesh_triangles = 0;   ///< And its triangles.
  int fine_vertices = 0;    ///< The fine surface on the net (NetModel::surface_point_count).
  int fine_triangles = 0;   ///< Its triangles (NetModel::surface_face_count).
  /// Largest distance from a fine vertex to the net at rest (core::net_surface_max_offset(), m).
  double fine_max_distance_m = 0.0;
  double simplify_cpu_s = 0.0;  ///< NetLoad::simplify_seconds: simplification and map (CPU s).
  bool cache_loaded = false;    ///< NetLoad::cache_loaded: the net read from its cache file.
  /// Heap bytes of the map: the fine vertices' embeddings, the fine triangles and the net
  /// triangle → fine triangles lists (Model::net_surface_*, net_face_surface_*).
  std::size_t map_heap = 0;
  /// A net given by its material (NetLoad::material; docs/tissue.md): its interior nodes,
  /// tetrahedra and the constants derived; false, 0 and zeros otherwise.
  bool material = false;
  int interior_nodes = 0;
  int tetrahedra = 0;
  core::MaterialNetConstants material_constants;
};

/// One device of the scene, device 0 first (docs/scenes.md, "Several devices").
struct DeviceLine {
  std::string name;                   ///< Its `name`.
  std::string kind;                   ///< hal::to_string(DeviceKind).
  int axes = 0;                       ///< Its axes.
  std::vector<int> node_ids;          ///< Managed stack: its CANopen nodes, in axis order; else empty.
  std::vector<std::string> bodies;    ///< The bodies its links drive (device 0: with the held body).
  std::vector<std::string> graspers;  ///< The graspers whose jaws its axes turn.
};

/// What a scene compiles to.
struct SceneInfo {
  std::string name;
  std::string file;
  std::string integrator;  ///< Scene-file name of the integrator.
  std::string coupling;    ///< Scene-file name of the coupling mode.
  double dt_s = 0.0;
  int bodies = 0, joints = 0, joint_rows = 0, nets = 0, nodes = 0, net_springs = 0;
  int obstacles = 0, body_spheres = 0, static_spheres = 0, materials = 0;
  std::vector<StageLine> stages;  ///< Every stage of step(), in step order.
  int max_contacts = 0;            ///< kMaxContacts (compile time).
  int contact_capacity = 0;        ///< core::contact_capacity(): room of the contact scratch.
  int cross_contact_capacity = 0;  ///< core::cross_contact_capacity().
  /// Data::node_contacts.size(): with nets kMaxNodeContacts and the room of the grasp springs,
  /// the needles' puncture ties and the threads' eyelet springs (make_data()), else 0.
  int node_contact_capacity = 0;
  core::ModelFootprint model_bytes;
  /// Every mesh: the mesh obstacles, then the mesh bodies, then the nets with triangles, each in
  /// the model's order.
  std::vector<MeshLine> meshes;
  core::DataFootprint data_bytes;  ///< Of a Data made by make_data() for the scene.
  std::string device_name;         ///< [device] name.
  std::string device_kind;         ///< hal::to_string(DeviceKind).
  bool device_managed = false;     ///< The managed CANopen stack ([device.canopen] managed).
  std::vector<DeviceAxisLine> device_axes;   ///< Every axis, in the scene's order.
  std::vector<DeviceNodeLine> device_nodes;  ///< Managed stack only; else empty.
  /// "closed" (the scene declares [device.plant]) or "replay".
  std::string device_loop;
  /// Every device, device 0 first (one entry for a scene of one device).
  std::vector<DeviceLine> devices;
  /// The passivity lint of each driven plant axis (Scene::passivity_lint).
  std::vector<PassivityLintRow> passivity_lint;
  /// Wall-clock time of the scene's load (s; sim::load_scene(), as its caller timed it: `numen
  /// info`); negative when not timed (then not printed). describe_scene() leaves it negative.
  double load_wall_s = -1.0;
};

/// Every device of `scene`, device 0 first: its name, kind, axes, CANopen nodes, the bodies its
/// links drive and the graspers whose jaws it turns. Load time only: allocates.
std::vector<DeviceLine> device_lines(const Scene& scene);

/// Describes a loaded scene (makes one Data to measure it). Load time only: allocates.
SceneInfo describe_scene(const Scene& scene);

/// Human-readable report, several lines ending in '\n'; when the load was timed
/// (SceneInfo::load_wall_s ≥ 0), a line "  load: X s wall clock" with, for a scene whose organs'
/// nets were simplified, how many of them were read from their cache file.
std::string format_scene_info(const SceneInfo& info);

/// The same as one JSON object (no trailing newline): keys name, file,
/// integrator, coupling, dt_s, sizes{...}, stages[{name, runs, skipped_why}],
/// capacities{...}, model_bytes{sizeof, heap, groups{...}}, meshes[{kind, name, triangles,
/// vertices, heap, band_heap, band_width_m, band_note}], data_bytes{...},
/// device{name, kind, managed, axes[{name, rated_torque}], nodes[{node_id, dcf, axes[]}]},
/// devices[{name, kind, axes, node_ids[], bodies[], graspers[]}]; and, when timed (load_wall_s
/// ≥ 0), load{wall_s, nets_simplified, nets_from_cache}.
std::string format_scene_info_json(const SceneInfo& info);

}  // namespace numen::sim
