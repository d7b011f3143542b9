#pragma once
/// @file scene_deformable.hpp
/// The deformable god-objects of a scene file (docs/scenes.md, paper §4.2):
/// [[deformable]] tables, each a triangle mesh (built-in icosphere, capsule or
/// box, or a Wavefront OBJ file) placed in the frame of a hidden rigid
/// component (a [[body]] without spheres) and compiled by core::add_net() into
/// a mass-spring net tied to that body. Private to numen::sim (used by
/// scene.cpp, before the model is finalized).

#include <filesystem>
#include <string>
#include <vector>

#include "numen/core/model.hpp"
#include "numen/sim/scene/scene.hpp"
#include "toml_reader.hpp"

namespace numen::sim {

/// Reads the [[deformable]] tables of `root` into `model` (its bodies and
/// materials already parsed; not yet finalized). OBJ paths are relative to
/// `scene_dir`. Throws InputError naming file, line, column and key: unknown
/// keys, unknown body or material, a rigid component with spheres, unknown
/// mesh kind, missing OBJ file, numbers out of range; core::add_net()'s own
/// message is located at the deformable's table. Appends each net's triangles (node indices
/// local to the net) to `triangles`, and how it was made to `loads`, in the order of model.nets.
/// A mesh file of more vertices than the net asked for (`nodes`, `edge_length`, else
/// kDefaultNetNodes) is simplified into the net (net_simplify.hpp) and rides on it as its fine
/// surface (core::add_net_surface(); docs/fine-surface.md); bad
/// sizes, a mesh with holes and a failed simplification are errors located at the key that asked
/// for the net's size (`file` for the default). Appends to `warnings` a mesh whose surface
/// intersects itself (core::find_self_intersections(), at `file`, or at `mesh` for a built-in
/// one; docs/meshes.md, "Self-intersections"), a simplified net that does too, a fine surface
/// standing off its net by more than net_surface_offset_bound(), and a slow simplification
/// without a cache (mesh_cache.hpp, slow_net_simplification_hint()). A `cache` path that names
/// anything but nothing or a numen net cache fails at `cache` (mesh_cache.hpp,
/// simplify_net_cached()).
void parse_deformables(const TomlTable& root, const std::filesystem::path& scene_dir,
                       core::Model& model, std::vector<NetTriangles>& triangles,
                       std::vector<NetLoad>& loads, std::vector<std::string>& warnings);

/// Largest distance from an organ's fine surface to the net simplified from it, as a share of
/// the organ's size (the longest side of the fine mesh's bounding box), before a load warning
/// (docs/fine-surface.md): 2 %, 1.4 mm on the 70 mm shipped
/// ellipsoid, where a 1024-node net stands 0.07–0.1 mm off.
inline constexpr double kMaxFineOffsetShare = 0.02;

/// The distance (m) a fine surface may stand off its net before the load warns: the smaller of
/// `half_edge` (half the net's mean edge: within it the node spheres, radius edge / √3, reach the
/// fine surface) and kMaxFineOffsetShare times `organ_size` (m; a bound that does not grow as
/// the net coarsens).
double net_surface_offset_bound(double half_edge, double organ_size);

/// Load-time check of the deformable organs (nets on an anchored body, core::BodyModel::anchored)
/// against the bodies that move (the tool), at their starting poses: appends one warning per
/// organ and body, naming both, when a sphere of the body overlaps a node sphere of the organ's
/// rest shape or has its centre inside the organ's closed rest surface (winding number of
/// `triangles`, model.nets' order). Call after core::finalize_model(). Load time only.
/// The rest positions (m, world) of `net`'s nodes at its body's starting pose (Model::node_rest
/// placed by BodyModel::initial_pose), in the net's node order. Load time only.
std::vector<core::Vec3> net_rest_positions(const core::Model& m, const core::NetModel& net);

/// Winding number of the closed triangle surface `tris` (vertices `verts`) about `p`: ±1 inside,
/// 0 outside (Van Oosterom & Strackee 1983's solid angle of each triangle, summed over 4π).
double winding_number(const std::vector<core::Vec3>& verts, const NetTriangles& tris, const core::Vec3& p);

void warn_organs_inside_tools(const core::Model& model, const std::vector<NetTriangles>& triangles,
                              std::vector<std::string>& warnings);

}  // namespace numen::sim
