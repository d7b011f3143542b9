#include "numen/sim/view/view_scene.hpp"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "numen/core/capacity.hpp"
#include "numen/core/mesh_shape.hpp"
#include "numen/core/needle.hpp"
#include "numen/core/thread.hpp"

namespace numen::sim {
namespace {

using nlohmann::json;

json vec3(const core::Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }
json quat(const core::Quat& q) { return json::array({q.x(), q.y(), q.z(), q.w()}); }
json sphere(const core::Sphere& s) {
  return json::array({s.center.x(), s.center.y(), s.center.z(), s.radius});
}
json pose(const core::Pose& p) { return json{{"position", vec3(p.position)}, {"orientation", quat(p.orientation)}}; }

const char* shape_name(core::ShapeType t) {
  switch (t) {
    case core::ShapeType::kPlane: return "plane";
    case core::ShapeType::kBox: return "box";
    case core::ShapeType::kSphere: return "sphere";
    case core::ShapeType::kCapsule: return "capsule";
    case core::ShapeType::kSphereSet: return "sphere_set";
    case core::ShapeType::kMesh: return "mesh";
  }
  return "unknown";
}

// A mesh's surface into `j`, in the mesh's own frame: its triangle_count, then flat x y z per
// vertex (m) and i j k per triangle (outward winding); above kViewMeshMaxTriangles only its
// bounds (the message stays well under a recording's kViewRecordMaxBytes).
void mesh_surface(json& j, const core::MeshShape& mesh) {
  j["triangle_count"] = mesh.num_triangles();
  if (mesh.num_triangles() > kViewMeshMaxTriangles) {
    j["aabb"] = json::array({vec3(mesh.aabb_min), vec3(mesh.aabb_max)});
    return;
  }
  json vertices = json::array(), triangles = json::array();
  for (const core::Vec3& v : mesh.vertices) {
    vertices.push_back(v.x());
    vertices.push_back(v.y());
    vertices.push_back(v.z());
  }
  for (const std::array<int, 3>& t : mesh.triangles)
    for (int k : t) triangles.push_back(k);
  j["vertices"] = std::move(vertices);
  j["triangles"] = std::move(triangles);
}

json obstacle(const core::Model& m, const core::Obstacle& o) {
  json j{{"name", o.name},
         {"type", shape_name(o.type)},
         {"position", vec3(o.pose.position)},
         {"orientation", quat(o.pose.orientation)}};
  switch (o.type) {
    case core::ShapeType::kPlane: break;
    case core::ShapeType::kBox: j["half_extents"] = vec3(o.half_extents); break;
    case core::ShapeType::kSphere: j["radius"] = o.radius; break;
    case core::ShapeType::kCapsule:
      j["radius"] = o.radius;
      j["half_length"] = o.half_length;
      break;
    case core::ShapeType::kSphereSet: {
      json spheres = json::array();
      for (int i = o.sphere_begin; i < o.sphere_begin + o.sphere_count; ++i)
        spheres.push_back(sphere(m.static_spheres[static_cast<std::size_t>(i)]));
      j["spheres"] = std::move(spheres);
      break;
    }
    case core::ShapeType::kMesh:
      mesh_surface(j, m.meshes[static_cast<std::size_t>(o.mesh)]);
      break;
  }
  return j;
}

/// `x` rounded to `per_unit`ths (a power of ten): the double nearest k / per_unit, which the
/// JSON writer prints with at most log10(per_unit) decimals.
double rounded(double x, double per_unit) { return std::round(x * per_unit) / per_unit; }

// Net `net`'s fine surface (core::add_net_surface()) as the scene message's "surface" of the
// net (docs/viewer.md, "Scene message"): point_count, triangle_count, and, up to
// kViewNetSurfaceMaxTriangles, the net's own triangles in the model's corner order (the order
// that defines each triangle's frame) as net-local node indices, each fine vertex's net-local
// triangle, barycentric weights (to 1e-6) and offset in the triangle's frame (m, to 0.1 µm),
// and the fine triangles as fine-surface-local indices. Null without a fine surface.
json net_surface(const core::Model& m, const core::NetModel& net) {
  if (net.surface_point_count <= 0) return nullptr;
  json j{{"point_count", net.surface_point_count}, {"triangle_count", net.surface_face_count}};
  if (net.surface_face_count > kViewNetSurfaceMaxTriangles) return j;
  json net_triangles = json::array(), face = json::array(), weights = json::array(),
       offset = json::array(), triangles = json::array();
  for (int f = net.face_begin; f < net.face_begin + net.face_count; ++f)
    for (int k : m.net_faces[static_cast<std::size_t>(f)]) net_triangles.push_back(k - net.node_begin);
  for (int i = net.surface_point_begin; i < net.surface_point_begin + net.surface_point_count; ++i) {
    const core::NetSurfacePoint& e = m.net_surface_points[static_cast<std::size_t>(i)];
    face.push_back(e.face - net.face_begin);
    for (int k = 0; k < 3; ++k) weights.push_back(rounded(e.weights[k], 1e6));
    for (int k = 0; k < 3; ++k) offset.push_back(rounded(e.offset[k], 1e7));
  }
  for (int t = net.surface_face_begin; t < net.surface_face_begin + net.surface_face_count; ++t)
    for (int k : m.net_surface_faces[static_cast<std::size_t>(t)]) triangles.push_back(k - net.surface_point_begin);
  j["net_triangles"] = std::move(net_triangles);
  j["face"] = std::move(face);
  j["weights"] = std::move(weights);
  j["offset"] = std::move(offset);
  j["triangles"] = std::move(triangles);
  return j;
}

}  // namespace

platform::StateFrameLayout view_frame_layout(const Scene& scene) {
  const core::Model& m = scene.model;
  platform::StateFrameLayout layout;
  layout.num_bodies = static_cast<std::uint32_t>(m.num_bodies());
  layout.num_nodes = static_cast<std::uint32_t>(m.num_nodes());
  layout.num_axes = static_cast<std::uint32_t>(scene.device.axes.size());
  layout.max_contacts =
      static_cast<std::uint32_t>(core::kMaxContacts + (m.num_nets() > 0 ? core::kMaxNodeContacts : 0));
  layout.num_grasps = static_cast<std::uint32_t>(m.grasps.size());
  layout.num_extra_devices = static_cast<std::uint32_t>(scene.extra_devices.size());
  for (const SceneDevice& d : scene.extra_devices)
    layout.num_extra_axes += static_cast<std::uint32_t>(d.device.axes.size());
  // The threads' nodes, reserved from their segment counts: fixed for the run.
  layout.num_threads = static_cast<std::uint32_t>(m.threads.size());
  for (const core::ThreadModel& t : m.threads)
    layout.num_thread_nodes += static_cast<std::uint32_t>(std::max(t.segments, 0) + 1);
  return layout;
}

std::string view_scene_message(const Scene& scene, const platform::StateFrameLayout& layout,
                               double display_rate_hz) {
  const core::Model& m = scene.model;
  json bodies = json::array();
  for (const core::BodyModel& b : m.bodies) {
    json spheres = json::array();
    for (int i = b.sphere_begin; i < b.sphere_begin + b.sphere_count; ++i)
      spheres.push_back(sphere(m.body_spheres[static_cast<std::size_t>(i)]));
    json body{{"name", b.name}, {"spheres", std::move(spheres)}};
    if (b.mesh >= 0) {  // its mesh's pose in the body frame, and its surface in the mesh frame
      json mesh = pose(b.mesh_pose);
      mesh_surface(mesh, m.meshes[static_cast<std::size_t>(b.mesh)]);
      body["mesh"] = std::move(mesh);
    }
    bodies.push_back(std::move(body));
  }
  json obstacles = json::array();
  for (const core::Obstacle& o : m.obstacles) obstacles.push_back(obstacle(m, o));
  json nets = json::array();
  for (std::size_t n = 0; n < m.nets.size(); ++n) {
    const core::NetModel& net = m.nets[n];
    json triangles = json::array();
    if (n < scene.net_triangles.size())
      for (const auto& t : scene.net_triangles[n]) triangles.push_back(json::array({t[0], t[1], t[2]}));
    const double radius =
        net.node_count > 0 ? m.node_radius[static_cast<std::size_t>(net.node_begin)] : 0.0;
    json entry{{"name", net.name},
               {"body", net.body},
               {"node_begin", net.node_begin},
               {"node_count", net.node_count},
               {"node_radius", radius},
               {"triangles", std::move(triangles)}};
    if (json surface = net_surface(m, net); !surface.is_null()) entry["surface"] = std::move(surface);
    // An organ given by its material: the page draws the tools' dimples on it (tissue_dimple.js).
    if (net.contact_modulus > 0.0) entry["tissue"] = true;
    nets.push_back(std::move(entry));
  }
  json joints = json::array();
  for (const core::JointModel& j : m.joints)
    joints.push_back({{"name", j.name},
                      {"type", core::to_string(j.type)},
                      {"parent", j.parent},
                      {"child", j.child},
                      {"prescribed", j.prescribed},
                      {"frame_parent", pose(j.frame_parent)},
                      {"frame_child", pose(j.frame_child)}});
  json axes = json::array();
  for (const hal::AxisConfig& a : scene.device.axes) axes.push_back(a.name);
  // The loop's other devices, in the frames' extra_device order.
  json extra_devices = json::array();
  for (const SceneDevice& d : scene.extra_devices) {
    json names = json::array();
    for (const hal::AxisConfig& a : d.device.axes) names.push_back(a.name);
    extra_devices.push_back({{"name", d.device.name},
                             {"kind", hal::to_string(d.device.kind)},
                             {"protocol", d.device.canopen.managed ? "managed" : "minimal"},
                             {"axes", std::move(names)}});
  }
  json grasps = json::array();
  for (const core::GraspModel& g : m.grasps)
    grasps.push_back({{"name", g.name}, {"jaws", json::array({g.jaws[0], g.jaws[1]})}});
  // The needles: each one's body (its pose is the frames' body_pose) and its arc in that body's
  // frame, so that the page draws the wire as a tube instead of its spheres.
  json needles = json::array();
  for (const core::NeedleModel& n : m.needles)
    needles.push_back({{"name", n.name},
                       {"body", n.body},
                       {"radius", n.radius},
                       {"arc_angle", n.arc_angle},
                       {"wire_radius", n.wire_radius},
                       {"centre", vec3(n.centre)},
                       {"tail_angle", n.tail_angle},
                       {"tip_angle", n.tip_angle}});
  // The threads, in the frames' thread order: each one's nodes in thread_node.
  json threads = json::array();
  int thread_node = 0;
  for (const core::ThreadModel& t : m.threads) {
    const int count = std::max(t.segments, 0) + 1;
    threads.push_back({{"name", t.name},
                       {"node_begin", thread_node},
                       {"node_count", count},
                       {"radius", t.radius},
                       {"needle", t.needle}});
    thread_node += count;
  }
  const json message{
      {"format", "numen-view"},
      {"version", kViewSceneVersion},
      {"frame_version", platform::kStateFrameVersion},
      {"scene", scene.name},
      {"description", scene.description},
      {"dt", m.dt},
      // The stream sends at most one frame per period: a faster rate asked is the period's.
      {"display_rate_hz", std::min(display_rate_hz, 1.0 / m.dt)},
      {"layout",
       {{"bodies", layout.num_bodies},
        {"nodes", layout.num_nodes},
        {"axes", layout.num_axes},
        {"max_contacts", layout.max_contacts},
        {"grasps", layout.num_grasps},
        {"extra_devices", layout.num_extra_devices},
        {"extra_axes", layout.num_extra_axes},
        {"threads", layout.num_threads},
        {"thread_nodes", layout.num_thread_nodes}}},
      {"attached_body", m.initial_held_body},
      {"bodies", std::move(bodies)},
      {"obstacles", std::move(obstacles)},
      {"nets", std::move(nets)},
      {"joints", std::move(joints)},
      {"grasps", std::move(grasps)},
      {"needles", std::move(needles)},
      {"threads", std::move(threads)},
      {"device",
       {{"name", scene.device.name},
        {"kind", hal::to_string(scene.device.kind)},
        // What the frames' lifecycle, start-up and wrench fields mean (docs/viewer.md):
        // "managed" CANopen (NMT start-up, CiA 402), "minimal" (no start-up), "admittance"
        // (no start-up; the wrench is the measured one, no axis torque).
        {"protocol", scene.admittance ? "admittance" : scene.device.canopen.managed ? "managed" : "minimal"},
        {"axes", std::move(axes)}}},
      {"extra_devices", std::move(extra_devices)}};
  // Non-finite numbers (an infinite plane has none, but a user's scene might) become null.
  return message.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::vector<std::string> view_scene_warnings(const Scene& scene) {
  const core::Model& m = scene.model;
  std::vector<std::string> out;
  const auto mesh_line = [&](const std::string& what, const core::MeshShape& mesh) {
    if (mesh.num_triangles() > kViewMeshMaxTriangles)
      out.push_back(what + "'s mesh has " + std::to_string(mesh.num_triangles()) +
                    " triangles, more than the " + std::to_string(kViewMeshMaxTriangles) +
                    " the view sends: the view draws its bounding box");
  };
  for (const core::Obstacle& o : m.obstacles)
    if (o.type == core::ShapeType::kMesh && o.mesh >= 0 && o.mesh < static_cast<int>(m.meshes.size()))
      mesh_line("obstacle \"" + o.name + "\"", m.meshes[static_cast<std::size_t>(o.mesh)]);
  for (const core::BodyModel& b : m.bodies)
    if (b.mesh >= 0 && b.mesh < static_cast<int>(m.meshes.size()))
      mesh_line("body \"" + b.name + "\"", m.meshes[static_cast<std::size_t>(b.mesh)]);
  for (const core::NetModel& net : m.nets)
    if (net.surface_face_count > kViewNetSurfaceMaxTriangles)
      out.push_back("deformable \"" + net.name + "\"'s fine surface has " +
                    std::to_string(net.surface_face_count) + " triangles, more than the " +
                    std::to_string(kViewNetSurfaceMaxTriangles) +
                    " the view sends: the view draws its " + std::to_string(net.node_count) +
                    "-node net");
  return out;
}

}  // namespace numen::sim
