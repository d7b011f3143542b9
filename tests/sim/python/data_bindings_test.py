"""numen.Data: stepping from Python against the same loop in C++, and the NumPy views
(sim/python/data_bindings.cpp)."""
import os

import numpy as np
import pytest

import numen
from conftest import load_or_skip, scripted_step

STEPS = 400  # 0.4 s of the lattice scene: the tool reaches the organ (contacts)


def bits(a):
    """The bytes of an array (bitwise comparison: -0.0 differs from 0.0, NaN equals NaN)."""
    return np.ascontiguousarray(a).tobytes()


VIEWS = ["body_positions", "body_orientations", "body_linear_velocities",
         "body_angular_velocities", "node_positions", "feedback_wrench"]


def test_python_loop_is_bit_identical_to_cpp(scene):
    data = scene.make_data()
    for _ in range(STEPS):
        scripted_step(scene, data)
    ref = numen._testing.step_loop(scene, STEPS)
    before = numen._testing.step_loop(scene, STEPS - 1)
    assert data.time == ref["time"] and data.step_count == ref["step_count"] == STEPS
    assert data.num_contacts == ref["num_contacts"]
    for name in VIEWS:
        assert bits(getattr(data, name)) == bits(ref[name]), name
    # Not vacuous: one step earlier the state differs.
    assert bits(data.body_positions) != bits(before["body_positions"])


def test_module_step_function_and_model_argument(scene):
    a, b = scene.make_data(), scene.make_data()
    for _ in range(20):
        scripted_step(scene, a)
        position, orientation, _ = scene.target_at(b.time)
        linear, angular = scene.target_twist_at(b.time)
        b.set_target(position, orientation, linear, angular)
        numen.step(scene.model, b)
    assert bits(a.body_positions) == bits(b.body_positions)


def test_data_of_another_model_is_refused(scene):
    other = numen.load_scene(scene.file)
    data = other.make_data()
    with pytest.raises(ValueError):
        data.step(scene)
    with pytest.raises(ValueError):
        data.set_target([0, 0], [0, 0, 0, 1])


def test_views_are_live_read_only_and_not_copies(scene):
    data = scene.make_data()
    positions = data.body_positions
    orientations = data.body_orientations
    feedback = data.feedback_wrench
    nodes = data.node_positions
    b = scene.model.num_bodies
    assert positions.shape == (b, 3) and orientations.shape == (b, 4)
    assert nodes.shape == (scene.model.num_nodes, 3)
    assert feedback.shape == (6,)
    for view in (positions, orientations, feedback, data.body_linear_velocities):
        assert view.base is data  # a view of Data's memory, owned by the Data object
        assert not view.flags.writeable and not view.flags.owndata
        with pytest.raises(ValueError):
            view[0] = 1.0
    # Strided over core::BodyState (position, orientation, velocities): no copy was made.
    assert positions.strides[0] > 3 * 8 and positions.strides[1] == 8
    assert positions.strides[0] == orientations.strides[0]
    history = []
    for _ in range(STEPS):
        scripted_step(scene, data)
        # The same array objects show each step's values.
        assert bits(positions) == bits(data.body_positions)
        assert bits(orientations) == bits(data.body_orientations)
        assert bits(feedback) == bits(data.feedback_wrench)
        history.append(positions.copy())
    assert not np.array_equal(history[0], history[-1])
    assert np.allclose(np.linalg.norm(orientations, axis=1), 1.0)


def test_views_outlive_their_data_object(scene):
    data = scene.make_data()
    scripted_step(scene, data)
    positions = data.body_positions
    expected = positions.copy()
    del data  # the view keeps the Data alive
    assert np.array_equal(positions, expected)


def test_contact_views(scene):
    data = scene.make_data()
    for _ in range(STEPS):
        scripted_step(scene, data)
        if data.num_contacts > 0:
            break
    c = data.num_contacts
    assert c > 0, "the tool should touch an obstacle"
    points, normals = data.contact_points, data.contact_normals
    depths, forces, bodies = data.contact_depths, data.contact_forces, data.contact_bodies
    assert points.shape == normals.shape == forces.shape == (c, 3)
    assert depths.shape == (c,) and bodies.shape == (c, 2)
    assert points.base is data and depths.base is data and not depths.flags.writeable
    assert np.all(depths > 0)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert data.max_penetration == pytest.approx(depths.max())
    assert np.all(bodies[:, 0] >= 0) and np.all(bodies[:, 0] < scene.model.num_bodies)


def test_node_views_of_a_net_scene():
    net_scene = load_or_skip("deformable.toml")
    data = net_scene.make_data()
    nodes = data.node_positions
    n = net_scene.model.num_nodes
    assert n > 0 and nodes.shape == (n, 3) and nodes.base is data and not nodes.flags.writeable
    start = nodes.copy()
    for _ in range(50):
        scripted_step(net_scene, data)
    ref = numen._testing.step_loop(net_scene, 50)
    assert bits(nodes) == bits(ref["node_positions"])  # the same view, bit-identical to C++
    assert not np.array_equal(nodes, start)


def test_target_views_and_reset(scene):
    data = scene.make_data()
    data.set_target([0.1, 0.2, 0.3], [0.0, 0.0, 0.0, 1.0])
    assert np.array_equal(data.target_position, [0.1, 0.2, 0.3])
    assert np.array_equal(data.target_orientation, [0.0, 0.0, 0.0, 1.0])
    scripted_step(scene, data)
    assert data.time > 0 and data.status == 0 and data.nonfinite_steps == 0
    data.reset()
    assert data.time == 0 and data.step_count == 0
    data.set_target([np.nan, 0, 0], [0, 0, 0, 1])
    data.step(scene)
    assert data.status & numen.STATUS_INVALID_TARGET


# A probe pressed into a small organ (triangle contacts) and a net ball on a floor (node sphere
# contacts): tests/data/node_contacts.toml.
NODE_CONTACT_SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data",
                                  "node_contacts.toml")


def test_node_contact_views_carry_the_surface_triangle_fields():
    if not numen.features["deformable"]:
        pytest.skip("this build has NUMEN_WITH_DEFORMABLE=OFF: no nets")
    s = numen.load_scene(NODE_CONTACT_SCENE)
    m = s.model
    faces = m.net_faces
    assert faces.shape == (320 + 80, 3) and faces.dtype.kind == "i"  # icospheres of 2 and 1 subdivisions
    assert faces.min() >= 0 and faces.max() < m.num_nodes
    data = s.make_data()
    assert data.num_node_contacts == 0 and data.node_contact_faces.shape == (0,)
    for _ in range(600):
        scripted_step(s, data)
    k = data.num_node_contacts
    nodes, bodies, obstacles = data.node_contact_nodes, data.node_contact_bodies, data.node_contact_obstacles
    points, normals, forces = data.node_contact_points, data.node_contact_normals, data.node_contact_forces
    depths, active = data.node_contact_depths, data.node_contact_active
    face, weights, shares = data.node_contact_faces, data.node_contact_face_weights, data.node_contact_shares
    for v in (nodes, bodies, obstacles, depths, active, face, shares):
        assert v.shape == (k,) and v.base is data and not v.flags.writeable
    for v in (points, normals, forces, weights):
        assert v.shape == (k, 3) and v.base is data and not v.flags.writeable
    assert active.dtype == np.bool_ and face.dtype.kind == "i" and shares.dtype == np.float64
    assert face.strides == (shares.strides[0],) and face.strides[0] > 3 * 8  # strided, no copy
    assert np.all(depths > 0) and np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    probe = m.body_names.index("probe")
    tri = face >= 0
    # The probe on the organ: triangle contacts, one row per node of each triangle it touches.
    assert tri.sum() >= 3 and np.all(bodies[tri] == probe) and np.all(obstacles[tri] == -1)
    for i in np.flatnonzero(tri):
        corners = faces[face[i]]
        assert nodes[i] in corners
        assert np.all(weights[i] >= 0) and weights[i].sum() == pytest.approx(1.0, abs=1e-12)
        assert shares[i] == weights[i][list(corners).index(nodes[i])]
    # A triangle's force is split over its nodes by their shares: parallel, in proportion.
    for f in np.unique(face[tri]):
        rows = np.flatnonzero(face == f)
        assert len(rows) == 3
        per_share = forces[rows] / shares[rows, None]
        assert np.allclose(per_share, per_share[0], rtol=1e-9, atol=0)
    # The ball on the floor: node spheres' contacts with obstacle 0, no triangle, share 1.
    sphere = ~tri
    assert sphere.sum() >= 1
    assert np.all(bodies[sphere] == -1) and np.all(obstacles[sphere] == 0)
    assert np.all(shares[sphere] == 1.0) and np.all(weights[sphere] == 0.0)
    ball = m.net_faces[320:]
    assert np.all(np.isin(nodes[sphere], ball))


def test_nets_without_a_fine_surface_have_empty_surface_arrays():
    # No scene key maps a fine surface yet on this branch: the nets of node_contacts.toml have
    # none, so the fine-surface views are empty with their documented shapes and dtypes, and
    # every net's range is zero.
    if not numen.features["deformable"]:
        pytest.skip("this build has NUMEN_WITH_DEFORMABLE=OFF: no nets")
    m = numen.load_scene(NODE_CONTACT_SCENE).model
    assert m.net_surface_point_faces.shape == (0,) and m.net_surface_point_faces.dtype.kind == "i"
    assert m.net_surface_point_weights.shape == (0, 3) and m.net_surface_point_weights.dtype == np.float64
    assert m.net_surface_point_offsets.shape == (0, 3) and m.net_surface_point_offsets.dtype == np.float64
    assert m.net_surface_faces.shape == (0, 3) and m.net_surface_faces.dtype.kind == "i"
    ranges = m.net_surface_ranges
    assert ranges.shape == (m.num_nets, 4) and ranges.dtype.kind == "i"
    assert np.all(ranges == 0)
