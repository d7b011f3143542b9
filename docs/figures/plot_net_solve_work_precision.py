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
through its tolerances 1e-1 … 1e-10 (points labelled with the tolerance's
exponent), LDLᵀ as one point. Errors below 1e-16 are drawn at 1e-16.
Prints the table the figure (with the fastest solve, min_us, and the time
per iteration after the factorization, (median − factorize) / iterations,
which includes the start's residual and Eigen's vector set-up) is drawn from and, per size, the ratios at equal
error: for each numen point, each Eigen CG's time at numen's true error
(interpolated log–log between its two points that bracket it) over numen's
time, with the medians and with the fastest solves (min_us), and LDLᵀ's time
over numen's.
Usage: plot_net_solve_work_precision.py BENCH.json OUT.png"""
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

SOLVERS = [  # benchmark name, legend, style
    ("NetPeerNumen", "numen SSOR–Eisenstat CG (stops on ‖r‖_M⁻¹ / ‖b‖_D̃⁻¹)", "o-", "C0"),
    ("NetPeerEigenCgDiagonal", "Eigen CG + diagonal (stops on ‖r‖₂ / ‖b‖₂)", "s-", "C1"),
    ("NetPeerEigenCgIncompleteCholesky", "Eigen CG + IncompleteCholesky (‖r‖₂ / ‖b‖₂)", "^-", "C2"),
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
            min_us=r.get("min_us", r["median_us"]),
            factorize_us=r.get("median_factorize_us", 0.0), it=r["iterations"],
            err=r["error_nodes"], err_all=r["error_all"], ok=r["converged"]))
    return pts


pts = load(sys.argv[1])
sizes = sorted({p["nodes"] for v in pts.values() for p in v})
fig, axes = plt.subplots(1, len(sizes), figsize=(5.2 * len(sizes), 4.6), squeeze=False)
print(f"{'nodes':>6} {'solver':<34} {'tol':>7} {'iter':>6} {'µs':>9} {'min µs':>9} "
      f"{'factor µs':>9} {'µs/iter':>8} {'err Δv':>9} {'err all':>9}")
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
            per_it = (q["us"] - q["factorize_us"]) / q["it"] if q["it"] > 0 else float("nan")
            print(f"{n:>6} {name:<34} {q['tol']:>7.0e} {q['it']:>6.0f} {q['us']:>9.1f} "
                  f"{q['min_us']:>9.1f} {q['factorize_us']:>9.1f} {per_it:>8.1f} "
                  f"{q['err']:>9.2e} {q['err_all']:>9.2e}"
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

# Equal-error ratios. For each numen point and each Eigen solver: the time that
# solver needs for numen's true error, interpolated log–log between its two
# measured points that bracket that error (its tolerances are a decade apart,
# so the nearest point at least as accurate would overstate its cost), over
# numen's time; with the median times and with the fastest solves (min_us).
def time_at_error(curve, err, key):
    """Log–log interpolated time of `curve` (points sorted by falling error) at `err`."""
    for hi, lo in zip(curve, curve[1:]):
        if lo["err"] <= err <= hi["err"] and lo["err"] < hi["err"]:
            w = (math.log(hi["err"]) - math.log(err)) / (math.log(hi["err"]) - math.log(lo["err"]))
            return math.exp((1 - w) * math.log(hi[key]) + w * math.log(lo[key]))
    if curve and curve[0]["err"] <= err:  # its loosest point is already as accurate
        return curve[0][key]
    return None


print("\nAt numen's true error: Eigen's time (interpolated) / numen's time, medians (fastest):")
for n in sizes:
    numen = sorted((q for q in pts.get("NetPeerNumen", []) if q["nodes"] == n),
                   key=lambda q: -q["tol"])
    for q in numen:
        parts = []
        for name, *_ in SOLVERS[1:3]:
            curve = sorted((r for r in pts.get(name, []) if r["nodes"] == n),
                           key=lambda r: -r["err"])
            t_med = time_at_error(curve, q["err"], "us")
            t_min = time_at_error(curve, q["err"], "min_us")
            short = name.replace("NetPeerEigenCg", "CG+")
            parts.append(f"{short} ×{t_med / q['us']:.1f} (×{t_min / q['min_us']:.1f})"
                         if t_med else f"{short} —")
        ldlt = [r for r in pts.get("NetPeerEigenLdlt", []) if r["nodes"] == n]
        if ldlt:
            parts.append(f"LDLT ×{ldlt[0]['us'] / q['us']:.0f}")
        print(f"{n:>6} numen tol {q['tol']:.0e} ({q['us']:.1f} µs, {q['it']:.0f} it, "
              f"err {q['err']:.1e}): " + ", ".join(parts))
