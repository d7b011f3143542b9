#pragma once
/// @file collision.hpp
/// Collision stage (paper §5, sphere-based collision for penalty contacts):
/// the sphere sets of the dynamic bodies against the static obstacles (plane,
/// box, sphere, capsule, sphere set, closed mesh: mesh_shape.hpp), against each other and
/// against the meshes of the other bodies (BodyModel::mesh).
///
/// Pipeline of detect_contacts():
///   1. world centres c_w = x + R c_b of every body sphere, tight world AABB per body;
///   2. per body (index order): primitive obstacles (index order) culled by the
///      body's AABB and bounding sphere against their AABB (plane: signed
///      distance of the centre of mass), then each sphere against the shape;
///      then the static sphere sets through the uniform grid
///      (Model::static_grid), one query per sphere;
///   3. body–body: sort-and-sweep on the world AABBs along x (insertion sort of
///      the scratch's sweep order, CollisionScratch::sweep_order in
///      core/src/scratch/collision_scratch.hpp), then sphere–sphere between the spheres
///      of the two bodies that meet the overlap of their AABBs. body_a is the
///      lower body index;
///   4. body meshes (bodies with BodyModel::mesh, index order): the mesh's world box
///      (its local box at the body's pose composed with BodyModel::mesh_pose), the bodies of
///      other articulations (index order) whose AABB meets it, then each of their spheres
///      near the box against the mesh (sphere centre into the mesh frame, the mesh's signed
///      distance, back to world: sphere_mesh()). body_a is the sphere's body, body_b the
///      mesh's, sphere_b −1, the normal out of the mesh.
/// The order of the contacts is a pure function of the model and the body
/// states (deterministic, independent of the scratch's history).
///
/// Crossing (body–body sphere pairs, e.g. two instruments' jaws): a fast pair can go from
/// apart to centres past each other within one step, where the overlap's own normal would push
/// it on through. Each body–body contact takes a reference normal from the relative motion of
/// its two centres over the step (the bodies' point velocities × Model::dt, back from where
/// they are): the normal at first touch, or at the step's start for a pair overlapping then.
/// When the centre offset c_a − c_b lies behind it ((c_a − c_b)·n < 0), the contact keeps n with
/// the depth r_a + r_b − (c_a − c_b)·n, larger than r_a + r_b: it is pushed back the way it came
/// (Data::crossed_contacts). Such a pair is remembered (in the scratch) and held back along the
/// same normal at the next call until its centres are back in front; one found apart with its
/// centres still behind counts in Data::pass_throughs. With the bodies at rest the contacts are
/// a pure function of the poses (below); moving, of the poses, the velocities and the pairs held
/// back at the last call. A pair that goes from apart to apart within one step (relative motion
/// over 2 (r_a + r_b) a step head-on) is not seen.
///
/// Coincident sphere centres (narrowphase.hpp fallbacks): against a static
/// sphere or a sphere-set sphere, the normal points from that centre to the
/// body's centre of mass; between two bodies, from b's centre of mass to a's;
/// +z when those coincide too.

namespace numen::core {

struct Model;
struct Data;

/// Builds the broad-phase structures of `model`: the AABB of every obstacle
/// (Obstacle::aabb_min/max; planes stay infinite, an empty sphere set gets an
/// inverted box) and the static sphere grid over the sphere-set obstacles.
/// Called by finalize_model() after validation; allocates.
void build_collision_structures(Model& model);

/// Fills data.contacts[0, data.num_contacts) with the geometry of every
/// penetrating sphere pair (Contact::force is zeroed; the force stage fills it).
/// Sets data.max_penetration (deepest contact found, dropped ones included;
/// 0 if none). Overflow beyond kMaxContacts keeps the first kMaxContacts,
/// counts the rest in data.contacts_dropped, ORs StepStatus::kContactOverflow
/// into data.status and increments data.contact_overflow_steps (once per call).
/// Sets data.crossed_contacts, counts data.crossed_contact_steps and data.pass_throughs
/// ("Crossing" above; one call per step: the pairs held back are the last call's).
/// Clears only the kContactOverflow bit of data.status on entry. Sets its bit
/// of data.stages_run (kStageContacts, step_stages.hpp). Requires
/// a Data made by make_data() for `model`. No allocation, no exception.
void detect_contacts(const Model& model, Data& data) noexcept;

}  // namespace numen::core
