/// @file net_surface_map.cpp
/// A fine surface mapped onto a net (net_surface_map.hpp; docs/fine-surface.md).

#include "numen/core/net_surface_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <vector>

#include "mesh/mesh_shape_query.hpp"
#include "net/net_surface_frame.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"

namespace numen::core {
namespace {

/// The fine triangles a patch (NetSurfaceCluster) holds, about: the contact search tests a
/// patch's bounds once and its triangles only where those meet a sphere.
constexpr int kClusterSize = 10;

/// The float nearest `x` at or below it, at or above it: a patch's bounds kept in floats hold
/// what the doubles they round hold.
float float_below(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float float_above(double x) {
  const auto f = static_cast<float>(x);
  return static_cast<double>(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

/// Model::net_face_surface_cluster and net_surface_clusters from net_face_surface_begin /
/// net_face_surface_faces (every net's): each net triangle f's riders are split into patches by
/// the net triangles their vertices ride on (f alone, or f and one or two neighbours) and by the
/// cell, in an n × n grid over the first two barycentric weights on f, of the mean weights of
/// their vertices on f, n = round(√(count / kClusterSize)) (at least 1; half that, at least 1,
/// for the riders on more than one net triangle, which lie in strips along f's edges), so that
/// a patch holds about kClusterSize riders on f alone and more in a strip; a patch gets one record
/// per net triangle its vertices ride on (the range of their first two weights there), the first
/// holding the number of records, the number of its riders and the largest offset of its
/// vertices. f's riders are then reordered so that each patch's are consecutive (patches in the
/// order of their first rider, a patch's riders in their order before), which lets the contact
/// search step over a patch no sphere reaches at once.
void build_surface_clusters(Model& model) {
  const std::vector<std::int32_t>& begin = model.net_face_surface_begin;
  std::vector<std::int32_t>& list = model.net_face_surface_faces;
  std::vector<std::int32_t> reordered, heads;  // f's riders in patch order; its patches' first records
  std::vector<std::int32_t> cluster(list.size(), -1);
  std::vector<NetSurfaceCluster> clusters;
  using Key = std::array<int, 4>;  // the riders' net triangles (ascending, −1 padded), the cell
  std::map<Key, std::size_t> group_of;
  std::vector<std::vector<std::size_t>> groups;  // per patch of this net triangle: its entries
  std::vector<Key> keys;
  for (std::size_t f = 0; f + 1 < begin.size(); ++f) {
    const auto first = static_cast<std::size_t>(begin[f]), last = static_cast<std::size_t>(begin[f + 1]);
    if (first == last) continue;
    const int n = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(last - first) / kClusterSize))));
    const int nb = std::max(1, n / 2);  // riders on two or three net triangles: a strip along an edge
    const auto cell_of = [](double w, int cells) { return std::clamp(static_cast<int>(w * cells), 0, cells - 1); };
    group_of.clear();
    groups.clear();
    keys.clear();
    for (std::size_t k = first; k < last; ++k) {
      const std::array<int, 3>& t = model.net_surface_faces[static_cast<std::size_t>(list[k])];
      Key key{-1, -1, -1, 0};
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      int on_f = 0, faces = 0;
      for (const int p : t) {
        const NetSurfacePoint& e = model.net_surface_points[static_cast<std::size_t>(p)];
        if (e.face == static_cast<int>(f)) mean += e.weights.head<2>(), ++on_f;
        bool seen = false;
        for (int q = 0; q < faces; ++q) seen = seen || key[static_cast<std::size_t>(q)] == e.face;
        if (seen) continue;
        int q = faces++;  // inserted in ascending order
        for (; q > 0 && key[static_cast<std::size_t>(q - 1)] > e.face; --q)
          key[static_cast<std::size_t>(q)] = key[static_cast<std::size_t>(q - 1)];
        key[static_cast<std::size_t>(q)] = e.face;
      }
      mean /= std::max(on_f, 1);
      const int cells = key[1] < 0 ? n : nb;
      key[3] = cell_of(mean.x(), cells) * cells + cell_of(mean.y(), cells);
      const auto [it, added] = group_of.try_emplace(key, groups.size());
      if (added) {
        groups.emplace_back();
        keys.push_back(key);
      }
      groups[it->second].push_back(k);
    }
    heads.clear();
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const auto head = static_cast<std::int32_t>(clusters.size());
      heads.push_back(head);
      const Key& key = keys[g];
      for (int part = 0; part < 3 && key[static_cast<std::size_t>(part)] >= 0; ++part) {
        NetSurfaceCluster rec;
        rec.face = key[static_cast<std::size_t>(part)];
        Eigen::Vector2d lo = Eigen::Vector2d::Constant(1.0), hi = Eigen::Vector2d::Constant(0.0);
        for (const std::size_t k : groups[g])
          for (const int p : model.net_surface_faces[static_cast<std::size_t>(list[k])]) {
            const NetSurfacePoint& e = model.net_surface_points[static_cast<std::size_t>(p)];
            if (e.face != rec.face) continue;
            lo = lo.cwiseMin(e.weights.head<2>());
            hi = hi.cwiseMax(e.weights.head<2>());
          }
        for (int a = 0; a < 2; ++a) {
          rec.weights_lo[static_cast<std::size_t>(a)] = float_below(lo[a]);
          rec.weights_hi[static_cast<std::size_t>(a)] = float_above(hi[a]);
        }
        clusters.push_back(rec);
        ++clusters[static_cast<std::size_t>(head)].parts;
      }
      // The largest offset of the patch's vertices, on its first record.
      double offset = 0.0;
      for (const std::size_t k : groups[g])
        for (const int p : model.net_surface_faces[static_cast<std::size_t>(list[k])])
          offset = std::max(offset, model.net_surface_points[static_cast<std::size_t>(p)].offset.norm());
      clusters[static_cast<std::size_t>(head)].offset_max = float_above(offset);
      clusters[static_cast<std::size_t>(head)].riders = static_cast<int>(groups[g].size());
    }
    // The patches' riders made consecutive.
    reordered.clear();
    std::size_t k = first;
    for (std::size_t g = 0; g < groups.size(); ++g) {
      const std::int32_t head = heads[g];
      for (const std::size_t e : groups[g]) {
        reordered.push_back(list[e]);
        cluster[k++] = head;
      }
    }
    std::copy(reordered.begin(), reordered.end(), list.begin() + static_cast<std::ptrdiff_t>(first));
  }
  model.net_face_surface_cluster = std::move(cluster);
  model.net_surface_clusters = std::move(clusters);
}

}  // namespace

std::string add_net_surface(Model& model, int net_index, std::span<const Vec3> vertices,
                            std::span<const std::array<int, 3>> triangles,
                            std::span<const int> nearest_face) {
  if (net_index < 0 || net_index >= model.num_nets())
    return "fine surface: net index " + std::to_string(net_index) + " is not a net of the model";
  NetModel& net = model.nets[static_cast<std::size_t>(net_index)];
  const std::string where = "net '" + net.name + "': fine surface: ";
  if (net.surface_point_count > 0) return where + "the net has one already";
  if (net.face_count == 0) return where + "the net has no triangles to carry it";
  const auto nv = static_cast<int>(vertices.size());
  if (nv < 3 || triangles.empty()) return where + "needs at least 3 vertices and one triangle";
  if (nearest_face.size() != vertices.size())
    return where + std::to_string(nearest_face.size()) + " nearest triangles for " +
           std::to_string(nv) + " vertices";

  // Embeddings: the foot point on the given net triangle at the rest shape.
  std::vector<NetSurfacePoint> points(vertices.size());
  for (int i = 0; i < nv; ++i) {
    const Vec3& p = vertices[static_cast<std::size_t>(i)];
    if (!p.allFinite()) return where + "vertex " + std::to_string(i) + " is not finite";
    const int f = nearest_face[static_cast<std::size_t>(i)];
    if (f < 0 || f >= net.face_count)
      return where + "vertex " + std::to_string(i) + ": net triangle " + std::to_string(f) +
             " out of range [0, " + std::to_string(net.face_count) + ")";
    const int g = net.face_begin + f;
    const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(g)];
    const Vec3& a = model.node_rest[static_cast<std::size_t>(t[0])];
    const Vec3& b = model.node_rest[static_cast<std::size_t>(t[1])];
    const Vec3& c = model.node_rest[static_cast<std::size_t>(t[2])];
    Mat3 frame;
    if (!detail::net_surface_frame(a, b, c, frame))
      return where + "vertex " + std::to_string(i) + ": net triangle " + std::to_string(f) +
             " is degenerate";
    int feature = 0;
    Vec3 w;
    detail::closest_on_triangle(p, a, b, c, feature, w);
    NetSurfacePoint& e = points[static_cast<std::size_t>(i)];
    e.face = g;
    e.weights = w.cwiseMax(0.0) / w.cwiseMax(0.0).sum();
    e.offset = frame.transpose() * (p - (e.weights.x() * a + e.weights.y() * b + e.weights.z() * c));
  }
  // Triangles: indices checked, wound outward (signed volume about the vertices' centre).
  Vec3 centre = Vec3::Zero();
  for (const Vec3& v : vertices) centre += v;
  centre /= nv;
  double volume = 0.0, longest_edge = 0.0;
  for (std::size_t k = 0; k < triangles.size(); ++k) {
    const std::array<int, 3>& t = triangles[k];
    for (int m = 0; m < 3; ++m)
      if (t[static_cast<std::size_t>(m)] < 0 || t[static_cast<std::size_t>(m)] >= nv)
        return where + "triangle " + std::to_string(k) + ": vertex index " +
               std::to_string(t[static_cast<std::size_t>(m)]) + " out of range [0, " +
               std::to_string(nv) + ")";
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
      return where + "triangle " + std::to_string(k) + " repeats a vertex";
    const Vec3 a = vertices[static_cast<std::size_t>(t[0])] - centre;
    const Vec3 b = vertices[static_cast<std::size_t>(t[1])] - centre;
    const Vec3 c = vertices[static_cast<std::size_t>(t[2])] - centre;
    volume += a.dot(b.cross(c));
    longest_edge = std::max({longest_edge, (b - a).norm(), (c - b).norm(), (a - c).norm()});
  }

  const int point_begin = static_cast<int>(model.net_surface_points.size());
  const int face_begin = static_cast<int>(model.net_surface_faces.size());
  net.surface_point_begin = point_begin;
  net.surface_point_count = nv;
  net.surface_face_begin = face_begin;
  net.surface_face_count = static_cast<int>(triangles.size());
  double offset = 0.0;
  for (const NetSurfacePoint& e : points) offset = std::max(offset, e.offset.norm());
  net.surface_reach = offset + longest_edge;
  model.net_surface_points.insert(model.net_surface_points.end(), points.begin(), points.end());
  for (const std::array<int, 3>& t : triangles)
    model.net_surface_faces.push_back(
        volume < 0.0 ? std::array<int, 3>{point_begin + t[0], point_begin + t[2], point_begin + t[1]}
                     : std::array<int, 3>{point_begin + t[0], point_begin + t[1], point_begin + t[2]});

  // Net triangle → the fine triangles with a vertex on it (counting sort over every net).
  const std::size_t num_faces = model.net_faces.size();
  std::vector<std::int32_t> begin(num_faces + 1, 0);
  const auto faces_of = [&](const std::array<int, 3>& t, std::array<int, 3>& out) {
    int n = 0;
    for (int m = 0; m < 3; ++m) {
      const int f = model.net_surface_points[static_cast<std::size_t>(t[static_cast<std::size_t>(m)])].face;
      if (std::find(out.begin(), out.begin() + n, f) == out.begin() + n) out[static_cast<std::size_t>(n++)] = f;
    }
    return n;
  };
  std::array<int, 3> fs{};
  for (const std::array<int, 3>& t : model.net_surface_faces) {
    const int n = faces_of(t, fs);
    for (int m = 0; m < n; ++m) ++begin[static_cast<std::size_t>(fs[static_cast<std::size_t>(m)]) + 1];
  }
  for (std::size_t f = 0; f < num_faces; ++f) begin[f + 1] += begin[f];
  std::vector<std::int32_t> list(static_cast<std::size_t>(begin[num_faces]));
  std::vector<std::int32_t> next(begin.begin(), begin.end() - 1);
  for (std::size_t k = 0; k < model.net_surface_faces.size(); ++k) {
    const int n = faces_of(model.net_surface_faces[k], fs);
    for (int m = 0; m < n; ++m)
      list[static_cast<std::size_t>(next[static_cast<std::size_t>(fs[static_cast<std::size_t>(m)])]++)] =
          static_cast<std::int32_t>(k);
  }
  model.net_face_surface_begin = std::move(begin);
  model.net_face_surface_faces = std::move(list);
  build_surface_clusters(model);
  return "";
}

Vec3 net_surface_position(const Model& model, std::span<const NodeState> nodes, int point) noexcept {
  const NetSurfacePoint& e = model.net_surface_points[static_cast<std::size_t>(point)];
  const std::array<int, 3>& t = model.net_faces[static_cast<std::size_t>(e.face)];
  const Vec3& a = nodes[static_cast<std::size_t>(t[0])].position;
  const Vec3& b = nodes[static_cast<std::size_t>(t[1])].position;
  const Vec3& c = nodes[static_cast<std::size_t>(t[2])].position;
  return detail::net_surface_point(e, a, b, c);
}

int net_surface_positions(const Model& model, const Data& data, int net, std::span<Vec3> out) noexcept {
  if (net < 0 || net >= model.num_nets()) return 0;
  const NetModel& nm = model.nets[static_cast<std::size_t>(net)];
  const int n = std::min(nm.surface_point_count, static_cast<int>(out.size()));
  const std::span<const NodeState> nodes(data.nodes.data(), data.nodes.size());
  for (int i = 0; i < n; ++i)
    out[static_cast<std::size_t>(i)] = net_surface_position(model, nodes, nm.surface_point_begin + i);
  return n;
}

double net_surface_max_offset(const Model& model, int net) noexcept {
  if (net < 0 || net >= model.num_nets()) return 0.0;
  const NetModel& nm = model.nets[static_cast<std::size_t>(net)];
  double d = 0.0;
  for (int i = nm.surface_point_begin; i < nm.surface_point_begin + nm.surface_point_count; ++i)
    d = std::max(d, model.net_surface_points[static_cast<std::size_t>(i)].offset.norm());
  return d;
}

}  // namespace numen::core
