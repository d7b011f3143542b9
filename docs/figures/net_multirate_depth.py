#!/usr/bin/python3
"""Deepest node contact of the deformable god-objects' nets at the device rate (docs/multirate.md,
"Deformable god-objects"): the deformable and endobag scenes through `numen run --json --replay`
on the shipped excerpt with `dt = 0.0001` (a 10 kHz device loop; `[bus] latency = 0.00001`,
`compute_phase = 0.00005`), single-rate and with `[multirate] scene_dt = 0.001` and `0.01`,
`margin = 0.002`. Prints one line per run. The scene copies are written to a temporary directory
with their data and DCF paths made absolute.

    /usr/bin/python3 docs/figures/net_multirate_depth.py ./build/numen [FLOOR]

With FLOOR, the copies set `[solver] node_contact_max_omega_dt = FLOOR` (the node contacts'
time-constant floor, docs/dynamics.md "Stiff contacts"; 100 when not given).
"""
import json
import os
import re
import subprocess
import sys
import tempfile

RUNS = [("deformable", None), ("deformable", 0.001), ("deformable", 0.01),
        ("endobag", None), ("endobag", 0.001), ("endobag", 0.01)]


def scene_copy(root, name, scene_dt, tmp, floor=None):
    scenes = os.path.join(root, "sim", "scenes")
    with open(os.path.join(scenes, name + ".toml")) as f:
        text = f.read()
    text = text.replace('"../data/', '"' + os.path.join(root, "sim", "data") + "/")
    text = text.replace('dcf = "devices/', 'dcf = "' + os.path.join(scenes, "devices") + "/")
    if "\ndt = 0.001\n" not in text:
        sys.exit("%s: no 'dt = 0.001' line to replace" % name)
    text = text.replace("\ndt = 0.001\n", "\ndt = 0.0001\n", 1)
    text, n = re.subn(r"\[bus\]\nlatency = [0-9.e-]+[^\n]*\n",
                      "[bus]\nlatency = 0.00001\ncompute_phase = 0.00005\n", text)
    if n != 1:
        sys.exit("%s: no [bus] latency line to replace" % name)
    if floor is not None:
        if "\n[solver]\n" not in text:
            sys.exit("%s: no [solver] table to set node_contact_max_omega_dt in" % name)
        text = text.replace("\n[solver]\n", "\n[solver]\nnode_contact_max_omega_dt = %r\n" % floor, 1)
    if scene_dt is not None:
        text += "\n[multirate]\nscene_dt = %r\nmargin = 0.002\n" % scene_dt
    path = os.path.join(tmp, "%s_%s.toml" % (name, scene_dt or "single"))
    with open(path, "w") as f:
        f.write(text)
    return path


def main():
    numen = sys.argv[1]
    floor = float(sys.argv[2]) if len(sys.argv) > 2 else None
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    with tempfile.TemporaryDirectory() as tmp:
        for name, scene_dt in RUNS:
            path = scene_copy(root, name, scene_dt, tmp, floor)
            out = subprocess.run([numen, "run", path, "--json", "--replay"], capture_output=True, text=True)
            if out.returncode != 0:
                sys.exit("%s failed (exit %d): %s" % (path, out.returncode, out.stderr[-2000:]))
            s = json.loads(out.stdout)
            print("%-10s %-22s deepest node contact %.4f mm, tie stretch %.3f mm, feedback max %.3f N" %
                  (name, "single-rate 10 kHz" if scene_dt is None else "scene %g s" % scene_dt,
                   s["net_penetration_max_mm"], s["net_tie_stretch_max_mm"], s["feedback_force_max_n"]),
                  flush=True)


if __name__ == "__main__":
    main()
