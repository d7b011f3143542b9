#!/usr/bin/python3
"""Plots of `numen study accuracy` (docs/accuracy.md).

usage: plot_accuracy.py DIR OUT_DIR
Reads DIR/accuracy.csv (schema in docs/accuracy.md) and writes
OUT_DIR/accuracy_work_precision.png (position and orientation error max against CPU time per
simulated second, one panel per case, one line per integrator) and
OUT_DIR/accuracy_convergence.png (position error max against the time step, with the
slopes 1 and 2 for reference). Diverged runs are drawn as crosses above the panel's largest
finite error (at their CPU time or step).
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "implicit-euler": dict(color="tab:blue", marker="o", label="linearly implicit Euler (order 1)"),
    "symplectic-euler": dict(color="tab:orange", marker="s", label="symplectic Euler (order 1)"),
    "trapezoidal": dict(color="tab:green", marker="^", label="trapezoidal (order 2)"),
    "tr-bdf2": dict(color="tab:red", marker="D", label="TR-BDF2 (order 2, L-stable)"),
}
CASES = ["free-body", "wall", "wall-smoothed", "articulated", "deformable"]
TITLES = {
    "free-body": "coupled body, free space\n(vs closed form)",
    "wall": "god-object pushed into a wall\n(vs reference)",
    "wall-smoothed": "same, smoothed C\u00b9 contact onset\n(vs reference)",
    "articulated": "articulated instrument, recording\n(vs reference)",
    "deformable": "deformable probe into the post\n(vs reference)",
}


def load(path):
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            for k in ("dt_s", "position_error_max_mm", "orientation_error_max_mrad", "cpu_s_per_sim_s"):
                r[k] = float(r[k])
            r["diverged"] = r["diverged"] == "1"
            rows.append(r)
    return rows


def panel_top(rows, case, y):
    vals = [r[y] for r in rows if r["case"] == case and not r["diverged"] and r[y] > 0
            and math.isfinite(r[y])]
    return 3 * max(vals or [1.0])


def series(rows, case, integ, x, y):
    ok = [(r[x], r[y]) for r in rows if r["case"] == case and r["integrator"] == integ
          and not r["diverged"] and r[y] > 0 and math.isfinite(r[y])]
    bad = [r[x] for r in rows if r["case"] == case and r["integrator"] == integ and r["diverged"]]
    return ok, bad


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = load(os.path.join(sys.argv[1], "accuracy.csv"))
    cases = [c for c in CASES if any(r["case"] == c for r in rows)]
    integs = [i for i in STYLE if any(r["integrator"] == i for r in rows)]

    fig, axes = plt.subplots(2, len(cases), figsize=(4.2 * len(cases), 7.5), squeeze=False)
    for j, case in enumerate(cases):
        for i, (y, ylabel) in enumerate((("position_error_max_mm", "position error max (mm)"),
                                         ("orientation_error_max_mrad", "orientation error max (mrad)"))):
            ax = axes[i][j]
            for integ in integs:
                ok, bad = series(rows, case, integ, "cpu_s_per_sim_s", y)
                st = STYLE[integ]
                if ok:
                    ok.sort()
                    ax.loglog([p[0] for p in ok], [p[1] for p in ok], color=st["color"],
                              marker=st["marker"], ms=4, label=st["label"])
                if bad:
                    ax.scatter(bad, [panel_top(rows, case, y)] * len(bad), color=st["color"], marker="x")
            ax.grid(True, which="both", alpha=0.3)
            if i == 0:
                ax.set_title(TITLES.get(case, case), fontsize=9)
            ax.set_xlabel("CPU s per simulated s")
            if j == 0:
                ax.set_ylabel(ylabel)
    axes[0][0].legend(fontsize=7)
    fig.suptitle("numen study accuracy: error against run time (x: diverged)", fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(sys.argv[2], "accuracy_work_precision.png"), dpi=110)

    fig, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 3.8), squeeze=False)
    for j, case in enumerate(cases):
        ax = axes[0][j]
        for integ in integs:
            ok, bad = series(rows, case, integ, "dt_s", "position_error_max_mm")
            st = STYLE[integ]
            if ok:
                ok.sort()
                ax.loglog([p[0] for p in ok], [p[1] for p in ok], color=st["color"],
                          marker=st["marker"], ms=4, label=st["label"])
            if bad:
                ax.scatter(bad, [panel_top(rows, case, "position_error_max_mm")] * len(bad),
                           color=st["color"], marker="x")
        # slope guides through the middle of the panel
        xs = [r["dt_s"] for r in rows if r["case"] == case]
        ys = [r["position_error_max_mm"] for r in rows if r["case"] == case and not r["diverged"]
              and r["position_error_max_mm"] > 0]
        if xs and ys:
            x0, x1 = min(xs), max(xs)
            ym = math.sqrt(min(ys) * max(ys))
            xm = math.sqrt(x0 * x1)
            for p, ls in ((1, ":"), (2, "--")):
                ax.loglog([x0, x1], [ym * (x0 / xm) ** p, ym * (x1 / xm) ** p], "k", ls=ls, lw=0.8,
                          label=f"slope {p}")
        ax.set_title(TITLES.get(case, case), fontsize=9)
        ax.set_xlabel("time step h (s)")
        if j == 0:
            ax.set_ylabel("position error max (mm)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(sys.argv[2], "accuracy_convergence.png"), dpi=110)
    print("wrote", os.path.join(sys.argv[2], "accuracy_work_precision.png"),
          os.path.join(sys.argv[2], "accuracy_convergence.png"))


if __name__ == "__main__":
    main()
