#!/usr/bin/python3
"""Hand against tool against organ surface on the default scene (docs/organs.md, "Organs").

    ./build/numen run sim/scenes/default.toml --replay --trace organ.csv   (docs/figures/organ_runs.sh)
    /usr/bin/python3 docs/figures/plot_organ.py OUT.png [--json OUT.json] LABEL=organ.csv ...

For each trace (one panel each): the depth of the recorded hand's instrument tip and of the
god-object's tip below the organ's rest surface (the tube's frame is the traced frame, its tip
40 mm ahead along z, tool_offset of the scene), and how far the organ's surface was pushed from
its rest shape (the trace's net_tie_stretch_mm: the largest node displacement from its rest
position). The depth is signed (> 0 inside the rest surface: the winding number of its
triangles) and measured to the nearest rest vertex (exact to within half an edge, ≤ 2.4 mm).
The organ's mesh and pose are read from sim/scenes/default.toml. Needs numpy and matplotlib
(Debian's python3-numpy, python3-matplotlib).
"""
import csv
import json
import pathlib
import sys
import tomllib

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

ROOT = pathlib.Path(__file__).resolve().parents[2]
TIP = np.array([0.0, 0.0, 0.04])  # the tube's tip in its traced (COM) frame
EVERY = 10  # every 10th period (10 ms at 1 kHz)


def quat_rotate(q, v):
    """Rotates the rows of v by the unit quaternions q = [w, x, y, z] (rows)."""
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def organ_surface():
    scene = tomllib.loads((ROOT / "sim/scenes/default.toml").read_text())
    body = next(b for b in scene["body"] if b["name"] == "organ_core")
    net = next(d for d in scene["deformable"] if d["name"] == "organ")
    verts, tris = [], []
    for line in (ROOT / "sim/scenes" / net["file"]).read_text().splitlines():
        p = line.split()
        if p and p[0] == "v":
            verts.append([float(x) for x in p[1:4]])
        elif p and p[0] == "f":
            tris.append([int(x) - 1 for x in p[1:4]])
    v = np.array(verts)
    q = np.tile(np.array(body["orientation"], float), (len(v), 1))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return quat_rotate(q, v) + np.array(body["position"]), np.array(tris)


def depth_below(points, verts, tris):
    """Signed depth (m, > 0 inside) of each point below the closed surface."""
    out = np.empty(len(points))
    for i, p in enumerate(points):
        a, b, c = verts[tris[:, 0]] - p, verts[tris[:, 1]] - p, verts[tris[:, 2]] - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la \
            + np.einsum("ij,ij->i", c, a) * lb
        inside = abs(2.0 * np.arctan2(num, den).sum() / (4.0 * np.pi)) > 0.5
        nearest = np.linalg.norm(verts - p, axis=1).min()
        out[i] = nearest if inside else -nearest
    return out


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))[::EVERY]
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def tip(d, prefix):
    pos = np.stack([d[prefix + "_x"], d[prefix + "_y"], d[prefix + "_z"]], axis=1)
    q = np.stack([d[prefix + "_qw"], d[prefix + "_qx"], d[prefix + "_qy"], d[prefix + "_qz"]], axis=1)
    return pos + quat_rotate(q, np.tile(TIP, (len(pos), 1)))


def main():
    out = sys.argv[1]
    args = sys.argv[2:]
    json_out = None
    if args and args[0] == "--json":
        json_out, args = args[1], args[2:]
    runs = [a.split("=", 1) for a in args]
    verts, tris = organ_surface()
    fig, axes = plt.subplots(len(runs), 1, figsize=(9, 2.6 * len(runs)), squeeze=False)
    figures = {}
    for ax, (label, path) in zip(axes[:, 0], runs):
        d = load(path)
        t = d["time_s"]
        hand = 1e3 * depth_below(tip(d, "target"), verts, tris)
        tool = 1e3 * depth_below(tip(d, "tool"), verts, tris)
        surface = d["net_tie_stretch_mm"]
        force = np.sqrt(d["feedback_fx"] ** 2 + d["feedback_fy"] ** 2 + d["feedback_fz"] ** 2)
        figures[label] = {"hand_tip_depth_max_mm": float(hand.max()),
                          "tool_tip_depth_max_mm": float(tool.max()),
                          "organ_surface_displacement_max_mm": float(surface.max()),
                          "feedback_force_max_n": float(force.max()),
                          "duration_s": float(t[-1])}
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.plot(t, hand, lw=0.8, label="hand's tip below the organ's rest surface (mm)")
        ax.plot(t, tool, lw=0.8, label="tool's tip below the rest surface (mm)")
        ax.plot(t, surface, lw=0.8, label="organ surface pushed from rest, max (mm)")
        ax.plot(t, force, lw=0.6, color="0.4", label="feedback force (N)")
        ax.set_ylim(-5.0, max(25.0, hand.max() + 2.0))
        ax.set_title(label, fontsize=9)
        ax.set_ylabel("mm / N")
    axes[0, 0].legend(loc="upper right", fontsize=7)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle("Default scene: recorded hand vs god-object vs deformable organ (depths < 0: outside)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    if json_out:
        pathlib.Path(json_out).write_text(json.dumps(figures, indent=1) + "\n")
    print(json.dumps(figures, indent=1))


if __name__ == "__main__":
    main()
