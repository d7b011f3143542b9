#!/usr/bin/env python3
"""The default scene's organ given by its material against the per-spring organ it replaced
(docs/tissue.md, "The shipped organ keeps its feel" and "Cost"): runs sim/scenes/default.toml (its
organ given by its material) and a copy of it whose [[deformable]] "organ" takes the per-spring
constants the scene shipped before issue 67 (the mesh as its own 1 002-node net) in place of the
material, both with `numen run --json`, and prints the figures side by side. The copies are
written beside default.toml and removed afterwards.

    python3 docs/figures/tissue_default_run.py [--numen build/numen] [--duration 10]
        [--youngs-modulus-kpa E] [--poisson-ratio NU] [--density RHO]
        [--rayleigh-stiffness BETA] [--support-length L] [--strain-stiffening B] [--nodes N]

A material option, or --nodes, runs the material organ with that key changed (a copy of
default.toml); --nodes 0 takes the mesh's own 1 002 vertices as the net (no `nodes` key).
Exits 1 if either run's exit status is not 0.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = os.path.join(ROOT, "sim", "scenes")
MATERIAL_KEYS = ("youngs_modulus_kpa", "poisson_ratio", "density", "rayleigh_stiffness",
                 "support_length", "strain_stiffening", "load_patch_radius", "nodes")
# sim/scenes/default.toml's organ before issue 67 (docs/organs.md, "Organs"); the same as the stability
# grid's kShippedPerSpringOrgan (sim/include/numen/sim/study/study_stability_cases.hpp).
PER_SPRING = {"mass": 0.07, "stiffness": 200.0, "damping": 0.1, "bending_stiffness": 50.0,
              "bending_damping": 0.03, "tie_stiffness": 100.0, "tie_damping": 0.17}
FIGURES = ("step_time_median_us", "step_time_p99_us", "solver_iterations_mean",
           "feedback_force_max_n", "feedback_force_jump_max_n", "tool_penetration_max_mm",
           "net_penetration_max_mm", "net_tie_stretch_max_mm", "exit_status")


def organ_scene(text, drop, add):
    """default.toml's text with the organ's keys in `drop` removed and those of `add` appended."""
    start = text.index('[[deformable]]\nname = "organ"')
    end = text.index("\n[", start + 1)
    lines = [l for l in text[start:end].split("\n")
             if not any(re.match(r"\s*%s\s*=" % k, l) for k in drop)]
    lines += ["%s = %r" % kv for kv in add.items()]
    return text[:start] + "\n".join(lines) + "\n" + text[end:]


def run(numen, scene, duration):
    out = subprocess.run([numen, "run", scene, "--duration", str(duration), "--json"],
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.stderr.write(out.stderr)
    try:
        return json.loads(out.stdout)
    except json.JSONDecodeError:
        sys.stderr.write("%s: no JSON summary (exit status %d)\n" % (scene, out.returncode))
        return {"exit_status": out.returncode}


def figure(summary, key):
    if key in summary:
        return summary[key]
    step = summary.get("step_time_us", {})
    return {"step_time_median_us": step.get("median"), "step_time_p99_us": step.get("p99")}.get(key)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--numen", default=os.path.join(ROOT, "build", "numen"))
    p.add_argument("--duration", type=float, default=10.0)
    for key in MATERIAL_KEYS:
        p.add_argument("--" + key.replace("_", "-"), type=int if key == "nodes" else float, default=None)
    a = p.parse_args()
    changed = {k: getattr(a, k) for k in MATERIAL_KEYS if getattr(a, k) is not None}
    default = os.path.join(SCENES, "default.toml")
    with open(default) as f:
        text = f.read()
    scenes = {"spring": organ_scene(text, MATERIAL_KEYS, PER_SPRING)}
    if changed:
        add = {k: v for k, v in changed.items() if not (k == "nodes" and v == 0)}
        scenes["tissue"] = organ_scene(text, changed.keys(), add)
    paths = {}
    try:
        for name, body in scenes.items():
            fd, paths[name] = tempfile.mkstemp(prefix=".tissue-", suffix=".toml", dir=SCENES)
            with os.fdopen(fd, "w") as f:
                f.write(body)
        spring = run(a.numen, paths["spring"], a.duration)
        tissue = run(a.numen, paths.get("tissue", default), a.duration)
    finally:
        for path in paths.values():
            os.unlink(path)
    label = "default.toml" + ("".join(", %s %g" % kv for kv in changed.items()) if changed else "")
    print("| figure | per-spring organ | organ with its material (%s) |" % label)
    print("| --- | --- | --- |")
    for key in FIGURES:
        fmt = lambda v: "%.3f" % v if isinstance(v, float) else str(v)
        print("| %s | %s | %s |" % (key, fmt(figure(spring, key)), fmt(figure(tissue, key))))
    return 0 if spring.get("exit_status") == 0 and tissue.get("exit_status") == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
