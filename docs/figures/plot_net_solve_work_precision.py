"""Work–precision of the coupled net solve against Eigen's sparse solvers
(docs/deformable.md, "Work–precision against Eigen's solvers"). Input: the
JSON of
  numen_bench --benchmark_filter=NetPeer --benchmark_repetitions=5
              --benchmark_enable_random_interleaving=true
              --benchmark_report_aggregates_only=true
              --benchmark_out=FILE --benchmark_out_format=json
(tests/bench/net_solve_peer_bench.cpp). One panel per ball size (162, 642,
2562 nodes): the true error of the nodes' Δv against the refined LDLᵀ
solution (error_nodes, log) against the time per solve (median over the
repetitions of each repetition's median, µs, log), one line per solver
through its tolerances 1e-1 … 1e-8 (points labelled with the tolerance's
exponent), LDLᵀ as one point. Errors below 1e-16 are drawn at 1e-16.
Prints the table the figure is drawn from and, per size, the ratio at equal
error: for each numen point, the cheapest Eigen point whose error is at most
numen's, and its time over numen's.
Usage: plot_net_solve_work_precision.py BENCH.json OUT.png"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

SOLVERS = [  # benchmark name, legend, style
    ("NetPeerNumen", "numen SSOR–Eisenstat CG (‖r‖_{M⁻¹}/‖b‖_{D̃⁻¹})", "o-", "C0"),
    ("NetPeerEigenCgDiagonal", "Eigen CG + diagonal (‖r‖/‖b‖)", "s-", "C1"),
    ("NetPeerEigenCgIncompleteCholesky", "Eigen CG + IncompleteCholesky (‖r‖/‖b‖)", "^-", "C2"),
    ("NetPeerEigenLdlt", "Eigen SimplicialLDLT (factorize + solve)", "D", "C3"),
]
FLOOR = 1e-16


def load(path):
    pts = {}
    for r in json.load(open(path))["benchmarks"]:
        if r.get("aggregate_name") != "median" or not r["name"].startswith("NetPeer"):
            continue
        solver = r["name"].split("/")[0]
        pts.setdefault(solver, []).append(dict(
            nodes=int(round(r["nodes"])), tol=r["tolerance"], us=r["median_us"],
            factorize_us=r.get("median_factorize_us", 0.0), it=r["iterations"],
            err=r["error_nodes"], err_all=r["error_all"], ok=r["converged"]))
    return pts


pts = load(sys.argv[1])
sizes = sorted({p["nodes"] for v in pts.values() for p in v})
fig, axes = plt.subplots(1, len(sizes), figsize=(5.2 * len(sizes), 4.6), squeeze=False)
print(f"{'nodes':>6} {'solver':<34} {'tol':>7} {'iter':>6} {'µs':>9} {'factor µs':>9} "
      f"{'err Δv':>9} {'err all':>9}")
for ax, n in zip(axes[0], sizes):
    for name, label, style, color in SOLVERS:
        p = sorted((q for q in pts.get(name, []) if q["nodes"] == n), key=lambda q: -q["tol"])
        if not p:
            continue
        t = [q["us"] for q in p]
        e = [max(q["err"], FLOOR) for q in p]
        ax.loglog(t, e, style, color=color, label=label, ms=5)
        for q, ti, ei in zip(p, t, e):
            if q["tol"] > 0:
                ax.annotate(f"{-round(math.log10(q['tol']))}", (ti, ei),
                            textcoords="offset points", xytext=(4, 3), fontsize=7, color=color)
            print(f"{n:>6} {name:<34} {q['tol']:>7.0e} {q['it']:>6.0f} {q['us']:>9.1f} "
                  f"{q['factorize_us']:>9.1f} {q['err']:>9.2e} {q['err_all']:>9.2e}"
                  + ("" if q["ok"] else "  not converged"))
    ax.set_title(f"{n} nodes ({3 * n + 6} unknowns)")
    ax.set_xlabel("time per solve (µs, median)")
    ax.set_ylabel("‖Δv − Δv_ref‖ / ‖Δv_ref‖ (nodes)")
    ax.grid(alpha=0.3, which="both")
axes[0][0].legend(fontsize=7, loc="lower left")
fig.suptitle("Deformable ball, one frozen step: the same A Δ = b, the same warm start "
             "(numbers at the points: −log10 tolerance)", fontsize=10)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=120)
print("wrote", sys.argv[2])

# Equal-error ratios: for each numen point, the cheapest Eigen solve at least as accurate.
print("\nAt equal true error (Eigen time / numen time, the cheapest Eigen point with "
      "error ≤ numen's):")
for n in sizes:
    for q in sorted((q for q in pts.get("NetPeerNumen", []) if q["nodes"] == n),
                    key=lambda q: -q["tol"]):
        cands = [(r["us"], name, r) for name, *_ in SOLVERS[1:] for r in pts.get(name, [])
                 if r["nodes"] == n and r["err"] <= q["err"]]
        if not cands:
            print(f"{n:>6} numen tol {q['tol']:.0e}: no Eigen point as accurate")
            continue
        us, name, r = min(cands, key=lambda c: c[0])
        tol = f"tol {r['tol']:.0e}" if r["tol"] > 0 else "direct"
        print(f"{n:>6} numen tol {q['tol']:.0e} ({q['us']:.1f} µs, err {q['err']:.1e}) vs "
              f"{name} {tol} ({us:.1f} µs, err {r['err']:.1e}): ×{us / q['us']:.1f}")
