#!/usr/bin/env python3
"""The default scene with its organ given by a material (docs/tissue.md, "The shipped organ with a
material"): writes a copy of sim/scenes/default.toml beside it whose [[deformable]] "organ" takes
youngs_modulus_kpa, poisson_ratio, density, rayleigh_stiffness and support_length in place of its
per-spring constants, runs it and the default scene with `numen run --json`, and prints the figures
side by side. The copy is removed afterwards.

    python3 docs/figures/tissue_default_run.py [--numen build/numen] [--duration 10]
        [--youngs-modulus-kpa 120] [--poisson-ratio 0.45] [--density 1000]
        [--rayleigh-stiffness 0.001] [--support-length 0.02] [--nodes N]

--nodes N gives the material organ a net of N surface nodes simplified from the organ's mesh
(the `nodes` key; without it the mesh's own 1 002 vertices are the surface net).
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
SPRING_KEYS = ("mass", "stiffness", "damping", "bending_stiffness", "bending_damping",
               "tie_stiffness", "tie_damping")
FIGURES = ("step_time_median_us", "step_time_p99_us", "solver_iterations_mean",
           "feedback_force_max_n", "feedback_force_jump_max_n", "tool_penetration_max_mm",
           "net_penetration_max_mm", "net_tie_stretch_max_mm", "exit_status")


def material_scene(text, material, nodes=None):
    """default.toml's text with the organ's per-spring keys replaced by `material`'s (and its
    net's surface node count `nodes`, when given)."""
    start = text.index('[[deformable]]\nname = "organ"')
    end = text.index("\n[", start + 1)
    table = text[start:end]
    lines = [l for l in table.split("\n")
             if not any(re.match(r"\s*%s\s*=" % k, l) for k in SPRING_KEYS)]
    lines += ["%s = %r" % kv for kv in material.items()]
    if nodes is not None:
        lines.append("nodes = %d" % nodes)
    return text[:start] + "\n".join(lines) + "\n" + text[end:]


def run(numen, scene, duration):
    out = subprocess.run([numen, "run", scene, "--duration", str(duration), "--json"],
                         capture_output=True, text=True)
    if out.returncode not in (0,):
        sys.stderr.write(out.stderr)
    summary = json.loads(out.stdout)
    return summary


def figure(summary, key):
    for k in (key,):
        if k in summary:
            return summary[k]
    step = summary.get("step_time_us", {})
    return {"step_time_median_us": step.get("median"), "step_time_p99_us": step.get("p99")}.get(key)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--numen", default=os.path.join(ROOT, "build", "numen"))
    p.add_argument("--duration", type=float, default=10.0)
    p.add_argument("--youngs-modulus-kpa", type=float, default=120.0)
    p.add_argument("--poisson-ratio", type=float, default=0.45)
    p.add_argument("--density", type=float, default=1000.0)
    p.add_argument("--rayleigh-stiffness", type=float, default=0.001)
    p.add_argument("--support-length", type=float, default=0.02)
    p.add_argument("--nodes", type=int, default=None)
    a = p.parse_args()
    material = {"youngs_modulus_kpa": a.youngs_modulus_kpa, "poisson_ratio": a.poisson_ratio,
                "density": a.density, "rayleigh_stiffness": a.rayleigh_stiffness,
                "support_length": a.support_length}
    default = os.path.join(SCENES, "default.toml")
    with open(default) as f:
        text = material_scene(f.read(), material, a.nodes)
    fd, path = tempfile.mkstemp(prefix=".tissue-", suffix=".toml", dir=SCENES)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        spring = run(a.numen, default, a.duration)
        tissue = run(a.numen, path, a.duration)
    finally:
        os.unlink(path)
    label = ", ".join("%s %g" % kv for kv in material.items())
    if a.nodes is not None:
        label += ", nodes %d" % a.nodes
    print("| figure | per-spring organ (default.toml) | organ with material %s |" % label)
    print("| --- | --- | --- |")
    for key in FIGURES:
        fmt = lambda v: "%.3f" % v if isinstance(v, float) else str(v)
        print("| %s | %s | %s |" % (key, fmt(figure(spring, key)), fmt(figure(tissue, key))))
    return 0 if spring.get("exit_status") == 0 and tissue.get("exit_status") == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
