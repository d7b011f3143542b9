#!/usr/bin/env python3
"""Steps numen's lattice scene (the default scene with a rigid sphere-lattice organ) from Python
and plots how deep the tool (the god-object) and its target (the same instrument imposed at the
hand's pose) go into the organ and the tissue (docs/python.md).

    PYTHONPATH=build/sim/python /usr/bin/python3 examples/python_step.py \
        --out docs/figures/python_step_depth.png

Two Data of the lattice scene are stepped with the same targets: each step, Data.set_targets_at
turns the scene trajectory's sample (the instrument's tip and jaw) into every body's target as
`numen run` does from the encoders (the held tube's centre of mass 40 mm behind the tip, the
sleeve at the trocar, the jaws imposed), without the bus (numen.run_scene runs the full control
loop). One is the scene as it is (god-object
coupling: springs pull the tool toward the target, contacts keep it out of the obstacles); the
other is loaded with coupling "direct", which imposes the target pose on the held body: it
goes where the hand goes, through the obstacles. Depth is Data.max_penetration, the deepest
contact of the step (mm). Needs matplotlib (python3-matplotlib); Agg backend, no display.
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import numen  # noqa: E402


def scripted_step(scene, data):
    data.set_targets_at(data.time)
    data.step(scene)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="python_step_depth.png", help="PNG to write")
    ap.add_argument("--duration", type=float, default=None, help="s (default: the scene's)")
    args = ap.parse_args()

    path = os.path.join(os.path.dirname(numen.default_scene_path()), "lattice.toml")
    tool_scene = numen.load_scene(path)
    target_scene = numen.load_scene(path, coupling="direct")
    tool, target = tool_scene.make_data(), target_scene.make_data()
    steps = int(round((args.duration or tool_scene.duration) / tool_scene.dt))
    t, tool_depth, target_depth = (np.empty(steps) for _ in range(3))
    for k in range(steps):
        scripted_step(tool_scene, tool)
        scripted_step(target_scene, target)
        t[k] = tool.time
        tool_depth[k] = tool.max_penetration * 1e3
        target_depth[k] = target.max_penetration * 1e3

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t, target_depth, label="target (instrument imposed at the hand's pose)",
            color="tab:orange")
    ax.plot(t, tool_depth, label="tool (god-object)", color="tab:blue")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("deepest contact (mm)")
    ax.set_title(f"numen from Python: scene '{tool_scene.name}', {steps} steps of "
                 f"{tool_scene.dt * 1e3:g} ms, targets set_targets_at")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"{steps} steps; deepest contact: target {target_depth.max():.1f} mm, tool "
          f"{tool_depth.max():.1f} mm (median over steps {np.median(tool_depth):.2f} mm); "
          f"wrote {args.out}")


if __name__ == "__main__":
    main()
