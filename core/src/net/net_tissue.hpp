#pragma once
/// @file net_tissue.hpp
/// Private to numen::core (core/src/net; defined in net_tissue.cpp): the contact of a tool's
/// sphere with an organ given by its material (net_tissue_contact.hpp's two-scale law on its load
/// patch; docs/tissue.md, "The contact") for compute_net_forces(), the plane the sphere meets it
/// through for the multirate device loop's tissue planes (multirate/net_planes.cpp; docs/tissue.md,
/// "Multirate"), and what tells a contact's entries apart. No allocation.

#include "numen/core/contact_force.hpp"
#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::core {
struct NetScratch;
}  // namespace numen::core

namespace numen::core::detail {

/// Whether node contacts `a` and `b` are entries of one contact (the sink writes a contact's
/// entries one after the other with the same sphere and point).
inline bool same_contact(const NodeContact& a, const NodeContact& b) noexcept {
  return a.primary == b.primary && a.body_b == b.body_b && a.sphere_b == b.sphere_b &&
         a.position == b.position;
}

/// The net of an organ given by its material whose surface node contact `ct` is (a tool's
/// sphere on its surface: the two-scale law of net_tissue_contact.hpp), else null — null also
/// for a sharp body's sphere (BodyModel::sharp: the pair's penalty).
const NetModel* tissue_net(const Model& model, const NodeContact& ct) noexcept;

/// The two-scale law (net_tissue_contact.hpp) of the tissue contact `ct` on `net`, with the
/// material pair `mp` (its stiffness already under the time-constant floor): tissue_elastic()
/// at its depth (NodeContact::primary: seen through the load patch) and the touched fine
/// surface's `fine_depth`; − c v_n with the pair's damping scaled by the law's stiffness over the
/// pair's (c = c_pair k(d) / k_pair: the pair's time constant), the pair's friction; never a
/// pull. `elastic` gets the elastic force, `patch` F(d), the part laid on the load patch (the
/// rest acts on the contact's own nodes).
ContactForceResult tissue_node_contact_force(const Model& model, const NetModel& net,
                                             const NodeContact& ct, double fine_depth, const Vec3& v_rel, const MaterialPair& mp,
                                        double& elastic, double& patch) noexcept;

/// The primary tissue contact whose entries are data.node_contacts[first, last) seen through
/// its load patch (patch_plane()): in every entry the depth, normal and point of the sphere's
/// penetration into the patch's plane. A patch without a node leaves the entries as detected.
/// Keeps the detected depth in NetScratch::patch_fine_depth.
void see_through_patch(const Model& model, Data& data, NetScratch& s, const NetModel& net, int first,
                       int last) noexcept;

/// Σ w_j² / m_j over the load patch find_patch() found last (1/kg): a force F laid on it moves its
/// weighted mean as a mass 1 / Σ w_j² / m_j would.
double patch_inverse_mass(const Model& model, const NetScratch& s) noexcept;

/// Lays the force `f` (N, world) of a tissue contact on the load patch find_patch() found last
/// (NetScratch::patch_*), or on `node` when it has no node.
void lay_on_patch(NetScratch& s, int node, const Vec3& f) noexcept;

/// A tissue contact seen through its load patch at the scene loop's sample.
struct TissuePlane {
  bool valid = false;           ///< A patch with nodes and a normal: the fields below are set.
  Vec3 point = Vec3::Zero();    ///< The touched fine point moved by ū − u (m, world).
  Vec3 normal = Vec3::UnitZ();  ///< The patch's mean rest normal, turned (outward, to the tool).
  Vec3 velocity = Vec3::Zero(); ///< The patch's mean velocity Σ w_j v_j (m/s, world).
  double depth = 0.0;           ///< The true sphere's depth into the plane (m).
  double fine_depth = 0.0;      ///< Its depth into the touched fine surface (m).
  double force = 0.0;           ///< The law's elastic force at `depth`, backstop included (N).
  double stiffness = 0.0;       ///< Its slope dF/dd there (N/m), backstop included.
  double patch_compliance = 0.0;  ///< c_ρ (m/N): what the net gives under the patch's load.
  double secant_stiffness = 0.0;  ///< F(d)/d of the law at 1 % of the sphere's radius (N/m).
};

/// The tissue plane of the sphere whose primary contact (NodeContact::primary) is
/// data.node_contacts[first, last) on `net` (an organ given by its material), as
/// compute_net_forces() sees it: the load patch about the contact's material point, the plane
/// through the touched fine point moved by the patch's mean displacement, the law (and its
/// backstop) at the true sphere's depth, the pair's stiffness under the time-constant floor on
/// the patch's mass. The entries' NodeContact::position and depth were made with a sphere of
/// `position_radius` (m): the grown sphere before detail::cut_back_node_contacts(), the true one
/// after. Writes NetScratch::patch_* (the patch; hence `data` not const).
TissuePlane tissue_plane(const Model& model, Data& data, const NetModel& net, int first,
                         int last, double position_radius) noexcept;

}  // namespace numen::core::detail
