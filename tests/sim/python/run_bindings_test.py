"""numen.run_scene and the studies (sim/python/run_bindings.cpp)."""
import json
import math
import os
import signal
import subprocess
import threading
import time

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


def test_run_scene_duration_has_the_command_line_range(scene):
    # Before, NaN and -1 ran the whole recording and 1e9 was taken; `numen run --duration`
    # refuses them (sim::check_seconds, (0, 1e7]).
    for bad, shown in ((math.nan, "nan"), (-1.0, "-1"), (0.0, "0"), (1e9, "1e+09"),
                       (math.inf, "inf")):
        with pytest.raises(ValueError) as info:
            numen.run_scene(scene, duration=bad)
        assert str(info.value) == ("run_scene: duration must be a finite number of seconds in "
                                   f"(0, 1e+07] (or None: the scene's), got {shown}")


def test_study_stability_grid_steps_is_bounded():
    with pytest.raises(ValueError, match=r"study_stability: grid_steps must be at most 1000000 "
                                         r"steps per grid run .* got 1000000000"):
        numen.study_stability(grid_steps=10**9)


def interrupt_after(seconds):
    """Sends this process SIGINT (Ctrl-C) after `seconds`, from a timer thread; Python's default
    handler raises KeyboardInterrupt in the main thread, where the tests run."""
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_ends_run_scene_with_keyboard_interrupt(scene):
    # 1000 s of simulated time: minutes of stepping. Before, the SIGINT waited for the run's end
    # (the KeyboardInterrupt came after it).
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    start = time.monotonic()
    timer = interrupt_after(0.3)
    with pytest.raises(KeyboardInterrupt):
        numen.run_scene(scene, duration=1000.0)
    elapsed = time.monotonic() - start
    timer.join()
    print(f"run_scene interrupted after {elapsed:.2f} s")
    assert elapsed < 5.0
    # Nothing is left behind: the next run is clean.
    assert numen.run_scene(scene, duration=0.1)["exit_status"] == 0


def test_ctrl_c_ends_study_stability_with_keyboard_interrupt():
    # The full coupling grid with 1e5 steps per run: an hour. The study stops after the run in
    # progress (a fraction of a second each).
    start = time.monotonic()
    timer = interrupt_after(0.3)
    with pytest.raises(KeyboardInterrupt):
        numen.study_stability(quick=False, families=["coupling"], grid_steps=100000)
    elapsed = time.monotonic() - start
    timer.join()
    print(f"study_stability interrupted after {elapsed:.2f} s")
    assert elapsed < 5.0
