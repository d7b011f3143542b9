#!/usr/bin/python3
"""Z-width of `numen study passivity` (docs/passivity.md).

usage: plot_passivity.py DIR OUT.png
Reads DIR/passivity_boundary.csv (schema in docs/passivity.md) and writes OUT.png: the measured
largest passive stiffness K_max (markers) against the rendered damping B, one panel per coupling
(direct wall; god-object with a 1e6 N/m obstacle) and rate (1 kHz, 10 kHz), for the device
b = 1 N s/m without friction: without quantisation at delays 0, 1, 2 periods, and with a
10 um encoder (no delay); the device with f_c = 0.05 N and the same encoder as well. Lines:
the analytic bounds (the delay bound, Colgate & Schenkel's condition with the delay, which is
their 2(b - |B|)/T for d = 0; Abbott & Okamura max(2b/T, 2 f_c/Delta) dashed). A configuration
with no passive K (K_max = 0) has no marker. Filled markers: the backward difference as v-hat
(the theory's); hollow markers: the 50 Hz filter (docs/passivity.md "Velocity estimators").
Stars and crosses at B = 0: the passivity controller without and with an energy limit of
1 uJ, at delays 0 (blue) and 1 (orange).
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in r:
            if k not in ("coupling", "velocity_estimator"):
                r[k] = float(r[k])
    return rows


def select(rows, coupling, period, kw, b, fc, delta, delay, estimator="difference", pc=False):
    out = []
    for r in rows:
        if r["coupling"] != coupling or r["period_s"] != period:
            continue
        if (r.get("passivity_controller", 0.0) != 0.0) != pc:
            continue
        if r.get("velocity_estimator", "difference") != estimator:
            continue
        if coupling == "god-object" and r["obstacle_stiffness"] != kw:
            continue
        if (r["device_damping"], r["coulomb"], r["resolution"], r["delay_periods"]) != (b, fc, delta, delay):
            continue
        out.append(r)
    return sorted(out, key=lambda r: r["damping"])


SERIES = [
    # (label, b, f_c, Delta, delay, colour, marker, analytic column)
    ("Δ = 0, d = 0", 1.0, 0.0, 0.0, 0, "tab:blue", "o", "delay_bound"),
    ("Δ = 0, d = 1", 1.0, 0.0, 0.0, 1, "tab:orange", "s", "delay_bound"),
    ("Δ = 0, d = 2", 1.0, 0.0, 0.0, 2, "tab:green", "^", "delay_bound"),
    ("Δ = 10 µm, d = 0", 1.0, 0.0, 1e-5, 0, "tab:red", "v", None),
    ("Δ = 10 µm, f_c = 0.05 N, d = 0", 1.0, 0.05, 1e-5, 0, "tab:purple", "D", "abbott_okamura_bound"),
]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = load(sys.argv[1] + "/passivity_boundary.csv")
    panels = [("wall", None), ("god-object", 1e6)]
    periods = [1e-3, 1e-4]
    fig, axes = plt.subplots(len(panels), len(periods), figsize=(11, 8.5), squeeze=False)
    for i, (coupling, kw) in enumerate(panels):
        for j, period in enumerate(periods):
            ax = axes[i][j]
            for label, b, fc, delta, delay, colour, marker, bound in SERIES:
                pts = select(rows, coupling, period, kw, b, fc, delta, delay)
                if not pts:
                    continue
                bs = [p["damping"] for p in pts]
                ks = [p["k_max"] if p["k_max"] > 0 else float("nan") for p in pts]
                ax.plot(bs, ks, marker=marker, linestyle="none", color=colour, label=label + " (measured)")
                if bound:
                    ax.plot(bs, [p[bound] if p[bound] > 0 else float("nan") for p in pts], color=colour,
                            linestyle="--" if bound == "abbott_okamura_bound" else "-", linewidth=1)
                filt = select(rows, coupling, period, kw, b, fc, delta, delay, estimator="filter")
                if filt:
                    ax.plot([p["damping"] for p in filt],
                            [p["k_max"] if p["k_max"] > 0 else float("nan") for p in filt],
                            marker=marker, linestyle="none", markerfacecolor="none", color=colour,
                            label=label + ", 50 Hz filter")
            for delay, colour in ((0, "tab:blue"), (1, "tab:orange")):
                for p in select(rows, coupling, period, kw, 1.0, 0.0, 0.0, delay, pc=True):
                    limited = math.isfinite(p["passivity_energy_limit_j"])
                    ax.plot([p["damping"]], [p["k_max"] if p["k_max"] > 0 else float("nan")],
                            marker="P" if limited else "*", markersize=9, linestyle="none",
                            color=colour, label="PC, d = %d%s" % (delay, ", E_max = 1 µJ" if limited else ""))
            ax.set_yscale("log")
            ax.set_xlabel("rendered damping B (N·s/m)")
            ax.set_ylabel("largest passive K (N/m)")
            name = "direct wall" if coupling == "wall" else "god-object, k_w = %g N/m" % kw
            ax.set_title("%s, %g kHz (b = 1 N·s/m)" % (name, 1e-3 / period))
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="lower left")
    fig.suptitle("Z-width: measured K_max (markers) and analytic bounds (lines: Colgate & Schenkel "
                 "with the delay; dashed: Abbott & Okamura)\n"
                 "a missing marker: no passive K (quantised damper without friction, B > 0)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)
    print("wrote", sys.argv[2])


if __name__ == "__main__":
    main()
