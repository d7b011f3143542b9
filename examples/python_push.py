#!/usr/bin/env python3
"""Pushes numen's probe into a box from a Python loop and prints what a haptic program reads
each step: the feedback force and the contacts, with the obstacle each one touches
(docs/python.md "Drive it from your own program").

    PYTHONPATH=P/lib/python3/dist-packages /usr/bin/python3 examples/python_push.py

(P: the install prefix; PYTHONPATH=build/sim/python from a build tree.) The scene is the shipped
sim/scenes/probe.toml: a probe, one 5 mm sphere of 50 g, above a box whose top face is at z = 0;
no [trajectory]: this loop is the hand. Each 1 ms step it sets the target of the probe's centre
of mass (Data.set_target: world frame, metres, the orientation by name, xyzw=), from 10 mm
above the box down to 4 mm below its top face in 0.5 s, then holds it there for 0.5 s. The
probe (the god-object) stays on the surface, pressed in by its coupling spring; the feedback
(Eq. 8, the scene's [device.feedback]) pulls the hand back up towards it.
"""
import os

import numen

TOP = 0.0       # z of the box's top face (m)
START = 0.010   # the target's first height (m): 10 mm above the top
END = -0.004    # its last: 4 mm below the top
PUSH_S = 0.5    # s from START to END, then held as long


def main():
    scene = numen.load_scene(os.path.join(os.path.dirname(numen.default_scene_path()),
                                          "probe.toml"))
    for warning in scene.warnings:
        print("warning:", warning)
    data = scene.make_data()
    obstacles = scene.model.obstacle_names
    steps = int(round(2 * PUSH_S / scene.dt))
    speed = (END - START) / PUSH_S
    touched = set()
    for k in range(steps):
        t = k * scene.dt
        s = min(t / PUSH_S, 1.0)
        moving = t < PUSH_S
        data.set_target([0.0, 0.0, START + s * (END - START)], xyzw=[0.0, 0.0, 0.0, 1.0],
                        linear_velocity=[0.0, 0.0, speed if moving else 0.0])
        data.step(scene)
        for obstacle in data.contact_obstacles:
            if obstacle >= 0:
                touched.add(obstacles[obstacle])
    probe_z = data.body_positions[0, 2]
    radius = 0.005
    print(f"{steps} steps of {scene.dt * 1e3:g} ms; target {END * 1e3:+.1f} mm, probe centre "
          f"{probe_z * 1e3:+.3f} mm: {(TOP - (probe_z - radius)) * 1e3:.3f} mm into the box")
    print(f"contacts {data.num_contacts} on {', '.join(sorted(touched))}; deepest "
          f"{data.max_penetration * 1e3:.3f} mm")
    print(f"feedback force {data.feedback_wrench[2]:+.4f} N (z), coupling "
          f"{data.coupling_wrench[2]:+.4f} N; invalid target steps {data.invalid_target_steps}")


if __name__ == "__main__":
    main()
