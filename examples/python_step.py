#!/usr/bin/env python3
"""Steps numen's default scene from Python and plots how deep the tool (the god-object) and its
target (where the recorded hand puts it) go, over time (docs/python.md).

    PYTHONPATH=build/sim/python /usr/bin/python3 examples/python_step.py \
        --out docs/figures/python_step_depth.png

The device target of the attached body is the scene trajectory's pose and twist at each step
(a scripted target: no bus, no device kinematics; `numen.run_scene` runs the full loop). Depth
is measured along the world z axis against the height of the target at t = 0, in mm: the
recorded motion of the default scene goes down into the organ and the tissue, the god-object is
held at their surface by the contacts. Needs matplotlib (python3-matplotlib); Agg backend, no
display.
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import numen  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="python_step_depth.png", help="PNG to write")
    ap.add_argument("--duration", type=float, default=None, help="s (default: the scene's)")
    args = ap.parse_args()

    scene = numen.load_scene(numen.default_scene_path())
    data = scene.make_data()
    held = data.attached_body
    positions = data.body_positions  # (B, 3) view: shows every step, no copy
    steps = int(round((args.duration or scene.duration) / scene.dt))
    z0 = scene.target_at(0.0)[0][2]
    t, tool, target, contacts = (np.empty(steps) for _ in range(4))
    for k in range(steps):
        position, orientation, _jaw = scene.target_at(data.time)
        linear, angular = scene.target_twist_at(data.time)
        data.set_target(position, orientation, linear, angular)
        data.step(scene)
        t[k] = data.time
        target[k] = (z0 - position[2]) * 1e3
        tool[k] = (z0 - positions[held, 2]) * 1e3
        contacts[k] = data.num_contacts

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t, target, label="target (recorded hand)", color="tab:orange")
    ax.plot(t, tool, label=f"tool ({scene.model.body_names[held]}, god-object)", color="tab:blue")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("depth below the start (mm)")
    ax.set_title(f"numen from Python: scene '{scene.name}', {steps} steps of {scene.dt * 1e3:g} ms")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"{steps} steps; deepest target {target.max():.1f} mm, tool {tool.max():.1f} mm, "
          f"steps with contact {int((contacts > 0).sum())}; wrote {args.out}")


if __name__ == "__main__":
    main()
