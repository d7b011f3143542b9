"""Fixtures of the Python module's tests: the module (from PYTHONPATH, the build tree) and the
shipped lattice scene (the default scene with a rigid organ: a few µs a step), loaded once."""
import os

import pytest

import numen


def load_or_skip(name):
    """The shipped scene sim/scenes/<name>, or the test is skipped when this build leaves out a
    part the scene needs (NUMEN_WITH_ARTICULATION / NUMEN_WITH_DEFORMABLE off: the loader's
    InputError names the option)."""
    path = os.path.join(os.path.dirname(numen.default_scene_path()), name)
    try:
        return numen.load_scene(path)
    except numen.InputError as e:
        if "this build has NUMEN_WITH_" in str(e):
            pytest.skip(str(e))
        raise


@pytest.fixture(scope="session")
def scene():
    """The lattice scene (sim/scenes/lattice.toml: the default scene's instrument, a rigid
    sphere-lattice organ; the default scene's net costs ~60x its step, and these tests need only
    a scene); in a build without articulation (its instrument has joints), the construction scene (rigid blocks on a floor, no joints), so that the lean builds of
    .ci/options-matrix still step, view and run a scene."""
    if not numen.features["articulation"]:
        return load_or_skip("construction.toml")
    return load_or_skip("lattice.toml")


def scripted_step(scene, data):
    """One step of the scripted loop of numen._testing.step_loop: every target from the scene
    trajectory's sample at data.time, through the device to the held body's centre-of-mass frame
    (Data.set_targets_at, as `numen run` sets them from the encoders; the sample itself is the
    tool tip, not the frame set_target takes), then core::step."""
    data.set_targets_at()
    data.step(scene)
