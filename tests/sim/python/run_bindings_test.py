"""numen.run_scene and the studies (sim/python/run_bindings.cpp)."""
import json
import os
import subprocess

import pytest

import numen


def test_run_scene_default_is_clean_and_has_the_json_figures(scene):
    summary = numen.run_scene(scene, duration=1.0)
    assert summary["exit_status"] == 0, summary.get("exit_reasons")
    assert summary["steps"] == round(1.0 / scene.dt)
    assert summary["scene"] == scene.name
    # The dict is `numen run --json`'s object: the same keys, whatever they are.
    cli = os.environ.get("NUMEN_CLI")
    if cli:
        out = subprocess.run([cli, "run", scene.file, "--json", "--duration", "1"], check=True,
                             capture_output=True, text=True).stdout
        assert summary.keys() == json.loads(out).keys()


def test_run_scene_bad_bus_is_a_value_error(scene):
    with pytest.raises(ValueError):
        numen.run_scene(scene, duration=0.01, bus="nonsense")


def test_study_stability_returns_rows():
    rows = numen.study_stability(quick=True, families=["coupling"], integrators=["implicit-euler"])
    assert rows
    assert {r["family"] for r in rows} == {"coupling"}
    assert {r["integrator"] for r in rows} == {"implicit-euler"}
    assert isinstance(rows[0]["stable"], bool) and rows[0]["steps"] > 0
    with pytest.raises(ValueError):
        numen.study_stability(families=["nonsense"])


def test_study_accuracy_returns_rows():
    rows = numen.study_accuracy(quick=True, cases=["free-body"])
    assert rows and {r["case"] for r in rows} == {"free-body"}
    assert all(r["position_error_max_mm"] >= 0 for r in rows)
