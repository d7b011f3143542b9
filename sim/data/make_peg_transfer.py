#!/usr/bin/env python3
"""Writes sim/scenes/peg_transfer.toml: an FLS-style peg transfer (docs/grasping.md, "Peg
transfer") with two trocar graspers, each its own device with a scripted path. Deterministic, no
input data: this script is the scene's whole provenance. Regenerate with

    python3 sim/data/make_peg_transfer.py > sim/scenes/peg_transfer.toml
    python3 sim/data/make_peg_transfer.py clash > tests/data/tube_clash.toml

The second is the test scene of the two instruments' clash (the same instruments, no objects,
their tips driven at each other at 0.5 m/s; tests/sim/run/run_two_hands_test.cpp).

Frame: the board's top face is z = 0, gravity along -z, the left pegs at x < 0, the right at
x > 0, the trocars 0.2 m above the board. Units m, s, rad.
"""

import math

# ---- dimensions (approximate FLS pegboard; docs/grasping.md says where they come from)
PEG_RADIUS = 0.002          # m
PEG_HEIGHT = 0.020          # m, axis length above the board (its cap adds the radius)
PEG_X = (0.050, 0.085)      # |x| of the two columns of each side's six pegs
PEG_Y = (-0.030, 0.0, 0.030)
SIDE = 0.024                # m, side of the object's triangle (through its spheres' centres)
SPHERE = 0.002              # m, radius of the object's spheres (a wall 4 mm thick and tall)
PER_SIDE = 10               # spheres per side (2.4 mm apart: no gap a peg fits through)
OBJECT_MASS = 0.004         # kg
INRADIUS = SIDE / (2.0 * math.sqrt(3.0))

# ---- instruments: the jaws' outer sphere 11 mm from the hinge along the shaft (bimanual.toml's)
JAW_REACH = 0.011
TROCAR = {"left": (-0.09, 0.0, 0.20), "right": (0.09, 0.0, 0.20)}
GRIP_X = 0.006              # m: left grips the object's -y wall at x = -6 mm of its centre, right at +6
OPEN = math.radians(60.0)
CLOSED = math.radians(32.0) # below close_angle_deg = 35: the jaws' outer spheres squeeze the wall
JAW_TIME = 0.15             # s: the jaws close or open over this (the encoder's jump check)
REST_Z = SPHERE             # the object's centre resting on the board
CARRY_Z = 0.034             # the object's centre while carried: its underside 32 mm up, over the pegs
PLACE_Z = REST_Z + 0.002    # let go 2 mm above the board, around the peg
HOVER = 0.020               # m above a grip before descending onto it


def unit(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def tip_for_grip(device, grip):
    """The tool tip (jaw hinge) that puts the jaws' outer spheres at `grip`: on the line from
    the trocar through the grip, JAW_REACH short of it."""
    s = unit(tuple(g - p for g, p in zip(grip, TROCAR[device])))
    return tuple(g - JAW_REACH * c for g, c in zip(grip, s))


def grip_point(device, centre):
    """Where `device`'s jaws hold an object whose centre is at `centre`: on its -y wall."""
    dx = -GRIP_X if device == "left" else GRIP_X
    return (centre[0] + dx, centre[1] - INRADIUS, centre[2])


def up(p, dz):
    return (p[0], p[1], p[2] + dz)


class Path:
    """A device's scripted path as absolute times: line and hold segments."""

    def __init__(self, device, start):
        self.device, self.t, self.at, self.jaw, self.segments = device, 0.0, start, OPEN, []

    def move(self, to, duration):
        self.segments.append(("line", to, duration, None))
        self.t, self.at = self.t + duration, to

    def jaws(self, angle, duration):
        self.segments.append(("hold", None, duration, angle))
        self.t, self.jaw = self.t + duration, angle

    def until(self, t):
        if t > self.t + 1e-9:
            self.segments.append(("hold", None, t - self.t, None))
            self.t = t


def vec(v):
    return "[" + ", ".join(f"{c:.6f}" for c in v) + "]"


def main():
    left_pegs = [(-x, y) for x in PEG_X for y in PEG_Y]
    right_pegs = [(x, y) for x in PEG_X for y in PEG_Y]
    # The nearer column first; each object goes to the mirrored peg.
    order = list(range(6))
    left = Path("left", tip_for_grip("left", (-0.03, -0.04, 0.06)))
    right = Path("right", tip_for_grip("right", (0.03, -0.04, 0.06)))
    left.until(0.3)
    right.until(0.3)
    for i in order:
        src = (*left_pegs[i], REST_Z)
        dst = (-src[0], src[1], PLACE_Z)
        handover = (0.0, src[1], CARRY_Z)
        # Left: over the object, down, close, lift off its peg, carry to the hand-over, wait
        # for right's jaws, open, rise.
        g = grip_point("left", src)
        left.move(tip_for_grip("left", up(g, HOVER)), 0.6)
        left.move(tip_for_grip("left", g), 0.4)
        left.jaws(CLOSED, 0.3)
        left.move(tip_for_grip("left", grip_point("left", up(src, CARRY_Z - REST_Z))), 0.5)
        left.move(tip_for_grip("left", grip_point("left", handover)), 0.6)
        t_arrived = left.t
        left.until(t_arrived + 0.9)
        left.jaws(OPEN, 0.3)
        left.move(tip_for_grip("left", up(grip_point("left", handover), 0.015)), 0.3)
        # Right: waits above its grip on the held object, comes down, closes, holds until left
        # has opened and risen, carries it over its peg, lowers it round the peg, opens, rises.
        h = grip_point("right", handover)
        right.move(tip_for_grip("right", up(h, HOVER)), 0.5)
        right.until(t_arrived)
        right.move(tip_for_grip("right", h), 0.3)
        right.jaws(CLOSED, 0.3)
        right.until(left.t)
        right.move(tip_for_grip("right", grip_point("right", (dst[0], dst[1], CARRY_Z))), 0.7)
        right.move(tip_for_grip("right", grip_point("right", dst)), 0.5)
        right.jaws(OPEN, 0.3)
        right.move(tip_for_grip("right", up(grip_point("right", dst), 0.025)), 0.3)
    left.move(tip_for_grip("left", (-0.03, -0.04, 0.06)), 0.5)
    right.move(tip_for_grip("right", (0.03, -0.04, 0.06)), 0.5)
    end = max(left.t, right.t)
    left.until(end)
    right.until(end)

    out = []
    w = out.append
    w(HEADER)
    for k, (x, y) in enumerate(left_pegs + right_pegs):
        side = "l" if k < 6 else "r"
        w(f"""[[obstacle]]
name = "peg_{side}{k % 6 + 1}"
type = "capsule"
material = "board"
from = {vec((x, y, 0.0))}
to = {vec((x, y, PEG_HEIGHT))}
radius = {PEG_RADIUS}
""")
    corners = [(-SIDE / 2, -INRADIUS), (SIDE / 2, -INRADIUS), (0.0, 2 * INRADIUS)]
    for i, (x, y) in enumerate(left_pegs):
        w(f"""[[body]]
name = "object_{i + 1}"
mass = {OBJECT_MASS}
material = "rubber"
position = {vec((x, y, REST_Z + 1e-4))}""")
        for a, b in zip(corners, corners[1:] + corners[:1]):
            step_x, step_y = (b[0] - a[0]) / PER_SIDE, (b[1] - a[1]) / PER_SIDE
            w(f"""[[body.sphere_line]]
from = {vec((a[0], a[1], 0.0))}
to = {vec((b[0] - step_x, b[1] - step_y, 0.0))}
radius = {SPHERE}
count = {PER_SIDE}""")
        w("")
    w(INSTRUMENTS)
    for name, path, node, cob in (("left", left, 1, 0), ("right", right, 6, 5)):
        w(device_block(name, path, node, cob))
    w(GRASPERS)
    w(BUS)
    print("\n".join(out))


HEADER = f"""# numen peg transfer: the first task of the Fundamentals of Laparoscopic Surgery (FLS) on an
# FLS-style pegboard — twelve pegs, six on each side, six triangular objects that each go from a
# left peg, lifted by the left grasper, handed over in mid-air to the right grasper, onto the
# mirrored right peg (docs/grasping.md, "Peg transfer"). Written by sim/data/make_peg_transfer.py
# (its whole provenance; edit that and regenerate, not this file).
#
# Dimensions (approximate; docs/grasping.md says why): the board's top face at z = 0; pegs
# capsules of radius {PEG_RADIUS * 1e3:g} mm, {PEG_HEIGHT * 1e3:g} mm tall (+ cap), two columns of three on each side
# (|x| = {PEG_X[0] * 1e3:g} and {PEG_X[1] * 1e3:g} mm, y = -30, 0, 30 mm); each object an equilateral triangle of side
# {SIDE * 1e3:g} mm through its spheres' centres ({3 * PER_SIDE} spheres of {SPHERE * 1e3:g} mm: a wall 4 mm wide and tall, a
# hole of {(INRADIUS - SPHERE) * 1e3:.1f} mm inner radius round its peg), {OBJECT_MASS * 1e3:g} g. Gravity on.
#
# Two devices ("left", nodes 1-5, holding tube_l; "right", nodes 6-10), each the default
# scene's trocar-tube-jaws instrument through its own trocar 0.2 m above the board, each with
# its own scripted path (the tip; jaws closed to 32 deg and opened to 60 deg over
# jaw_time = 0.15 s). Each grasper holds an object's -y wall with its jaws' outer spheres
# (left 6 mm to -x of the object's centre, right 6 mm to +x). [task] names the objects and the
# pegs they go to: the summary counts the transfers, hand-overs and drops from the grasp log and
# the objects' final places (docs/outputs.md, "Task").

name = "peg_transfer"
description = "FLS-style peg transfer: six triangular objects lifted from the left pegs, handed over in mid-air, placed on the right pegs by two trocar graspers on two devices"
dt = 0.001
gravity = [0.0, 0.0, -9.81]
integrator = "implicit-euler"
coupling = "god-object"

[[material]]
name = "steel"

[[material]]
name = "rubber"

[[material]]
name = "board"

[contact_default]
stiffness = 2.0e4     # N/m per sphere contact
damping = 10.0        # N·s/m
friction = 0.5        # N·s/m, viscous tangential

[[contact]]           # the objects on the board and the pegs: damped so that they come to rest
materials = ["rubber", "board"]
stiffness = 2.0e3
damping = 2.0
friction = 2.0

[task]
objects = ["object_1", "object_2", "object_3", "object_4", "object_5", "object_6"]
pegs = ["peg_r1", "peg_r2", "peg_r3", "peg_r4", "peg_r5", "peg_r6"]
reach = {INRADIUS:.4f}       # m: an object is on a peg when its centre is this close to the peg's axis

[[obstacle]]
name = "board"
type = "box"
material = "board"
position = [0.0, 0.0, -0.005]
half_extents = [0.12, 0.07, 0.005]
"""


def instrument(side, jaw_spheres=4):
    """The trocar-tube-jaws instrument of device "left" (side "l") or "right" ("r"); each jaw
    `jaw_spheres` spheres of 1.5 mm over its 9 mm (make_suturing.py's needle drivers: 10)."""
    return f"""[[body]]
name = "sleeve_{side}"
mass = 0.02
inertia = [2.0e-5, 2.0e-5, 1.0e-6]
material = "steel"
link = "trocar"
device = "{'left' if side == 'l' else 'right'}"
[body.coupling]
rotational_stiffness = 0.5
rotational_damping_ratio = 0.85

[[body]]
name = "tube_{side}"
mass = 0.05
material = "steel"
link = "tube"
device = "{'left' if side == 'l' else 'right'}"
link_offset = {{ position = [0.0, 0.0, -0.04] }}
[[body.sphere_line]]
from = [0.0, 0.0, -0.08]
to = [0.0, 0.0, 0.0375]
radius = 0.0025
count = 30
[body.coupling]
stiffness = 1000.0
damping_ratio = 0.85
rotational_stiffness = 1.0
rotational_damping_ratio = 0.85
""" + "".join(f"""
[[body]]
name = "jaw_{k}_{side}"
mass = 0.005
material = "steel"
link = "jaw_{k}"
device = "{'left' if side == 'l' else 'right'}"
link_offset = {{ position = [0.0, 0.0, 0.006] }}
[[body.sphere_line]]
from = [0.0, 0.0, -0.004]
to = [0.0, 0.0, 0.005]
radius = 0.0015
count = {jaw_spheres}
[body.coupling]
stiffness = 100.0
damping_ratio = 0.85
rotational_stiffness = 0.02
rotational_damping_ratio = 0.85
""" for k in (1, 2)) + f"""
[[joint]]
name = "pivot_{side}"
type = "spherical"
parent = "world"
parent_frame = "trocar"
child = "sleeve_{side}"

[[joint]]
name = "insertion_{side}"
type = "cylindrical"
parent = "sleeve_{side}"
child = "tube_{side}"
""" + "".join(f"""
[[joint]]
name = "jaw_{k}_hinge_{side}"
type = "revolute"
parent = "tube_{side}"
parent_frame = {{ position = [0.0, 0.0, 0.04], axis = [1.0, 0.0, 0.0] }}
child = "jaw_{k}_{side}"
child_frame = {{ position = [0.0, 0.0, -0.006], axis = [1.0, 0.0, 0.0] }}
prescribed = {{ axis = "jaw", scale = {0.5 if k == 1 else -0.5}, device = "{'left' if side == 'l' else 'right'}" }}
""" for k in (1, 2))


INSTRUMENTS = ("# ---- the instruments: bimanual.toml's trocar-tube-jaws instrument, each on its device\n\n"
               + instrument("l") + "\n" + instrument("r"))


def device_block(name, path, node, cob):
    out = device_header(name, node, cob, "tube_l" if name == "left" else None, TROCAR[name])
    out += f"""
[device.trajectory]
source = "scripted"
start = {{ position = {vec(TROCAR_START[name])}, orientation = [0.0, 1.0, 0.0, 0.0], jaw = {OPEN:.6f} }}
"""
    for kind, to, duration, jaw in path.segments:
        out += f"[[device.trajectory.segment]]\ntype = \"{kind}\"\n"
        if kind == "line":
            out += f"to = {vec(to)}\n"
        out += f"duration = {duration:.3f}\n"
        if jaw is not None:
            out += f"jaw = {jaw:.6f}\njaw_time = {JAW_TIME}\n"
    return out


def device_header(name, node, cob, attach, trocar, trocar_orientation=None):
    """A trocar device's table up to its trajectory: its nodes from `node`, its COB-IDs `cob` past
    the first device's, `attach` (the held body, the first device's only), its trocar (the
    orientation as a vec() string; None: z down)."""
    axes = [("pivot_x", 2607.5945876176133, -1.2, 1.2, 10.0, True, 0.5, 1.0),
            ("pivot_y", 2607.5945876176133, -1.2, 1.2, 10.0, True, 0.5, 1.0),
            ("depth", 1.0e5, 0.0, 0.35, 2.0, True, 5.0, 10.0),
            ("roll", 2607.5945876176133, -math.pi, math.pi, 30.0, False, 0, 0),
            ("jaw", 2607.5945876176133, -math.pi, math.pi, 30.0, False, 0, 0)]
    out = f"""[[device]]
kind = "trocar-instrument"
name = "{name}"
first_node_id = {node}
"""
    if attach:
        out += f'attach = "{attach}"\n'
    out += f"""tool_offset = {{ position = [0.0, 0.0, -0.04] }}   # link "tool": the tube's COM frame
max_sample_age = 0.003
jump_tolerance_counts = 2

[device.trocar]
point = {vec(trocar)}
orientation = {trocar_orientation or "[0.0, 1.0, 0.0, 0.0]"}   # {"z along the shaft" if trocar_orientation else "z (the shaft into the box) down"}

[device.feedback]            # Eq. 8 virtual coupling to the trainer's motors
stiffness = 300.0            # N/m
damping = 1.0                # N·s/m
rotational_stiffness = 0.5   # N·m/rad
rotational_damping = 0.005   # N·m·s/rad
max_force = 8.0              # N
max_torque = 0.3             # N·m
"""
    for k, (axis, cpu, lo, hi, speed, drive, rated, most) in enumerate(axes):
        out += f"""
[[device.axis]]
name = "{axis}"
encoder_cob_id = 0x{0x181 + cob + k:X}
"""
        if drive:
            out += f"drive_cob_id = 0x{0x201 + cob + k:X}\n"
        out += f"counts_per_unit = {cpu!r}\nmin = {lo!r}\nmax = {hi!r}\nmax_speed = {speed}\n"
        if drive:
            out += f"rated_torque = {rated}\nmax_torque = {most}\n"
        if axis == "roll":
            out += "wraps = true\n"
    out += "\n[device.canopen]\n" + "".join(
        f'[[device.canopen.axis]]\ndcf = "devices/{dcf}.dcf"\n'
        for dcf in ("trocar_drive", "trocar_drive", "trocar_drive", "encoder", "encoder"))
    return out


TROCAR_START = {"left": tip_for_grip("left", (-0.03, -0.04, 0.06)),
                "right": tip_for_grip("right", (0.03, -0.04, 0.06))}

GRASPERS = """# ---- graspers (docs/grasping.md): a grasp starts below 35 deg with both jaws on the object (the
# jaws' outer spheres first touch its 4 mm wall at about 37 deg) and ends above 45 deg.

[[grasp]]
name = "left_grasper"
jaws = ["jaw_1_l", "jaw_2_l"]
close_angle_deg = 35.0
open_angle_deg = 45.0
tissue = false

[[grasp]]
name = "right_grasper"
jaws = ["jaw_1_r", "jaw_2_r"]
close_angle_deg = 35.0
open_angle_deg = 45.0
tissue = false

""" + "\n"

BUS = """[bus]
latency = 0.0001
drop_probability = 0.0
corruption_probability = 0.0
seed = 1
"""

def clash():
    """The instruments alone, jaws shut, their tips at the same height 60 mm apart driven at each
    other at 0.5 m/s each for 0.12 s (each target 30 mm past the other's start), then held."""
    out = [CLASH_HEADER, INSTRUMENTS]
    for name, sign, node, cob in (("left", -1.0, 1, 0), ("right", 1.0, 6, 5)):
        p = Path(name, (sign * 0.03, 0.0, 0.05))
        p.segments = [("hold", None, 0.1, None), ("line", (-sign * 0.03, 0.0, 0.05), 0.12, None),
                      ("hold", None, 0.18, None)]
        block = device_block(name, p, node, cob)
        block = block.replace(f"position = {vec(TROCAR_START[name])}", f"position = {vec((sign * 0.03, 0.0, 0.05))}")
        block = block.replace(f"jaw = {OPEN:.6f}", "jaw = 0.0")
        out.append(block)
    out.append(BUS)
    print("\n".join(out))


CLASH_HEADER = """# Test scene (written by sim/data/make_peg_transfer.py clash): peg_transfer.toml's two trocar
# instruments, each on its own device, jaws shut, their tips 60 mm apart at the same height and
# driven at each other at 0.5 m/s each for 0.12 s: their hands' targets cross and go 30 mm past
# each other; the god-objects must stop on each other (tests/sim/run/run_two_hands_test.cpp).

name = "tube_clash"
dt = 0.001
gravity = [0.0, 0.0, -9.81]

[[material]]
name = "steel"

[contact_default]
stiffness = 2.0e4
damping = 10.0
friction = 0.5
"""

if __name__ == "__main__":
    import sys
    clash() if sys.argv[1:] == ["clash"] else main()
