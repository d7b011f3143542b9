"""numen.load_scene, Scene, Model and numen.InputError (sim/python/scene_bindings.cpp)."""
import os
import warnings

import numpy as np
import pytest

import numen


def test_default_scene_loads(scene):
    assert os.path.isfile(numen.default_scene_path())
    assert scene.name
    assert scene.dt == scene.model.dt > 0
    assert scene.duration > 0
    model = scene.model
    assert model.num_bodies == len(model.body_names) == len(model.body_masses) > 0
    assert model.num_joints == len(model.joint_names)
    assert model.integrator in ("implicit-euler", "symplectic-euler", "trapezoidal", "tr-bdf2")
    assert model.gravity.shape == (3,)


def test_target_at_is_a_unit_pose(scene):
    position, orientation, jaw = scene.target_at(0.1)
    assert position.shape == (3,) and orientation.shape == (4,)
    assert np.isclose(np.linalg.norm(orientation), 1.0)
    assert np.isfinite(jaw)
    linear, angular = scene.target_twist_at(0.1)
    assert linear.shape == (3,) and angular.shape == (3,)


def test_target_at_a_time_that_is_not_finite_is_refused(scene):
    # Before, target_at(nan) gave the trajectory's first sample without a word.
    for t in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match=r"Scene.target_at: t must be a finite time in "
                                             r"seconds, got (nan|inf)"):
            scene.target_at(t)
        with pytest.raises(ValueError, match="Scene.target_twist_at: t must be a finite time"):
            scene.target_twist_at(t)


def test_bad_scene_raises_located_input_error(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "bad"\ndt = "fast"\n')
    with pytest.raises(numen.InputError) as info:
        numen.load_scene(str(path))
    e = info.value
    assert isinstance(e, ValueError)
    assert e.file == str(path)
    assert e.line == 2 and e.column >= 1
    assert e.key == "dt"
    assert str(e) == f"{path}:{e.line}:{e.column}: dt: {e.message}"


def test_missing_scene_raises_input_error(tmp_path):
    with pytest.raises(numen.InputError) as info:
        numen.load_scene(str(tmp_path / "none.toml"))
    assert info.value.file == str(tmp_path / "none.toml")


def test_coupling_override():
    path = os.path.join(os.path.dirname(numen.default_scene_path()), "lattice.toml")
    try:
        direct = numen.load_scene(path, coupling="direct")
    except numen.InputError as e:
        pytest.skip(str(e))  # a build without articulation cannot load the lattice scene
    assert direct.model.coupling == "direct"
    with pytest.raises(numen.InputError) as info:
        numen.load_scene(path, coupling="nonsense")
    assert info.value.key == "coupling"


def test_a_library_scene_needs_no_trajectory_and_run_scene_refuses_it():
    path = os.path.join(os.path.dirname(numen.default_scene_path()), "probe.toml")
    scene = numen.load_scene(path)
    assert not scene.has_trajectory and scene.has_device
    assert scene.warnings == []
    assert scene.model.body_names[scene.model.initial_held_body] == "probe"
    assert scene.model.obstacle_names == ["box"]
    with pytest.raises(numen.InputError) as info:
        scene.target_at(0.0)
    assert info.value.key == "trajectory" and info.value.file == path
    assert "`numen run` needs a [trajectory]" in info.value.message
    with pytest.raises(numen.InputError) as run:
        numen.run_scene(scene)
    assert str(run.value) == str(info.value)


def test_a_scene_without_device_or_feedback_says_so(tmp_path):
    path = tmp_path / "ball.toml"
    path.write_text('[[material]]\nname = "m"\n[[body]]\nname = "ball"\nmass = 0.1\n'
                    'spheres = [[0.0, 0.0, 0.0, 0.01]]\n[body.coupling]\nstiffness = 100.0\n')
    advice = ("no feedback: non-haptic device (the scene has no [device]): feedback_wrench "
              "stays 0; a [device] table with kind = \"pose-tracker\" and attach = \"ball\", and "
              "under it a [device.feedback] table with stiffness (N/m) and damping (N·s/m), give "
              "it (as sim/scenes/probe.toml)")
    with pytest.warns(numen.SceneWarning) as record:  # not only in a list: a Python warning
        scene = numen.load_scene(str(path))
    assert [str(w.message) for w in record] == [f"{path}: {advice}"]
    assert record[0].filename == __file__
    assert not scene.has_device and not scene.has_trajectory
    assert scene.warnings == [advice]
    data = scene.make_data()
    assert data.held_body == 0
    data.set_target([0.0, 0.0, 0.01], xyzw=[0, 0, 0, 1])
    data.step(scene)
    assert data.coupling_wrench[2] > 0 and np.all(data.feedback_wrench == 0)
    # The advice, followed, loads without a warning and gives feedback.
    fed = tmp_path / "fed.toml"
    fed.write_text(path.read_text() + '[device]\nkind = "pose-tracker"\nattach = "ball"\n'
                   '[device.feedback]\nstiffness = 100.0\ndamping = 1.0\n')
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene = numen.load_scene(str(fed))
    assert scene.warnings == []
    data = scene.make_data()
    data.set_target([0.0, 0.0, 0.01], xyzw=[0, 0, 0, 1])
    data.step(scene)
    assert np.linalg.norm(data.feedback_wrench[:3]) > 0


def test_devices_lists_each_device_with_what_it_drives():
    if not numen.features["articulation"]:
        pytest.skip("the peg transfer's instruments have joints")
    from conftest import load_or_skip
    peg = load_or_skip("peg_transfer.toml")
    devices = peg.devices
    assert [d["name"] for d in devices] == ["left", "right"]
    assert devices[1]["kind"] == "trocar instrument" and devices[1]["axes"] == 5
    assert devices[1]["node_ids"] == [6, 7, 8, 9, 10]
    assert devices[1]["bodies"] == ["sleeve_r", "tube_r", "jaw_1_r", "jaw_2_r"]
    assert devices[0]["graspers"] == ["left_grasper"]
