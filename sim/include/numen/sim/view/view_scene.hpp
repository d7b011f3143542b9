#pragma once
/// @file view_scene.hpp
/// The scene message of the state stream (docs/viewer.md, "Scene message"): the static world
/// of a run, sent once as JSON before the frames (state_frame.hpp) that animate it. Everything
/// a renderer needs to draw a frame: each body's spheres, the obstacles, the nets' triangles,
/// the joints, the device and the frame layout. Setup code (allocates).

#include <string>
#include <vector>

#include "numen/platform/state_frame.hpp"
#include "numen/sim/scene/scene.hpp"

namespace numen::sim {

/// Version of the scene message's schema (its "version" key); bumped with the frame version.
/// 4: the needles and the threads (layout threads and thread_nodes; issue 69).
inline constexpr int kViewSceneVersion = 4;

/// Most triangles of a mesh (obstacle or body) the scene message carries (about 5 MB of JSON); a
/// larger mesh is sent as its bounds ("aabb") and triangle count only.
inline constexpr int kViewMeshMaxTriangles = 200'000;

/// Most triangles of a net's fine surface (core::add_net_surface()) the scene message carries
/// with its embeddings (about 100 bytes of JSON per fine vertex: ~20 MB at this bound); a larger
/// one is sent as its point and triangle counts only, and the page draws the net's own
/// triangles.
inline constexpr int kViewNetSurfaceMaxTriangles = 400'000;

/// The frame layout of a run of `scene`: its bodies, net nodes, axes, graspers, other devices
/// (Scene::extra_devices) and their axes, suture threads and their nodes (segments + 1 each),
/// and room for every contact the model can report (core::kMaxContacts rigid + the nets' node
/// contacts).
platform::StateFrameLayout view_frame_layout(const Scene& scene);

/// The scene message as compact JSON (UTF-8): format, version, scene name and description,
/// dt (s), display rate (Hz; at most 1/dt: the stream sends one frame per period at most),
/// the frame layout, bodies (name, spheres [x, y, z, r] in the body frame, m; a body with a
/// mesh (core::BodyModel::mesh): "mesh", its position and orientation in the body frame and
/// its surface as an obstacle's mesh below, in the mesh's frame), obstacles
/// (name, type, position, orientation [x, y, z, w], and per type half_extents / radius /
/// half_length / spheres in the world frame; a mesh: triangle_count, and vertices (flat x y z,
/// m, in the obstacle's frame) and triangles (flat i j k, outward), or above
/// kViewMeshMaxTriangles its aabb [[min], [max]] only), nets (name, rigid body, node_begin,
/// node_count, node radius, triangles as local node indices; a net with a fine surface
/// (core::NetModel::surface_point_count > 0) also "surface": point_count, triangle_count and, up
/// to kViewNetSurfaceMaxTriangles, net_triangles (the net's Model::net_faces as flat local node
/// indices, corner order kept: it defines each triangle's frame), face (per fine vertex, the
/// index of its triangle in net_triangles), weights (flat, 3 per vertex, to 1e-6), offset (flat,
/// 3 per vertex, m, in the triangle's frame, to 1e-7) and triangles (flat i j k, indices of the
/// fine surface's vertices, outward): docs/viewer.md, "Scene message"), joints (name, type, parent, child
/// (−1: world), frame in the parent and in the child), the device (name, kind, protocol "managed" |
/// "minimal" | "admittance", axis names), the loop's other devices ("extra_devices", in the
/// frames' extra_device order: name, kind, protocol, axis names), the needles ("needles": name,
/// body index (its pose is the frames' body_pose), radius R (m), arc_angle φ (rad), wire_radius
/// (m), centre (the circle's centre in the body frame, m), tail_angle and tip_angle (rad about
/// the body's +z from its +x): the wire is the arc of radius R about centre from tail_angle to
/// tip_angle in the body's x–y plane), the suture threads ("threads", in the frames' thread
/// order: name, node_begin and node_count (segments + 1) in the frames' thread_node, radius (m),
/// needle (its Model::needles index, −1: none)) and the initially held body. Numbers are the
/// model's doubles, but for a fine surface's weights and offsets (rounded as said).
std::string view_scene_message(const Scene& scene, const platform::StateFrameLayout& layout,
                               double display_rate_hz);

/// What view_scene_message() leaves out of `scene`, one line each (empty when nothing): a mesh
/// (an obstacle's or a body's) of more than kViewMeshMaxTriangles triangles, sent as its bounds
/// (the page draws a box), and a net's fine surface of more than kViewNetSurfaceMaxTriangles,
/// sent as its counts (the page draws the net's own triangles). `numen run --view` and
/// `--record-view` print them on stderr, so that a view that draws less than the run simulates
/// says so.
std::vector<std::string> view_scene_warnings(const Scene& scene);

}  // namespace numen::sim
