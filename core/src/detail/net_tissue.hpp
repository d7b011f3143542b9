#pragma once
/// @file net_tissue.hpp
/// Private to numen::core (core/src/detail): the plane a tool's sphere meets an organ given by
/// its material through (net_tissue_contact.hpp's load patch), for the multirate device loop's
/// tissue planes (multirate/net_planes.cpp; docs/tissue.md, "Multirate"), and what tells a contact's
/// entries apart. No allocation.

#include "numen/core/data.hpp"
#include "numen/core/model.hpp"
#include "numen/core/types.hpp"

namespace numen::core::detail {

/// Whether node contacts `a` and `b` are entries of one contact (the sink writes a contact's
/// entries one after the other with the same sphere and point).
inline bool same_contact(const NodeContact& a, const NodeContact& b) noexcept {
  return a.primary == b.primary && a.body_b == b.body_b && a.sphere_b == b.sphere_b &&
         a.position == b.position;
}

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
