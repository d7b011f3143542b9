#!/usr/bin/python3
"""Figures of docs/results.md from `numen run --trace` CSV files.

Regenerate everything (from the project root, after building):
    docs/figures/make_figures.sh
Needs Debian's python3-matplotlib (run with /usr/bin/python3).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def default_run(trace, out, what="default"):
    d = load(trace)
    t = d["time_s"]
    fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    # Closed loop (the trace's hand column is not all zero): the hand pulls the handle along
    # the recording, the handle is the device pose the god-object follows.
    closed = any(v != 0.0 for v in d.get("hand_penetration_mm", []))
    if closed:
        ax[0].plot(t, d["hand_penetration_mm"], lw=0.8, label="hand (recorded motion)")
        ax[0].plot(t, d["target_penetration_mm"], lw=0.8, label="handle (device pose, held back by the feedback)")
    else:
        ax[0].plot(t, d["target_penetration_mm"], lw=0.8, label="target (recorded hand, tool placed there)")
    ax[0].plot(t, d["tool_penetration_mm"], lw=0.8, label="god-object (the tool)")
    if any(v != 0.0 for v in d.get("net_tie_stretch_mm", [])):  # a deformable organ
        ax[0].plot(t, d["net_tie_stretch_mm"], lw=0.8, label="organ surface pushed from rest, max")
    ax[0].set_ylabel("penetration (mm)")
    ax[0].legend(loc="upper right")
    organ = "deformable organ" if what == "default" else "rigid sphere-lattice organ"
    ax[0].set_title("%s scene (%s): laparoscopic instrument on recorded suturing motion (JIGSAWS)"
                    % (what.capitalize(), organ))
    sep = [((d["tool_x"][i] - d["target_x"][i]) ** 2 + (d["tool_y"][i] - d["target_y"][i]) ** 2
            + (d["tool_z"][i] - d["target_z"][i]) ** 2) ** 0.5 * 1e3 for i in range(len(t))]
    f = [(d["feedback_fx"][i] ** 2 + d["feedback_fy"][i] ** 2 + d["feedback_fz"][i] ** 2) ** 0.5 for i in range(len(t))]
    ax[1].plot(t, sep, lw=0.8, label="|god-object − target| (mm)")
    ax[1].plot(t, f, lw=0.8, label="feedback force (N; saturation 8 N)")
    ax[1].set_xlabel("time (s)")
    ax[1].legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def construction(god, direct, out):
    g, dr = load(god), load(direct)
    fig, ax = plt.subplots(figsize=(9, 3.5))
    ax.plot(dr["time_s"], dr["tool_penetration_mm"], lw=0.8, label="direct coupling (pose imposed, Fig. 5)")
    ax.plot(g["time_s"], g["tool_penetration_mm"], lw=0.8, label="god-object (Fig. 6)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("held block penetration (mm)")
    ax.set_title("Construction game: held block carried through a tower, then pressed into the board")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    what = sys.argv[1]
    if what in ("default", "lattice"):
        default_run(sys.argv[2], sys.argv[3], what)
    elif what == "construction":
        construction(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        sys.exit("usage: plot_runs.py default|lattice TRACE OUT.png | construction GOD.csv DIRECT.csv OUT.png")
