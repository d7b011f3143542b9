#!/usr/bin/python3
"""Stability maps of `numen study stability` (docs/stability.md).

usage: plot_stability.py DIR OUT_DIR
Reads DIR/stability_coupling.csv, stability_contact.csv, stability_boundary.csv (schema in
docs/stability.md) and writes into OUT_DIR:
  stability_coupling_undamped.png, stability_coupling_damped.png: stiffness k against mass m,
      one panel per integrator (rows) and time step (columns), colour = verdict, with the
      symplectic Euler's theoretical limit k = m (a/h)^2 (a = 2 undamped, 2(sqrt(1+z^2) - z) damped);
  stability_contact_undamped.png, stability_contact_damped.png: contact stiffness against the
      time step, one panel per integrator and mass, with the line sqrt((k_c + k_t)/m) h = 2;
  stability_boundary.png: the symplectic Euler's largest energy ratio E/E0 against omega h on the
      undamped and damped spring, with the theoretical limits and 1/(1 - omega h / 2).
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

INTEGRATORS = ["implicit-euler", "symplectic-euler", "trapezoidal", "tr-bdf2"]
COLOURS = {
    "stable": ("tab:green", "stable"),
    "energy": ("tab:red", "diverged: energy"),
    "non-finite": ("black", "diverged: non-finite (rolled back)"),
    "penetration": ("tab:purple", "diverged: penetration"),
    "drift": ("tab:brown", "diverged: joint drift"),
}


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("dt_s", "mass_kg", "stiffness", "parameter", "omega_dt"):
            r[k] = float(r[k])
    return rows


def key(r):
    return "stable" if r["stable"] == "1" else r["reason"]


def scatter(ax, rows, x, y):
    for verdict, (colour, label) in COLOURS.items():
        pts = [r for r in rows if key(r) == verdict]
        if pts:
            ax.scatter([p[x] for p in pts], [p[y] for p in pts], s=9, c=colour, marker="s", label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")


def coupling_maps(rows, zeta, out):
    rows = [r for r in rows if abs(r["parameter"] - zeta) < 1e-9]
    dts = sorted({r["dt_s"] for r in rows})
    a = 2.0 * (math.sqrt(1.0 + zeta * zeta) - zeta)
    fig, axes = plt.subplots(len(INTEGRATORS), len(dts), figsize=(3.2 * len(dts), 3 * len(INTEGRATORS)), sharex=True, sharey=True, squeeze=False)
    for i, integ in enumerate(INTEGRATORS):
        for j, h in enumerate(dts):
            ax = axes[i][j]
            sel = [r for r in rows if r["integrator"] == integ and r["dt_s"] == h]
            scatter(ax, sel, "mass_kg", "stiffness")
            ms = [1e-3, 1e2]
            ax.plot(ms, [m * (a / h) ** 2 for m in ms], "k--", lw=1, label="symplectic limit ω h = %.3g" % a)
            ax.set_ylim(5, 2e8)
            ax.set_title("%s, h = %.0e s" % (integ, h), fontsize=8)
            if i == 2:
                ax.set_xlabel("mass m (kg)")
            if j == 0:
                ax.set_ylabel("coupling stiffness k (N/m)")
    handles, labels = axes[1][-1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle("Coupling spring alone, ζ = %.2f: verdict per run (2000 steps from 10 mm, at rest)" % zeta)
    fig.tight_layout(rect=(0, 0.05, 1, 0.96))
    fig.savefig(out, dpi=110)
    plt.close(fig)


def contact_maps(rows, zeta_c, out):
    rows = [r for r in rows if abs(r["parameter"] - zeta_c) < 1e-9]
    masses = sorted({r["mass_kg"] for r in rows})
    fig, axes = plt.subplots(len(INTEGRATORS), len(masses), figsize=(3.6 * len(masses), 3 * len(INTEGRATORS)), sharex=True, sharey=True, squeeze=False)
    for i, integ in enumerate(INTEGRATORS):
        for j, m in enumerate(masses):
            ax = axes[i][j]
            sel = [r for r in rows if r["integrator"] == integ and r["mass_kg"] == m]
            scatter(ax, sel, "stiffness", "dt_s")
            ks = [1e2, 1e8]
            k_t = 2000.0 * m
            ax.plot(ks, [2.0 / math.sqrt((k + k_t) / m) for k in ks], "k--", lw=1, label="ω h = 2, ω² = (k_c + k_t)/m")
            ax.set_ylim(5e-5, 2e-2)
            ax.set_title("%s, m = %.0e kg" % (integ, m), fontsize=8)
            if i == 2:
                ax.set_xlabel("contact stiffness k_c (N/m)")
            if j == 0:
                ax.set_ylabel("time step h (s)")
    handles, labels = axes[1][-1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle("Sphere pushed 20 mm into a plane, contact damping ratio %.1f: verdict per run" % zeta_c)
    fig.tight_layout(rect=(0, 0.05, 1, 0.96))
    fig.savefig(out, dpi=110)
    plt.close(fig)


def boundary_plot(path, out):
    with open(path, newline="") as f:
        rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for zeta, colour in ((0.0, "tab:blue"), (0.85, "tab:orange")):
        sel = sorted((r for r in rows if abs(r["zeta"] - zeta) < 1e-9), key=lambda r: r["omega_dt"])
        if not sel:
            continue
        xs = [r["omega_dt"] for r in sel]
        ys = [min(r["energy_ratio_max"], 1e30) for r in sel]
        ax.semilogy(xs, ys, ".-", color=colour, ms=3, lw=0.8, label="symplectic Euler, ζ = %.2f: max E/E₀" % zeta)
        ax.axvline(sel[0]["theory_omega_dt"], color=colour, ls="--", lw=1,
                   label="theory %.4f, measured %.5f" % (sel[0]["theory_omega_dt"], sel[0]["measured_growth_omega_dt"]))
    xs = [0.02 * i for i in range(1, 100)]
    ax.semilogy(xs, [1.0 / (1.0 - x / 2.0) for x in xs], "k:", lw=1, label="1 / (1 − ω h / 2): invariant ellipse, ζ = 0")
    ax.axhline(100.0, color="grey", lw=0.8, label="verdict bound E ≤ 100 (E₀ + W_in)")
    ax.set_ylim(0.5, 1e6)
    ax.set_xlabel("ω h")
    ax.set_ylabel("max E / E₀ over 4000 steps")
    ax.set_title("Symplectic Euler on a spring: measured stability limit")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    written = []
    p = os.path.join(src, "stability_coupling.csv")
    if os.path.exists(p):
        rows = load(p)
        for zeta, name in ((0.0, "undamped"), (0.85, "damped")):
            f = os.path.join(out, "stability_coupling_%s.png" % name)
            coupling_maps(rows, zeta, f)
            written.append(f)
    p = os.path.join(src, "stability_contact.csv")
    if os.path.exists(p):
        rows = load(p)
        for zeta_c, name in ((0.0, "undamped"), (0.5, "damped")):
            f = os.path.join(out, "stability_contact_%s.png" % name)
            contact_maps(rows, zeta_c, f)
            written.append(f)
    p = os.path.join(src, "stability_boundary.csv")
    if os.path.exists(p):
        f = os.path.join(out, "stability_boundary.png")
        boundary_plot(p, f)
        written.append(f)
    print("wrote " + " ".join(written))


if __name__ == "__main__":
    main()
