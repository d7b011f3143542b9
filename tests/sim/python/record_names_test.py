"""The Python dicts carry the names `numen figures --all` lists for their output (sim/python,
sim/run/record_lists.cpp): a study row's dict has its row's field list, in order; a run's dict the
run figures. The C++ outputs: tests/sim/run/record_names_test.cpp."""
import os
import re
import subprocess

import pytest

import numen


def listed_names():
    """`numen figures --all`'s "Names by output" table: {output: [names]}."""
    cli = os.environ.get("NUMEN_CLI")
    if not cli:
        pytest.skip("NUMEN_CLI is not set (ctest sets it)")
    out = subprocess.run([cli, "figures", "--all"], check=True, capture_output=True,
                         text=True).stdout
    table = out[out.index("## Names by output"):]
    lists = {}
    for line in table.splitlines()[4:]:
        if not line.startswith("| "):
            continue
        output, _, names = line[2:-2].split(" | ")
        lists[output] = re.findall(r"`([^`]*)`", names)
    return lists


def names_of(lists, part):
    found = [names for output, names in lists.items() if part in output]
    assert len(found) == 1, (part, list(lists))
    return found[0]


def leaf_names(d, prefix=""):
    out = set()
    for k, v in d.items():
        out |= leaf_names(v, prefix + k + ".") if isinstance(v, dict) else {prefix + k}
    return out


def test_study_rows_carry_the_listed_names_in_order():
    lists = listed_names()
    stability = numen.study_stability(quick=True, families=["coupling"],
                                      integrators=["implicit-euler"])
    assert list(stability[0].keys()) == names_of(lists, "stability study row")
    assert "stable" in stability[0] and "verdict" not in stability[0]
    accuracy = numen.study_accuracy(quick=True, cases=["free-body"])
    assert list(accuracy[0].keys()) == names_of(lists, "accuracy study row")


def test_run_summary_carries_run_figures_names(scene):
    figures = set(names_of(listed_names(), "run summary"))
    summary = leaf_names(numen.run_scene(scene, duration=0.05))
    assert summary <= figures, summary - figures
    # Figures a run leaves out are those of other kinds of run (admittance, multirate) and of
    # scenes with graspers, threads, needles, hands with a servo, a [task] or several devices; first_pass_through_s is there only when a
    # pair of bodies went through each other (docs/dynamics.md, "Crossing").
    missing = {n for n in figures - summary
               if not n.startswith(("admittance.", "multirate.", "grasp.", "thread.", "needle.", "servo.", "task.",
                                    "device_lines"))
               and n != "first_pass_through_s"}
    assert not missing, missing
