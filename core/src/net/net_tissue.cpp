/// @file net_tissue.cpp
/// The contact of a tool's sphere with an organ given by its material (net/net_tissue.hpp;
/// net_tissue_contact.hpp's two-scale law, its load patch, the plane a sphere meets it through;
/// docs/tissue.md, "The contact"): what compute_net_forces() (net_forces.cpp) and the multirate
/// device loop's tissue planes (multirate/net_planes.cpp) take. Nets given per spring never call
/// it.

#include "net/net_tissue.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/net_tissue_contact.hpp"

#include "net/net_terms.hpp"
#include "scratch/data_scratch.hpp"
#include "scratch/net_scratch.hpp"

namespace numen::core::detail {
namespace {

/// The radius of the true sphere of contact `ct` (m): its body's sphere less the margin a
/// multirate scene loop grew it by (BodyModel::sphere_margin; 0 elsewhere).
double true_radius(const Model& model, const NodeContact& ct) noexcept {
  return model.body_spheres[static_cast<std::size_t>(ct.sphere_b)].radius -
         model.bodies[static_cast<std::size_t>(ct.body_b)].sphere_margin;
}

/// The contact law (net_tissue_contact.hpp) of `net` for a sphere of `radius` and the pair `mp`
/// (its stiffness already under the time-constant floor).
TissueContactLaw tissue_law(const NetModel& net, double radius, const MaterialPair& mp) noexcept {
  return make_tissue_contact_law(net.contact_modulus, net.contact_poisson_ratio,
                                 net.contact_stiffening, radius,
                                 net.load_patch_radius, mp.stiffness);
}

/// The elastic part of a tissue contact for a sphere of `radius` and the pair `mp` (as
/// tissue_law()): at the sphere's deepest contact (`law` given: the primary, `depth` seen
/// through the load patch) F(d) and its slope, and the backstop, the pair's penalty with a C¹
/// onset over r / 4 (kTissueBackstopOnset) on d_fine − 2 r once the touched fine surface is
/// `fine_depth` > 2 r deep (kTissueBackstopDepth), along `normal`.
struct TissueElastic {
  double force = 0.0;      ///< F(d) + the backstop (N).
  double stiffness = 0.0;  ///< Its slope (N/m).
  double patch = 0.0;      ///< F(d) alone: the part laid on the load patch (N).
};
TissueElastic tissue_elastic(const TissueContactLaw* law, double radius, double depth,
                             double fine_depth, const Vec3& normal, const MaterialPair& mp) noexcept {
  TissueContactForce e;
  if (law) e = tissue_contact_force(*law, depth);
  // The backstop, its onset smoothed over a quarter radius (contact_force.hpp's C¹ onset).
  MaterialPair onset = mp;
  onset.onset_depth = kTissueBackstopOnset * radius;
  const ContactForceResult b = contact_penalty_force(
      normal, fine_depth - kTissueBackstopDepth * radius, Vec3::Zero(), onset);
  return {e.force + b.normal_force, e.stiffness + (b.active ? b.stiffness : 0.0), e.force};
}

/// The load patch (net_tissue_contact.hpp) of `net` about the rest point `p` (body frame) into
/// NetScratch::patch_*: the surface nodes within ρ of p, weighted K(|r_j − p| / ρ) A_j and
/// normalised (no node: patch_count 0). The last patch is kept (NetScratch::patch_at).
void find_patch(const Model& model, NetScratch& s, const NetModel& net, const Vec3& p) noexcept {
  if (s.patch_net == net.node_begin && s.patch_at == p) return;
  const double rho = net.load_patch_radius, rho2 = rho * rho;
  const int count = static_cast<int>(net.surface_node_area.size());
  int kept = 0;
  double total = 0.0;
  for (int j = 0; j < count; ++j) {
    const int node = net.node_begin + j;
    const double d2 = (model.node_rest[static_cast<std::size_t>(node)] - p).squaredNorm();
    if (!(d2 < rho2)) continue;
    const double w = load_patch_kernel(std::sqrt(d2) / rho) * net.surface_node_area[static_cast<std::size_t>(j)];
    if (!(w > 0.0)) continue;
    s.patch_nodes[static_cast<std::size_t>(kept)] = node;
    s.patch_weights[static_cast<std::size_t>(kept)] = w;
    total += w;
    ++kept;
  }
  for (int k = 0; k < kept; ++k) s.patch_weights[static_cast<std::size_t>(k)] /= total;
  s.patch_count = kept;
  s.patch_net = net.node_begin;
  s.patch_at = p;
}

/// The plane of the primary tissue contact whose entries are data.node_contacts[first, last)
/// (NodeContact::primary; net_tissue_contact.hpp): the patch about its material point
/// p = Σ_e w_e r_e / Σ_e w_e (rest positions of the entries' nodes) into NetScratch::patch_*, and
/// the plane through the touched fine point q̄ = Σ_e w_e q_e / Σ_e w_e moved by the patch's mean
/// displacement ū instead of its own u = Σ_e w_e u_e / Σ_e w_e, normal to the patch's mean rest
/// normal (turned with the rigid component): its point, outward normal and the true sphere's
/// depth into it. w_e = blend_e share_e over the entries of the sphere's contacts with this net
/// about [first, last) (NodeContact::blend, kTissueTouchDepthScale's; the primary's entries have
/// kTissueTouchFloor more). The entries' position was made with a sphere of `position_radius`. False
/// (patch_count 0 where the primary's entries have no share) for a patch without a node or a
/// normal.
struct PatchPlane {
  Vec3 touched, outward;
  double depth;
};
bool patch_plane(const Model& model, const Data& data, NetScratch& s, const NetModel& net, int first,
                 int last, double position_radius, PatchPlane& out) noexcept {
  const BodyState& body = data.bodies[static_cast<std::size_t>(net.body)];
  const Mat3 rot = body.orientation.toRotationMatrix();
  const auto move = [&](int v) -> Vec3 {  // u_v = x_v − a_v
    const auto i = static_cast<std::size_t>(v);
    return data.nodes[i].position - (body.position + rot * model.node_rest[i]);
  };
  const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(first)];
  const BodyState& tool = data.bodies[static_cast<std::size_t>(ct.body_b)];
  const Sphere& sphere = model.body_spheres[static_cast<std::size_t>(ct.sphere_b)];
  const Vec3 centre = tool.position + tool.orientation * sphere.center;
  // The sphere's entries on this net about the primary's (written together by the collision
  // stage, net_surface.cpp).
  const int n = node_contact_count(data);
  const auto same_sphere = [&](int c) {
    const NodeContact& e = data.node_contacts[static_cast<std::size_t>(c)];
    return !e.held && e.body_b == ct.body_b && e.sphere_b == ct.sphere_b && e.node >= net.node_begin &&
           e.node < net.node_begin + net.node_count;
  };
  int lo = first, hi = last;
  while (lo > 0 && same_sphere(lo - 1)) --lo;
  while (hi < n && same_sphere(hi)) ++hi;
  Vec3 p = Vec3::Zero(), own = Vec3::Zero(), fine = Vec3::Zero();
  double weights = 0.0, shares = 0.0;
  for (int c = lo; c < hi; ++c) {
    const NodeContact& e = data.node_contacts[static_cast<std::size_t>(c)];
    const bool in_primary = c >= first && c < last;
    const double w = (e.blend + (in_primary ? kTissueTouchFloor : 0.0)) * e.share;
    if (in_primary) shares += e.share;
    if (!(w > 0.0)) continue;
    p += w * model.node_rest[static_cast<std::size_t>(e.node)];
    own += w * move(e.node);
    // The touched fine point (NodeContact::position is ½ (q + c − r o), o = −normal, r the
    // radius the contact was made with).
    fine += w * (2.0 * e.position - centre - position_radius * e.normal);
    weights += w;
  }
  // (weights ≥ kTissueTouchFloor · shares: positive with the primary's shares)
  if (!(shares > 0.0)) {  // no patch: the force stays on the entries' nodes (lay_on_patch())
    s.patch_count = 0;
    s.patch_net = -1;
    return false;
  }
  p /= weights;
  own /= weights;
  fine /= weights;
  find_patch(model, s, net, p);
  if (s.patch_count == 0) return false;
  Vec3 mean = Vec3::Zero(), normal = Vec3::Zero();
  for (int k = 0; k < s.patch_count; ++k) {
    const int v = s.patch_nodes[static_cast<std::size_t>(k)];
    const double w = s.patch_weights[static_cast<std::size_t>(k)];
    mean += w * move(v);
    normal += w * net.surface_node_normal[static_cast<std::size_t>(v - net.node_begin)];
  }
  const double len = normal.norm();
  if (!(len > 0.0)) return false;
  out.outward = rot * (normal / len);
  const double radius = true_radius(model, ct);
  out.touched = fine + (mean - own);  // the touched point moved by ū − u
  out.depth = radius - (centre - out.touched).dot(out.outward);
  return true;
}

}  // namespace

// (net_tissue.hpp)
const NetModel* tissue_net(const Model& model, const NodeContact& ct) noexcept {
  if (ct.face < 0 || ct.body_b < 0 || ct.sphere_b < 0) return nullptr;
  if (model.bodies[static_cast<std::size_t>(ct.body_b)].sharp) return nullptr;  // the pair's penalty
  const NetModel& net = model.nets[static_cast<std::size_t>(model.node_net[static_cast<std::size_t>(ct.node)])];
  return net.contact_modulus > 0.0 ? &net : nullptr;
}

// (net_tissue.hpp)
ContactForceResult tissue_node_contact_force(const Model& model, const NetModel& net,
                                             const NodeContact& ct, double fine_depth, const Vec3& v_rel, const MaterialPair& mp,
                                        double& elastic, double& patch) noexcept {
  const double radius = true_radius(model, ct);
  TissueContactLaw law;
  if (ct.primary) law = tissue_law(net, radius, mp);
  const TissueElastic e =
      tissue_elastic(ct.primary ? &law : nullptr, radius, ct.depth, fine_depth, ct.normal, mp);
  elastic = e.force;
  patch = e.patch;
  ContactForceResult r;
  r.stiffness = e.stiffness;
  r.damping = mp.stiffness > 0.0 ? mp.damping * r.stiffness / mp.stiffness : 0.0;
  r.friction = mp.friction;
  const double v_n = ct.normal.dot(v_rel);
  r.normal_force = std::max(0.0, elastic - r.damping * v_n);
  r.active = r.normal_force > 0.0;
  if (r.active) r.force = r.normal_force * ct.normal - mp.friction * (v_rel - v_n * ct.normal);
  return r;
}

// (net_tissue.hpp)
void see_through_patch(const Model& model, Data& data, NetScratch& s, const NetModel& net, int first,
                       int last) noexcept {
  const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(first)];
  s.patch_fine_depth = ct.depth;
  // The entries were cut back to the true sphere (a multirate scene loop's) or made with it.
  PatchPlane plane;
  if (!patch_plane(model, data, s, net, first, last, true_radius(model, ct), plane)) return;
  const Vec3 position = plane.touched + 0.5 * plane.depth * plane.outward;
  for (int c = first; c < last; ++c) {
    NodeContact& e = data.node_contacts[static_cast<std::size_t>(c)];
    e.depth = plane.depth;
    e.normal = -plane.outward;
    e.position = position;
  }
}

// (net_tissue.hpp)
double patch_inverse_mass(const Model& model, const NetScratch& s) noexcept {
  double inv = 0.0;
  for (int k = 0; k < s.patch_count; ++k) {
    const double w = s.patch_weights[static_cast<std::size_t>(k)];
    inv += w * w / model.node_mass[static_cast<std::size_t>(s.patch_nodes[static_cast<std::size_t>(k)])];
  }
  return inv;
}

// (net_tissue.hpp)
void lay_on_patch(NetScratch& s, int node, const Vec3& f) noexcept {
  if (s.patch_count == 0) {
    s.force[static_cast<std::size_t>(node)] += f;
    return;
  }
  for (int k = 0; k < s.patch_count; ++k)
    s.force[static_cast<std::size_t>(s.patch_nodes[static_cast<std::size_t>(k)])] +=
        s.patch_weights[static_cast<std::size_t>(k)] * f;
}



TissuePlane tissue_plane(const Model& model, Data& data, const NetModel& net, int first,
                         int last, double position_radius) noexcept {
  TissuePlane out;
  NetScratch& s = data.scratch->net;
  const NodeContact& ct = data.node_contacts[static_cast<std::size_t>(first)];
  const double radius = true_radius(model, ct);
  PatchPlane plane;
  if (!patch_plane(model, data, s, net, first, last, position_radius, plane)) return out;
  out.valid = true;
  out.point = plane.touched;
  out.normal = plane.outward;
  out.depth = plane.depth;
  out.fine_depth = ct.depth - (position_radius - radius);  // the true sphere's
  for (int k = 0; k < s.patch_count; ++k)
    out.velocity += s.patch_weights[static_cast<std::size_t>(k)] *
                    data.nodes[static_cast<std::size_t>(s.patch_nodes[static_cast<std::size_t>(k)])].velocity;
  // The pair's stiffness under the time-constant floor on the patch's mass (the tool imposed, as
  // in the scene loop), as compute_net_forces() takes it.
  MaterialPair mp = model.material_pairs[static_cast<std::size_t>(ct.material_pair)];
  if (mp.stiffness > 0.0 &&
      model.solver.node_contact_max_omega_dt < std::numeric_limits<double>::infinity()) {
    const double limit = contact_stiffness_limit(1.0 / patch_inverse_mass(model, s), model.dt,
                                                 model.solver.node_contact_max_omega_dt);
    mp.stiffness = std::min(mp.stiffness, limit);
  }
  const TissueContactLaw law = tissue_law(net, radius, mp);
  const TissueElastic e = tissue_elastic(&law, radius, out.depth, out.fine_depth, -out.normal, mp);
  out.force = e.force;
  out.stiffness = e.stiffness;
  out.patch_compliance = law.patch;
  const double d_ref = 0.01 * radius;
  out.secant_stiffness = tissue_contact_force(law, d_ref).force / d_ref;
  return out;
}

}  // namespace numen::core::detail
