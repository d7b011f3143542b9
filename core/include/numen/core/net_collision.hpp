#pragma once
/// @file net_collision.hpp
/// Collision stage of the deformable nets (paper §4.2: the net collides, one
/// sphere per node; §5 penalty contacts): every node sphere (centre
/// Data::nodes[i].position, radius Model::node_radius[i]) against the static
/// obstacles (primitive shapes, then the static sphere sets through
/// Model::static_grid) and against the spheres of the dynamic bodies, except
/// the net's own rigid component and the bodies of its articulation
/// (ArticulationTopology::body_tree). Nets do not collide with themselves or
/// with each other. An organ's net (its rigid component anchored, BodyModel::anchored) is part
/// of the static world and, like the obstacles among themselves, meets no obstacle: only the
/// dynamic bodies' spheres, and with its surface triangles (Model::net_faces) instead of its node
/// spheres when it has any (core/src/net/net_surface.cpp: one NodeContact per node of a triangle
/// contact, NodeContact::face). Coincident centres (narrowphase.hpp fallbacks): the
/// normal is the direction from the net's rigid component's COM to the node
/// (+z when those coincide too).

namespace numen::core {

struct Model;
struct Data;

/// Fills data.node_contacts[0, data.num_node_contacts) with the geometry of
/// every penetrating node sphere (force and linearisation zeroed); contact
/// order is a pure function of the model and the states (per net, per node,
/// obstacles in index order, then sphere sets, then bodies in index order).
/// Raises data.max_penetration to the deepest node contact and sets each
/// NetOutput::max_penetration. Overflow beyond kMaxNodeContacts keeps the
/// first ones, adds the rest to data.contacts_dropped, ORs
/// StepStatus::kContactOverflow into data.status and increments
/// data.contact_overflow_steps unless detect_contacts() already did in this
/// step. Call after detect_contacts(). Nothing to do without nets; with nets it
/// sets its bit of Data::stages_run (kStageNodeContacts, step_stages.hpp). No
/// allocation, no exception.
void detect_node_contacts(const Model& model, Data& data) noexcept;

}  // namespace numen::core
