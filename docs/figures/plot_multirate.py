#!/usr/bin/python3
"""Multirate quality against the rate ratio (docs/multirate.md): runs a shipped scene through
`numen run --json --replay` single-rate and with `[multirate] scene_dt = N·dt` for each ratio N, and plots
the tool's deepest contact, the free-space tracking error, a third figure of the scene (the
fastest free body, the net's largest tie stretch, or the largest feedback force) and the largest
feedback-force jump (at a new scene model and otherwise) against N; the single-rate run at the
device rate as a line, and the single-rate run at the scene loop's period (dt = N·1 ms, up to
N = 20) as a second series. Writes the figures and a JSON of the numbers beside them.

    /usr/bin/python3 docs/figures/plot_multirate.py ./build/numen OUT_DIR [SCENE ...]

With SCENE names, only those scenes are run; the other scenes' numbers are read from the
OUT_DIR/multirate_quality.json already there, and the figure is drawn from both.

(docs/figures/make_figures.sh runs it.) The scene copies are written to a temporary directory
with their data and DCF paths made absolute. The margin is 10 mm for every ratio on the rigid
scenes (1 m/s of tool travel at 100 Hz) and 2 mm on the deformable ones (the hands travel less
than that in 10 ms; docs/multirate.md, "The margin on sphere sets"). A run that fails is left
out of its series (a single-rate scene at 20 ms may not hold, a multirate run at N = 100 may be
stopped by the run monitor). Needs Debian's python3-matplotlib (run with /usr/bin/python3).
"""
import json
import os
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

RATIOS = [1, 2, 5, 10, 20, 100]
SLOW = [2, 5, 10, 20]  # single-rate at dt = N·1 ms
MARGIN = {"construction": 0.01, "lattice": 0.01, "deformable": 0.002, "endobag": 0.002}
SCENES = ["construction", "lattice", "deformable", "endobag"]
THIRD = {"construction": ("free_body_speed_max_mps", "fastest free body (m/s)"),
         "lattice": ("feedback_force_max_n", "largest feedback force (N)"),
         "deformable": ("net_tie_stretch_max_mm", "net's largest tie stretch (mm)"),
         "endobag": ("net_tie_stretch_max_mm", "net's largest tie stretch (mm)")}


def scene_copy(root, name, ratio, tmp, slow=None):
    scenes = os.path.join(root, "sim", "scenes")
    with open(os.path.join(scenes, name + ".toml")) as f:
        text = f.read()
    text = text.replace('"../data/', '"' + os.path.join(root, "sim", "data") + "/")
    text = text.replace('dcf = "devices/', 'dcf = "' + os.path.join(scenes, "devices") + "/")
    if ratio is not None:
        dt = None
        for line in text.splitlines():
            if line.startswith("dt ="):
                dt = float(line.split("=")[1].split("#")[0])
        text += "\n[multirate]\nscene_dt = %r\nmargin = %r\n" % (dt * ratio, MARGIN[name])
    if slow is not None:
        text = text.replace("\ndt = 0.001\n", "\ndt = %r\n" % (0.001 * slow), 1)
    path = os.path.join(tmp, "%s_%s_%s.toml" % (name, ratio or "single", slow or 1))
    with open(path, "w") as f:
        f.write(text)
    return path


def run(numen, path, may_fail=False):
    # --replay: the same hand in every run (a scene's [device.plant] would let each run's device
    # answer its own forces; the closed loop is docs/device_plant.md's).
    out = subprocess.run([numen, "run", path, "--json", "--replay"], capture_output=True, text=True)
    if out.returncode != 0:
        if may_fail:
            status = [l.strip() for l in out.stderr.splitlines() if l.strip().startswith("exit status")]
            print("left out: %s (%s)" % (os.path.basename(path), status[-1] if status else "exit %d" % out.returncode))
            return None
        sys.exit("%s failed (exit %d): %s" % (path, out.returncode, out.stderr[-2000:]))
    return json.loads(out.stdout)


def main():
    numen, out_dir = sys.argv[1], sys.argv[2]
    chosen = sys.argv[3:] or SCENES
    for name in chosen:
        if name not in SCENES:
            sys.exit("unknown scene %r (one of %s)" % (name, ", ".join(SCENES)))
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    results = {}
    kept = os.path.join(out_dir, "multirate_quality.json")
    if chosen != SCENES:
        try:
            with open(kept) as f:
                earlier = json.load(f)
        except OSError as e:
            sys.exit("%s: %s (the scenes not run are read from it)" % (kept, e))
        for name in SCENES:
            if name not in chosen:
                if name not in earlier:
                    sys.exit("%s has no scene %r (run it too)" % (kept, name))
                results[name] = earlier[name]
    with tempfile.TemporaryDirectory() as tmp:
        for name in chosen:
            single = run(numen, scene_copy(root, name, None, tmp))
            rows = [run(numen, scene_copy(root, name, n, tmp), may_fail=n >= 100) for n in RATIOS]
            slow = [run(numen, scene_copy(root, name, None, tmp, n), may_fail=True) for n in SLOW]
            results[name] = {"single": single,
                             "multirate": {str(n): r for n, r in zip(RATIOS, rows) if r is not None},
                             "slow": {str(n): r for n, r in zip(SLOW, slow) if r is not None}}
    with open(os.path.join(out_dir, "multirate_quality.json"), "w") as f:
        json.dump({n: {"single": {k: r["single"][k] for k in keys(r["single"])},
                       "multirate": {q: {k: v[k] for k in keys(v)} | {"multirate": v["multirate"]}
                                     for q, v in r["multirate"].items()},
                       "slow": {q: {k: v[k] for k in keys(v)} for q, v in r["slow"].items()}}
                   for n, r in ((n, results[n]) for n in SCENES)}, f, indent=1)
    fig, ax = plt.subplots(len(SCENES), 4, figsize=(16, 3.6 * len(SCENES)))
    for i, name in enumerate(SCENES):
        r = results[name]
        panels = [("tool_penetration_max_mm", "tool's deepest contact (mm)"),
                  ("tracking_error_free_rms_mm", "free-space tracking rms (mm)"), THIRD[name],
                  ("feedback_force_jump_max_n", "largest feedback-force jump (N)")]
        for j, (key, label) in enumerate(panels):
            a = ax[i][j]
            ratios = [n for n in RATIOS if str(n) in r["multirate"]]
            ys = [r["multirate"][str(n)][key] for n in ratios]
            a.semilogx(ratios, ys, "o-", label="multirate (device 1 kHz)")
            slow = [(n, r["slow"][str(n)][key]) for n in SLOW if str(n) in r["slow"]]
            if slow:
                a.semilogx([n for n, _ in slow], [y for _, y in slow], "^:", color="tab:red",
                           label="single-rate at dt = N ms")
            if key == "feedback_force_jump_max_n":
                a.semilogx(ratios, [r["multirate"][str(n)]["multirate"]["model_force_jump_max_n"] for n in ratios],
                           "s--", label="… into a period with a new model")
            a.axhline(r["single"][key], color="k", lw=0.8, label="single-rate 1 kHz")
            a.set_title("%s: %s" % (name, label), fontsize=9)
            a.set_xlabel("rate ratio N = scene_dt / dt")
            a.grid(True, which="both", alpha=0.3)
            if i == 0 and j == 0:
                a.legend(fontsize=8)
            if key == "feedback_force_jump_max_n":
                a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "multirate_quality.png"), dpi=110)
    print("wrote", os.path.join(out_dir, "multirate_quality.png"))


def keys(summary):
    return [k for k in ("tool_penetration_max_mm", "tracking_error_free_rms_mm", "free_body_speed_max_mps",
                        "feedback_force_max_n", "feedback_force_jump_max_n", "any_penetration_max_mm",
                        "net_penetration_max_mm", "net_tie_stretch_max_mm", "nonfinite_steps")
            if k in summary]


if __name__ == "__main__":
    main()
