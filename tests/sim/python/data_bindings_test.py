"""numen.Data: stepping from Python against the same loop in C++, and the NumPy views
(sim/python/data_bindings.cpp)."""
import os
import warnings

import numpy as np
import pytest

import numen
from conftest import load_or_skip, scripted_step

STEPS = 400  # 0.4 s of the lattice scene
# 3.7 s of the lattice scene: driven as `numen run` drives it (Data.set_targets_at: the tube's
# centre of mass 40 mm behind the recorded tip), the tool first touches the organ at 3.672 s.
CONTACT_STEPS = 3700


def bits(a):
    """The bytes of an array (bitwise comparison: -0.0 differs from 0.0, NaN equals NaN)."""
    return np.ascontiguousarray(a).tobytes()


VIEWS = ["body_positions", "body_orientations", "body_linear_velocities",
         "body_angular_velocities", "node_positions", "feedback_wrench"]


def test_python_loop_is_bit_identical_to_cpp(scene):
    data = scene.make_data()
    for _ in range(CONTACT_STEPS):
        scripted_step(scene, data)
    ref = numen._testing.step_loop(scene, CONTACT_STEPS)
    before = numen._testing.step_loop(scene, CONTACT_STEPS - 1)
    assert data.time == ref["time"] and data.step_count == ref["step_count"] == CONTACT_STEPS
    assert data.num_contacts == ref["num_contacts"]
    for name in VIEWS:
        assert bits(getattr(data, name)) == bits(ref[name]), name
    # Not vacuous: one step earlier the state differs.
    assert bits(data.body_positions) != bits(before["body_positions"])


def test_module_step_function_and_model_argument(scene):
    a, b = scene.make_data(), scene.make_data()
    for _ in range(20):
        scripted_step(scene, a)
        b.set_targets_at()
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
    for _ in range(CONTACT_STEPS):
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
    data.set_target([0.1, 0.2, 0.3], xyzw=[0.0, 0.0, 0.0, 1.0])
    assert np.array_equal(data.target_position, [0.1, 0.2, 0.3])
    assert np.array_equal(data.target_orientation, [0.0, 0.0, 0.0, 1.0])
    scripted_step(scene, data)
    assert data.time > 0 and data.status == 0 and data.nonfinite_steps == 0
    data.reset()
    assert data.time == 0 and data.step_count == 0
    data.set_target([np.nan, 0, 0], xyzw=[0, 0, 0, 1])
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


# ---- targets that are hard to get wrong (issue 56) ----

def probe_scene():
    """The shipped library scene sim/scenes/probe.toml: a probe above a box, no trajectory."""
    return numen.load_scene(os.path.join(os.path.dirname(numen.default_scene_path()),
                                         "probe.toml"))


def turn_deg(q_xyzw):
    return np.degrees(2 * np.arccos(min(1.0, abs(q_xyzw[3]) / np.linalg.norm(q_xyzw))))


def test_an_ambiguous_positional_quaternion_is_refused_and_named_forms_agree():
    scene = probe_scene()
    data = scene.make_data()
    # [1, 0, 0, 0] meant as the identity in the scene files' order (w, x, y, z) would be a
    # 180° turn about x in the Python order (x, y, z, w): refused, with both readings.
    with pytest.raises(ValueError) as info:
        data.set_target([0, 0, 0.01], [1, 0, 0, 0])
    assert str(info.value) == (
        "orientation (1, 0, 0, 0) given without a name is ambiguous: read as (x, y, z, w), "
        "numen's Python order, it turns by 180.0°; read as (w, x, y, z), the scene files' "
        "order, by 0.0°. Pass it by name: xyzw=... or wxyz=... (docs/python.md \"Quaternions\")")
    # By name: the identity either way; xyzw=[1, 0, 0, 0] is the 180° turn, taken as given.
    data.set_target([0, 0, 0.01], wxyz=[1, 0, 0, 0])
    assert np.array_equal(data.target_orientation, [0, 0, 0, 1])
    data.set_target([0, 0, 0.01], xyzw=[0, 0, 0, 1])
    assert np.array_equal(data.target_orientation, [0, 0, 0, 1])
    data.set_target([0, 0, 0.01], xyzw=[1, 0, 0, 0])
    assert turn_deg(data.target_orientation) == 180.0
    q = [0.1, 0.2, 0.3, 0.927]  # (x, y, z, w): x well under 1/√2 of the norm, accepted as is
    with pytest.warns(numen.QuaternionOrderWarning):  # read as (x, y, z, w), with a warning
        data.set_target([0, 0, 0.01], q)
    assert np.array_equal(data.target_orientation, q)
    data.set_target([0, 0, 0.01], wxyz=[q[3], q[0], q[1], q[2]])
    assert np.array_equal(data.target_orientation, q)
    for bad in ({}, {"xyzw": [0, 0, 0, 1], "wxyz": [1, 0, 0, 0]}):
        with pytest.raises(ValueError, match="give the orientation once"):
            data.set_target([0, 0, 0.01], **bad)


def test_set_target_without_a_held_body_is_refused():
    scene = probe_scene()
    data = scene.make_data()
    data.held_body = -1
    with pytest.raises(ValueError, match="no body is held"):
        data.set_target([0, 0, 0.01], xyzw=[0, 0, 0, 1])


def test_attached_body_is_an_alias_of_held_body():
    scene = probe_scene()
    data = scene.make_data()
    probe = scene.model.body_names.index("probe")
    assert data.attached_body == data.held_body == scene.model.initial_held_body == probe
    assert scene.model.initial_attached_body == probe
    data.attached_body = -1
    assert data.held_body == -1
    data.held_body = probe
    assert data.attached_body == probe
    # Out of range: refused, the instrument stays held (core::set_held_body alone would let go).
    for bad in (99, scene.model.num_bodies, -2):
        for name in ("held_body", "attached_body"):
            with pytest.raises(ValueError, match=rf"{name} must be -1 \(none\) or a body index "
                                                 rf"in \[0, 1\) \(Model.body_names\), got {bad}"):
                setattr(data, name, bad)
            assert data.held_body == probe
    with pytest.raises(ValueError, match="no body named 'nope'"):
        data.held_body = "nope"
    with pytest.raises(TypeError, match="held_body must be a body index, a body name or -1"):
        data.held_body = 0.0
    data.held_body = -1
    data.held_body = "probe"  # by name, or any integer type
    assert data.held_body == probe
    data.held_body = np.int64(-1)
    assert data.held_body == -1


def test_step_of_something_else_is_a_type_error_saying_what_step_takes(scene):
    data = scene.make_data()
    with pytest.raises(TypeError) as info:
        data.step(5)
    assert str(info.value) == (
        "Data.step(scene_or_model): scene_or_model must be the numen.Scene (or its Scene.model) "
        "whose make_data() made the Data, got int 5")
    with pytest.raises(TypeError, match=r"numen.step\(model, data\): model must be the "
                                        r"numen.Scene .* got str 'scene'"):
        numen.step("scene", data)
    with pytest.raises(TypeError, match=r"numen.step\(model, data\): data must be a numen.Data "
                                        r"\(Scene.make_data\(\)\), got int"):
        numen.step(scene, 5)
    assert data.step_count == 0


def test_set_targets_at_a_time_that_is_not_finite_is_refused(scene):
    data = scene.make_data()
    data.set_targets_at(0.0)
    before = data.target_position.copy()
    for t in (np.nan, np.inf, -np.inf):
        with pytest.raises(ValueError, match="Data.set_targets_at: t must be a finite time in "
                                             "seconds, got"):
            data.set_targets_at(t)
    assert np.array_equal(data.target_position, before)


def test_a_quaternion_that_is_not_unit_is_refused():
    scene = probe_scene()
    data = scene.make_data()
    with pytest.raises(ValueError) as info:
        data.set_target([0, 0, 0.01], xyzw=[1, 0, 0, 1])
    assert str(info.value) == (
        "orientation xyzw=(1, 0, 0, 1) is not a unit quaternion (norm 1.41421): a rotation is one "
        "of norm 1 (within 0.001); divide it by its norm (docs/python.md \"Quaternions\")")
    for bad in ({"wxyz": [0, 0, 0, 0]}, {"wxyz": [90, 0, 0, 0]}, {"xyzw": [0, 0, 0, 0.99]}):
        with pytest.raises(ValueError, match="is not a unit quaternion"):
            data.set_target([0, 0, 0.01], **bad)
        with pytest.raises(ValueError, match="is not a unit quaternion"):
            data.set_tool_sample([0, 0, 0.01], **bad)
        with pytest.raises(ValueError, match="is not a unit quaternion"):
            data.set_body_target("probe", [0, 0, 0.01], **bad)
    # A hand-typed rounding passes as given; a non-finite one is the invalid-target path.
    data.set_target([0, 0, 0.01], xyzw=[0.7071, 0, 0, 0.7071])
    assert np.array_equal(data.target_orientation, [0.7071, 0, 0, 0.7071])
    data.set_target([0, 0, 0.01], xyzw=[np.nan, 0, 0, 1])
    data.step(scene)
    assert data.status & numen.STATUS_INVALID_TARGET


def test_a_positional_quaternion_warns_that_it_is_read_as_xyzw():
    scene = probe_scene()
    data = scene.make_data()
    # (w, x, y, z) of a 180° turn about z, passed without a name: read as (x, y, z, w) it is the
    # identity. No value tells the orders apart: every positional orientation warns.
    with pytest.warns(numen.QuaternionOrderWarning) as record:
        data.set_target([0, 0, 0.01], [0, 0, 0, 1])
    assert len(record) == 1 and record[0].filename == __file__
    assert str(record[0].message) == (
        "orientation (0, 0, 0, 1) given without a name is read as (x, y, z, w), numen's Python "
        "order (a turn of 0.0°; as (w, x, y, z), the scene files' order, it would turn by "
        "180.0°): pass it by name, xyzw=... or wxyz=... (docs/python.md \"Quaternions\")")
    assert issubclass(numen.QuaternionOrderWarning, UserWarning)
    assert np.array_equal(data.target_orientation, [0, 0, 0, 1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # by name: no warning
        data.set_target([0, 0, 0.01], xyzw=[0, 0, 0, 1])
        data.set_target([0, 0, 0.01], wxyz=[1, 0, 0, 0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", numen.QuaternionOrderWarning)  # the strict form
        with pytest.raises(numen.QuaternionOrderWarning):
            data.set_target([0, 0, 0.01], [0, 0, 0, 1])


def test_set_targets_at_gives_the_held_tube_its_centre_of_mass_target(scene):
    if not numen.features["articulation"]:
        pytest.skip("the lattice scene has joints")
    data = scene.make_data()
    tip, tip_q, jaw = scene.target_at(0.0)
    data.set_targets_at(0.0)
    assert scene.model.body_names[data.held_body] == "tube"
    # The tube's centre of mass is 40 mm behind the tip along the shaft; the recorded
    # orientation (with the surgeon's wrist) is 16.5° off the shaft through the trocar.
    offset = tip - data.target_position
    assert abs(np.linalg.norm(offset) - 0.040) < 1e-12
    q, r = data.target_orientation, tip_q
    assert abs(np.degrees(2 * np.arccos(min(1.0, abs(np.dot(q, r))))) - 16.5) < 0.05
    # The sleeve's own target and the jaw hinges (prescribed at ±jaw/2) are set too.
    assert data.body_targets_enabled[scene.model.body_names.index("sleeve")]
    hinges = [scene.model.joint_names.index(n) for n in ("jaw_1_hinge", "jaw_2_hinge")]
    assert np.allclose(data.joint_prescribed[hinges, 0], [0.5 * jaw, -0.5 * jaw], atol=1e-12)
    # A loop of it tracks the recording: the tube stays within the coupling's lag of its target.
    for _ in range(500):
        data.set_targets_at()
        data.step(scene)
    assert data.status == 0 and data.invalid_target_steps == 0
    tube = data.held_body
    assert np.linalg.norm(data.body_positions[tube] - data.target_position) < 0.005


def test_set_tool_sample_on_a_scene_without_offset_is_the_target_itself():
    scene = probe_scene()
    data = scene.make_data()
    data.set_tool_sample([0.01, 0.02, 0.03], wxyz=[1, 0, 0, 0], jaw=0.2)
    assert np.array_equal(data.target_position, [0.01, 0.02, 0.03])
    assert np.allclose(data.target_orientation, [0, 0, 0, 1], atol=1e-15)


def test_an_invalid_target_is_counted_and_the_feedback_held(scene):
    if not numen.features["articulation"]:
        pytest.skip("the lattice scene has joints")
    # The reproduction: the scripted loop (the trajectory's tip as the held tube's
    # target, whose 40 mm offset keeps a feedback of 1.6 N), the target NaN at step 300. Before
    # the hold the feedback dropped to 0 for that period and came back.
    data = scene.make_data()
    forces = []
    for k in range(400):
        position, orientation, _jaw = scene.target_at(data.time)
        linear, angular = scene.target_twist_at(data.time)
        data.set_target(position, xyzw=orientation, linear_velocity=linear,
                        angular_velocity=angular)
        if k == 300:
            data.set_target([np.nan, 0, 0], xyzw=[0, 0, 0, 1])
        data.step(scene)
        if k == 300:
            assert data.status == numen.STATUS_INVALID_TARGET
        forces.append(data.feedback_wrench[:3].copy())
    forces = np.array(forces)
    assert data.invalid_target_steps == 1 and data.nonfinite_steps == 0
    assert np.array_equal(forces[300], forces[299])  # held, not dropped to zero
    jumps = np.linalg.norm(np.diff(forces, axis=0), axis=1)  # jumps[k - 1]: into period k
    held = np.linalg.norm(forces[299])
    print(f"feedback at the gap {held:.4f} N, out of the gap {jumps[300]:.4f} N; largest change "
          f"per period {jumps.max():.4f} N (into period {jumps.argmax() + 1})")
    assert round(held, 4) == 1.6059
    assert jumps[299] == 0.0 and jumps[300] < 0.02 * held
    # The largest change of the run is the start's (the offset's spring taking up), not the gap.
    assert round(jumps.max(), 4) == 0.7095 and jumps.argmax() + 1 == 18
    data.reset()
    assert data.invalid_target_steps == 0


def test_body_targets_and_prescribed_joints_are_settable(scene):
    if not numen.features["articulation"]:
        pytest.skip("the lattice scene has joints")
    data = scene.make_data()
    sleeve = scene.model.body_names.index("sleeve")
    data.set_body_target("sleeve", data.body_positions[sleeve],
                         xyzw=data.body_orientations[sleeve])
    assert data.body_targets_enabled[sleeve]
    data.clear_body_target(sleeve)
    assert not data.body_targets_enabled[sleeve]
    data.set_joint_prescribed("jaw_1_hinge", 0.3, 0.5)
    j = scene.model.joint_names.index("jaw_1_hinge")
    assert np.array_equal(data.joint_prescribed[j], [0.3, 0.5])
    with pytest.raises(ValueError, match="is not prescribed"):
        data.set_joint_prescribed("pivot", 0.1)
    with pytest.raises(ValueError, match="no body named"):
        data.set_body_target("nope", [0, 0, 0], xyzw=[0, 0, 0, 1])


def test_contacts_name_their_obstacle():
    scene = probe_scene()
    data = scene.make_data()
    for _ in range(300):  # the probe's target 3 mm into the box's top face
        data.set_target([0, 0, 0.002], xyzw=[0, 0, 0, 1])
        data.step(scene)
    assert data.num_contacts == 1
    assert data.contact_bodies.tolist() == [[0, -1]]
    assert data.contact_obstacles.tolist() == [0]
    assert scene.model.obstacle_names[data.contact_obstacles[0]] == "box"
    assert data.contact_obstacles.base is not None  # a view, like the other contact views


def test_grasp_state_is_read_per_grasper(tmp_path):
    """A [[grasp]] on the lattice scene's jaws: Model.grasp_names and Data.grasp(i) mirror
    core::GraspState; closing the jaws on nothing grasps nothing (docs/grasping.md)."""
    if not numen.features["articulation"]:
        pytest.skip("the lattice scene's jaws are on hinges")
    shipped = os.path.join(os.path.dirname(numen.default_scene_path()), "lattice.toml")
    with open(shipped) as f:
        text = f.read()
    scenes = os.path.dirname(shipped)
    text = text.replace('"../data/', '"' + os.path.join(os.path.dirname(scenes), "data") + "/")
    text = text.replace('dcf = "devices/', 'dcf = "' + os.path.join(scenes, "devices") + "/")
    path = tmp_path / "grasp.toml"
    path.write_text(text + '\n[[grasp]]\nname = "grasper"\njaws = ["jaw_1", "jaw_2"]\n')
    scene = numen.load_scene(str(path))
    assert scene.model.grasp_names == ["grasper"]
    data = scene.make_data()
    for _ in range(50):  # the jaws 0.2 rad apart, the instrument held where it starts
        data.set_joint_prescribed("jaw_1_hinge", 0.1)
        data.set_joint_prescribed("jaw_2_hinge", -0.1)
        data.step(scene)
    g = data.grasp(0)
    assert g["opening"] == pytest.approx(0.2, abs=0.01)
    assert not g["holding"] and g["body"] == -1 and g["net"] == -1 and g["nodes"] == []
    assert g["thread"] == -1 and g["thread_nodes"] == []
    assert g["event"] == "none" and g["grasps"] == g["releases"] == g["slips"] == 0
    assert g["armed"]
    with pytest.raises(IndexError, match="no grasper 1"):
        data.grasp(1)


def test_the_tip_and_the_centre_of_mass_frames_are_one_call_apart(scene):
    if not numen.features["articulation"]:
        pytest.skip("the lattice scene has joints")
    data = scene.make_data()
    tip, tip_q, _jaw = scene.target_at(1.0)
    # The tube's centre-of-mass pose for the recorded tip: what set_tool_sample / set_targets_at
    # give Data.target, read without setting anything.
    position, orientation = data.tool_to_body(tip, xyzw=tip_q)
    assert np.linalg.norm(tip - position) == pytest.approx(0.040, abs=1e-12)
    data.set_tool_sample(tip, xyzw=tip_q)
    assert np.allclose(data.target_position, position, atol=1e-15)
    assert abs(abs(np.dot(data.target_orientation, orientation)) - 1) < 1e-12
    # The tip in the tube's frame: 40 mm ahead along its z (the shaft).
    offset, _q = data.tool_in_held_body(tip, xyzw=tip_q)
    assert np.allclose(offset, [0, 0, 0.040], atol=1e-12)
    # Given the tip where the centre of mass is meant, the feedback is the 40 mm spring's (and
    # the tube is pulled into contact); given its centre-of-mass pose, a fraction of it.
    tipped, right = scene.make_data(), scene.make_data()
    for _ in range(200):
        p, q, _ = scene.target_at(tipped.time)
        tipped.set_target(p, xyzw=q)
        tipped.step(scene)
        com, com_q = right.tool_to_body(p, xyzw=q)
        right.set_target(com, xyzw=com_q)
        right.step(scene)
    f_tip = np.linalg.norm(tipped.feedback_wrench[:3])
    f_right = np.linalg.norm(right.feedback_wrench[:3])
    print(f"feedback after 0.2 s: tip as the target {f_tip:.4f} N, "
          f"its centre-of-mass pose {f_right:.4f} N")
    assert right.num_contacts == 0
    assert f_tip > 10 * f_right
    data.held_body = -1
    with pytest.raises(ValueError, match="no body is held"):
        data.tool_to_body(tip, xyzw=tip_q)


def test_a_probe_scene_tells_its_shape_and_has_no_tool_offset():
    scene = probe_scene()
    data = scene.make_data()
    spheres = scene.model.body_spheres(0)
    assert spheres.shape == (1, 4) and np.array_equal(spheres, [[0, 0, 0, 0.005]])
    offset, q = data.tool_in_held_body([0, 0, 0.01], xyzw=[0, 0, 0, 1])
    assert np.array_equal(offset, [0, 0, 0]) and np.allclose(q, [0, 0, 0, 1])
    # The probe's lowest point: its centre of mass minus the sphere's radius.
    lowest = data.body_positions[0][2] + spheres[0, 2] - spheres[0, 3]
    assert lowest == pytest.approx(0.005)
    with pytest.raises(IndexError, match=r"body 1 out of range \[0, 1\)"):
        scene.model.body_spheres(1)


def test_the_feedback_ramp_takes_the_kick_out_of_a_first_target():
    scene = probe_scene()
    data = scene.make_data()
    ramp = numen.FeedbackRamp(scene)  # the scene's [device] soft_start: 0.1 s by default
    raw, ramped = [], []
    for k in range(600):
        x = 0.020 if k < 300 else 0.025  # 20 mm beside the probe; the hand 5 mm on in a dropout
        data.set_target([np.nan if 300 <= k < 400 else x, 0, 0.01], xyzw=[0, 0, 0, 1])
        data.step(scene)
        raw.append(np.linalg.norm(data.feedback_wrench[:3]))
        ramped.append(np.linalg.norm(ramp.apply(data)[:3]))
    raw, ramped = np.array(raw), np.array(ramped)
    print(f"step 0: {raw[0]:.4f} N raw, {ramped[0]:.4f} N ramped; after the dropout: a jump of "
          f"{raw[400] - raw[399]:.4f} N raw, {ramped[400] - ramped[399]:.4f} N ramped")
    assert raw[0] == pytest.approx(3.9136, abs=1e-4) and ramped[0] == pytest.approx(0.01 * raw[0])
    assert raw[400] - raw[399] == pytest.approx(0.9784, abs=1e-4)
    assert np.abs(np.diff(ramped)).max() < 0.04
    assert ramped[599] == pytest.approx(raw[599]) and ramp.ramp == 1.0
    off = numen.FeedbackRamp(scene, soft_start=0.0)
    assert np.array_equal(off.apply(data), data.feedback_wrench)
    with pytest.raises(ValueError, match="soft_start must be a finite number of seconds >= 0"):
        numen.FeedbackRamp(scene, soft_start=-1.0)
