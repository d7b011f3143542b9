#!/usr/bin/env python3
"""Writes sim/scenes/suturing.toml: two suture passes (docs/suturing.md, "The suturing scene") —
a tissue pad with an entry and an exit mark for each, the 26 mm half-circle needle with its thread, two
needle drivers (trocar instruments with dense jaws) on two devices, each with a scripted path.
Deterministic, no input data: this script is the scene's whole provenance. Regenerate with

    python3 sim/data/make_suturing.py > sim/scenes/suturing.toml

`python3 sim/data/make_suturing.py --perturb SEED` writes the same scene with each device's path
moved by a smooth offset of up to ±2 mm on each coordinate (seeded; `perturbed()`): the perturbed
runs of docs/suturing.md (tests/sim/run/suturing_scene_test.cpp makes its own the same way).

The pass. The right driver holds the needle near its tail, its plane normal to the shaft, and
rolls it about the arc's own axis (the tip goes round its circle; the jaws' hinge goes round the
arc's centre with it): the tip presses on the pad at the entry mark until the force along the
needle reaches the puncture threshold, goes in, runs under the surface along the arc and comes out
at the exit mark. The left driver then closes on the wire near the tip, the right opens and draws
back, and the left rolls the needle on round its arc until the tail has passed out of the pad:
the needle's puncture points are let go and the thread (tied to the tail) follows. The left then
draws the needle back (pulling thread through for the next pass), hands it back to the right over
the second pass's start, 6 mm along the wound, and the pass is made again there.

A trocar fixes the shaft's direction from the hinge's place (only the roll about the shaft is
free), so the needle cannot turn exactly about its arc's axis: each knot is the rigid turn of the
needle about that axis mapped onto what the trocar allows (the roll taken from it, the hinge moved
so that the arc's centre stays put); the needle's plane then tilts by at most the shaft's swing,
about atan(8.3 mm / 150 mm) = 3 deg.

The drivers look (each device's `[device.trajectory.servo]`, docs/suturing.md "The drivers'
sight"): the one holding the needle moves its hand until the needle's arc centre is where its
script wants it (each segment's `servo_target`), and one coming to take the needle until its own
jaws' hinge is where the script closes them on the wire.

Frame: the pad's top face at z = 0, gravity along -z, the trocars up and to +x. Units m, s, rad.
"""

import math
import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_peg_transfer import device_header, instrument  # noqa: E402  the peg transfer's instrument

# ---- the needle: the 26 mm half circle (core::NeedleSpec's defaults)
R = 0.026 / math.pi            # m, the arc's radius
WIRE = 0.00035                 # m, the wire's radius
PUNCTURE_FORCE = 1.0           # N: 3-0 taper needle through skin (docs/suturing.md, "The threshold")
NEEDLE_MASS = 0.002            # kg: the needle's simulated mass, not the steel wire's 78 mg: a 78 mg
                               # needle turns about its chord (I = 5e-10 kg m^2) far faster than a 1 ms
                               # step resolves between jaws and tissue (docs/suturing.md, "The suturing
                               # scene": what diverged, and the two changes)

# ---- the pad: a box net on an anchored core, its top at z = 0. Its constants are the needle
# puncture rig's (tests/core/needle_puncture_test.cpp) on a 1 442-node pad of 1 x 0.83 mm on its
# top face, kept per area at the coarser 24 x 20 mm net of 496 nodes and per node on this one, wider
# along y with the same cells: a surface net's springs (stretch and bending) give
# a membrane whose stiffness does not depend on the edge length, so they stay; the mass and the
# ties to the core are per area (docs/suturing.md, "The pad's net size and the step").
PAD_HALF = (0.012, 0.04 / 3, 0.004)  # m: 24 x 26.7 x 8 mm: the needle's tip starts 4.5 mm inside
                                 # the pad's edge (y), 2.5 mm with its hand 2 mm off
                                 # (docs/suturing.md, "A tunnel at the pad's edge")
PAD_SUBDIVISIONS = (12, 16, 2)   # per axis: the top and bottom faces a 13 x 17 grid (2 x 1.67 mm
                                 # on the top), the sides 3 rows of 2.7 mm (the needle meets the top
                                 # face alone)
PAD_NODES = ((PAD_SUBDIVISIONS[0] + 2) * (PAD_SUBDIVISIONS[1] + 2) * (PAD_SUBDIVISIONS[2] + 2)
             - PAD_SUBDIVISIONS[0] * PAD_SUBDIVISIONS[1] * PAD_SUBDIVISIONS[2])
PAD_REFERENCE_NODES = 1442       # the constants' pad: (23, 23, 2), 70 mg, 100 N/m and 0.17 N s/m a node
PAD_FIRST_NODES = 496            # the 24 x 20 mm pad (12, 12, 2) its constants were first kept per area on:
                                 # the wider pad keeps them per node (the top face's cells the same)
PAD_MASS = 7e-5 * PAD_REFERENCE_NODES * PAD_NODES / PAD_FIRST_NODES  # kg
PAD_TIE_STIFFNESS = 100.0 * PAD_REFERENCE_NODES / PAD_FIRST_NODES  # N/m a node: the same per area
PAD_TIE_DAMPING = 0.17 * PAD_REFERENCE_NODES / PAD_FIRST_NODES     # N s/m a node

# ---- the pass: the needle's plane normal to the arc's axis N, tilted ALPHA from horizontal
ALPHA = math.radians(20.0)     # the shafts come down at 20 deg from the horizontal, from +x
CENTRE_HEIGHT = 0.5            # the arc's centre above the pad, in units of R cos(ALPHA)
SHAFT = 0.15                   # m from the trocar to the grip
JAW_GRIP = 0.009               # m from the jaws' hinge to the wire along the shaft
TIP_START = math.radians(-10.0)# β of the tip at the start (β: angle in the needle's plane, below)
GRIP_R = math.radians(165.0)   # the right driver's grip: β_tip + 165 deg (15 deg from the tail)
TURN_R = math.radians(165.0)   # the right driver's turn: the tip 25 deg past the exit
GRIP_L = math.radians(8.0)     # the left driver's grip: 8 deg behind the tip
TURN_L = math.radians(165.0)   # the left driver's turn: the tail past the exit, the needle out
KNOT = math.radians(5.0)       # path knots every 5 deg of turn
PASSES = 2                     # suture passes, each through its own entry and exit mark
PASS_SPACING = 0.006           # m between the passes' arcs, along the wound (x)
DRAW = 0.06                    # m: the left draws the needle back along its shaft after a pass but the
                               # last, pulling through thread enough for the next (0.02: 38 N on it)
PERTURB = 0.002                # m: the perturbed runs' largest offset of a path on each coordinate
PERTURB_WAVES = 3              # sines a coordinate
PERTURB_BAND = (0.2, 1.0)      # Hz: their frequencies (slow, as a hand's drift, not a tremor)
LIFT = 0.010                   # m: the arc's centre above a pass's start at the hand-back between passes
TURN_RATE = math.radians(60.0) # rad/s: the tip at 8.7 mm/s (JIGSAWS suturing's tool tips: up to 0.3 m/s)

JAW_SPHERES = 10               # a jaw's spheres: 1 mm apart, so that they hold the 0.7 mm wire
OPEN = math.radians(60.0)
CLOSED = math.radians(12.0)    # the jaws meet the 0.7 mm wire at about 24 deg JAW_GRIP from the hinge
JAW_TIME = 0.15


# ---- small vector and quaternion helpers (w, x, y, z)
def add(a, b): return tuple(x + y for x, y in zip(a, b))
def sub(a, b): return tuple(x - y for x, y in zip(a, b))
def mul(a, s): return tuple(x * s for x in a)
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
def norm(a): return math.sqrt(dot(a, a))
def unit(a): return mul(a, 1.0 / norm(a))


def qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


def qconj(q): return (q[0], -q[1], -q[2], -q[3])


def qrot(q, v): return qmul(qmul(q, (0.0, *v)), qconj(q))[1:]


def qaxis(axis, angle):
    a = unit(axis)
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), a[0] * s, a[1] * s, a[2] * s)


def qfrom_axes(x, y, z):
    """The rotation whose columns are x, y, z (right handed, orthonormal)."""
    m = ((x[0], y[0], z[0]), (x[1], y[1], z[1]), (x[2], y[2], z[2]))
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = 2 * math.sqrt(tr + 1)
        q = (0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s)
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = 2 * math.sqrt(1 + m[0][0] - m[1][1] - m[2][2])
        q = ((m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s)
    elif m[1][1] > m[2][2]:
        s = 2 * math.sqrt(1 + m[1][1] - m[0][0] - m[2][2])
        q = ((m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s)
    else:
        s = 2 * math.sqrt(1 + m[2][2] - m[0][0] - m[1][1])
        q = ((m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s)
    n = math.sqrt(sum(c * c for c in q))
    q = tuple(c / n for c in q)
    return q if q[0] >= 0 else tuple(-c for c in q)


def qlog(q):
    """The rotation vector of unit quaternion q (its shortest turn)."""
    if q[0] < 0:
        q = tuple(-c for c in q)
    v = q[1:]
    s = norm(v)
    if s < 1e-15:
        return (0.0, 0.0, 0.0)
    return mul(v, 2 * math.atan2(s, q[0]) / s)


# ---- the trocar: hal::TrocarKinematics::inverse_tool(), forward (the swing of the shaft). Its
# frame's z along the shafts (N_AXIS, below): the pivots stay near 0, well inside their ±1.2 rad.


def trocar_tool(trocar, hinge, wanted):
    """The tool pose the trocar gives for the hinge at `hinge` and orientation `wanted`: the
    shaft from the trocar through the hinge, the roll the twist of `wanted` about it."""
    u = unit(sub(hinge, trocar))
    uc = qrot(qconj(TROCAR_ORIENTATION), u)
    b = math.asin(max(-1.0, min(1.0, uc[0])))
    a = math.atan2(-uc[1], uc[2])
    swing = qmul(qmul(TROCAR_ORIENTATION, qaxis((1, 0, 0), a)), qaxis((0, 1, 0), b))
    rel = qmul(qconj(swing), wanted)
    psi = 2 * math.atan2(rel[3], rel[0])
    return qmul(swing, qaxis((0, 0, 1), psi))


# ---- the geometry of the pass
N_AXIS = (-math.cos(ALPHA), 0.0, -math.sin(ALPHA))   # the shafts' direction, trocar to jaws
E_Y = (0.0, 1.0, 0.0)                                 # in the needle's plane, horizontal
E_U = (-math.sin(ALPHA), 0.0, math.cos(ALPHA))        # in the needle's plane, up
# The marks: where the arc about MARK_CENTRE meets the pad's top; the drivers' scripts turn the
# needle about that centre. A driver that holds the needle also looks at it (its servo,
# docs/suturing.md "The drivers' sight"): its hand is moved by what puts the needle's arc centre on
# the plan's, SERVO_AIM off it where it drives the needle through the pad. The tip dents the surface
# by about 1.7 mm before it goes in and slides along it towards the exit, so that a needle turned
# about the marks' centre comes in 0.8 mm past its entry mark and 0.4 mm off its exit (measured with
# the servo on the centre): the aim, lower and back, is what an expert's eye learns.
MARK_CENTRE = (0.0, 0.0, CENTRE_HEIGHT * R * math.cos(ALPHA))
CENTRE = MARK_CENTRE
SERVO_AIM = (-0.0006, 0.0003, -0.0005)   # m: the servo's target, off the plan's arc centre, in the passes
SERVO_LATENCY = 0.002          # s: the eye and hand's delay (docs/suturing.md: 20 ms gave 15 of 20, 150 ms none)
SERVO_TIME_CONSTANT = 0.05     # s: the correction's integral time constant
SERVO_MAX_OFFSET = 0.004       # m: the largest correction of a hand
GRIP_MAX_FORCE = 15.0           # N: the pull past which a driver's grip on the needle slips: a needle
                               # driver's locked jaws hold the needle against the thread drawn through the
                               # pad (3-7 N in the perturbed runs); the default 5 N let it slip there
TUBE_HINGE = (0.0, 0.0, 0.04)  # m: the jaws' hinge (the tool frame) in the shaft body's frame
                               # (make_peg_transfer.instrument(): the tube 40 mm behind it)


Z_BODY = cross(E_U, E_Y)                              # the needle's +z: advancing turns about it
TROCAR_ORIENTATION = qfrom_axes(E_Y, cross(N_AXIS, E_Y), N_AXIS)


def on_circle(beta, centre=CENTRE):
    return add(centre, mul(add(mul(E_Y, math.cos(beta)), mul(E_U, math.sin(beta))), R))


def tangent(beta):
    """The arc's unit tangent at β, towards the tip (β decreasing)."""
    return add(mul(E_Y, math.sin(beta)), mul(E_U, -math.cos(beta)))


def crossing(sign):
    """β where the circle crosses the pad's top (z = 0): the entry (sign -1: nearer the start)
    and the exit (sign +1)."""
    s = -CENTRE[2] / (R * math.cos(ALPHA))
    b = math.asin(s)                      # in (-90, 0) deg: the entry side
    return b if sign < 0 else -math.pi - b


BETA_ENTRY, BETA_EXIT = crossing(-1), crossing(+1)
# The passes' arc centres: the second PASS_SPACING along +x (towards the trocars), a running
# suture's next stitch along the wound (the marks' line, y, crosses it).
CENTRES = [add(CENTRE, (k * PASS_SPACING, 0.0, 0.0)) for k in range(PASSES)]
ENTRY_MARKS = [on_circle(BETA_ENTRY, c) for c in CENTRES]
EXIT_MARKS = [on_circle(BETA_EXIT, c) for c in CENTRES]

# The needle's pose at the start: body x towards the arc's middle (β_tip + 90 deg), z = Z_BODY.
NEEDLE_X = unit(add(mul(E_Y, math.cos(TIP_START + math.pi / 2)), mul(E_U, math.sin(TIP_START + math.pi / 2))))
NEEDLE_Q0 = qfrom_axes(NEEDLE_X, cross(Z_BODY, NEEDLE_X), Z_BODY)
NEEDLE_CENTRE_LOCAL = (-2 * R / math.pi, 0.0, 0.0)    # the circle's centre in the body frame (φ = π)
NEEDLE_P0 = sub(CENTRE, qrot(NEEDLE_Q0, NEEDLE_CENTRE_LOCAL))


def jaw_frame(grip_beta, centre=CENTRE):
    """The jaws' wanted frame holding the wire at β: z along the shafts (N_AXIS), x along the wire,
    the hinge JAW_GRIP behind the wire along z."""
    g = on_circle(grip_beta, centre)
    x = tangent(grip_beta)
    x = unit(sub(x, mul(N_AXIS, dot(x, N_AXIS))))
    q = qfrom_axes(x, cross(N_AXIS, x), N_AXIS)
    return sub(g, mul(N_AXIS, JAW_GRIP)), q


def trocar_for(grip_beta):
    """The trocar SHAFT behind the wire at β along the shafts' direction."""
    return sub(on_circle(grip_beta), mul(N_AXIS, SHAFT + JAW_GRIP))


def carried_path(trocar, grip_beta, poses, centre=CENTRE):
    """The knots (hinge position, orientation, the needle's arc centre there) of a driver that holds the wire at β of the needle
    whose arc is about `centre` (at turn 0), carrying the needle through `poses`: each (arc
    centre, turn), the needle turned about its arc's axis by `turn` (the tip advancing) and moved
    so that its arc is about that centre. Each knot is the rigid motion mapped onto the trocar (its
    roll; the hinge moved so that the arc's centre the jaws carry is the pose's)."""
    hinge0, q0 = jaw_frame(grip_beta, centre)
    centre_in_jaws = qrot(qconj(q0), sub(centre, hinge0))
    knots = []
    for c, turn in poses:
        turn_q = qaxis(Z_BODY, turn)
        wanted_q = qmul(turn_q, q0)
        hinge = add(c, qrot(turn_q, sub(hinge0, centre)))
        for _ in range(20):  # move the hinge until the centre the jaws carry is c
            q = trocar_tool(trocar, hinge, wanted_q)
            hinge = add(hinge, sub(c, add(hinge, qrot(q, centre_in_jaws))))
        knots.append((hinge, trocar_tool(trocar, hinge, wanted_q), c))
    return knots


def turned_path(trocar, grip_beta, turn, centre=CENTRE):
    """The knots of a driver that holds the wire at β (at turn 0) and turns the needle about its
    arc's axis (about `centre`) by `turn` (the tip advancing), in KNOT steps."""
    steps = max(1, int(round(abs(turn) / KNOT)))
    return carried_path(trocar, grip_beta, [(centre, turn * k / steps) for k in range(steps + 1)], centre)


TROCAR_R = trocar_for(TIP_START + GRIP_R - TURN_R / 2)
TROCAR_L = trocar_for(TIP_START - TURN_R + GRIP_L - TURN_L / 2)


def qexp(v):
    """The unit quaternion of rotation vector v."""
    a = norm(v)
    return qaxis(v, a) if a > 1e-15 else (1.0, 0.0, 0.0, 0.0)


class Path:
    """A device's scripted path: line and hold segments (each with its orientation and the spin
    to the next), as absolute times. `tube`: the instrument's shaft body, which the hand watches
    when it comes to take the needle."""

    def __init__(self, start, q, tube):
        self.t, self.at, self.q, self.segments = 0.0, start, q, []
        self.start = (start, q)
        self.tube = tube

    def move(self, to, q, duration, jaw=None, servo=None):
        """A line to `to` with orientation `q`; `servo`: where the needle's arc centre should be
        at its end (the servo's target; none: the hand does not look), or (target, body, point,
        from) for another body's point, from `from` at the segment's start (None: as the parser
        takes it)."""
        spin = mul(qlog(qmul(q, qconj(self.q))), 1.0 / duration)
        self.segments.append(("line", to, self.q, spin, duration, jaw, servo))
        self.t, self.at, self.q = self.t + duration, to, q

    def hold(self, duration, jaw=None, servo=None):
        self.segments.append(("hold", None, self.q, None, duration, jaw, servo))
        self.t += duration

    def until(self, t, servo=None):
        if t > self.t + 1e-9:
            self.hold(t - self.t, servo=servo)

    def follow(self, knots, duration=KNOT / TURN_RATE, aim=None):
        """Along `knots` (carried_path()); with `aim`, looking at the needle: its arc centre on
        each knot's, moved by `aim`."""
        for hinge, q, c in knots[1:]:
            self.move(hinge, q, duration, servo=add(c, aim) if aim is not None else None)

    def travel(self, trocar, to, q, duration):
        """To `to` with orientation `q` (its roll about the shaft) in knots of at most 0.1 s, each
        the straight line's point with the orientation's share of the turn, as the trocar gives
        it."""
        steps = max(1, int(math.ceil(duration / 0.1 - 1e-9)))
        frm, q_from = self.at, self.q
        turn = qlog(qmul(q, qconj(q_from)))
        for k in range(1, steps + 1):
            s = k / steps
            hinge = add(frm, mul(sub(to, frm), s))
            wanted = trocar_tool(trocar, hinge, qmul(qexp(mul(turn, s)), q_from))
            self.move(hinge, wanted, duration / steps)


def vec(v):
    return "[" + ", ".join(f"{c:.6f}" for c in v) + "]"


def hand_over(taker, giver, knot, giver_servo=None):
    """`taker` comes in along its shaft to `knot` (hinge, orientation, ...) over the wire and
    closes; `giver` then opens and draws back 20 mm along its shaft; `taker` waits for it. With
    `giver_servo`, the giver holds the needle's arc centre there by sight until it has let go."""
    hinge, q = knot[:2]
    # The taker looks at its own instrument: its jaws' hinge (TUBE_HINGE on its shaft) where the
    # plan closes them on the wire, which the giver holds where the plan has it.
    approach = add(hinge, mul(N_AXIS, -0.004))
    taker.move(approach, q, 0.6, servo=(approach, taker.tube, TUBE_HINGE, taker.at))
    taker.move(hinge, q, 0.4, servo=(hinge, taker.tube, TUBE_HINGE, approach))
    giver.until(taker.t, servo=giver_servo)  # (not while both hold it: the two would pull it apart)
    taker.hold(0.3, CLOSED, servo=(hinge, taker.tube, TUBE_HINGE, None))
    giver.until(taker.t)
    giver.hold(0.3, OPEN)
    giver.move(add(giver.at, mul(N_AXIS, -0.02)), giver.q, 0.5)
    taker.until(giver.t)


def paths():
    """The two drivers' paths through PASSES passes."""
    tip_after = TIP_START - TURN_R
    right_knots = turned_path(TROCAR_R, TIP_START + GRIP_R, TURN_R)
    left_knots = turned_path(TROCAR_L, tip_after + GRIP_L, TURN_L)
    # Right: closes on the needle where it lies, turns it through the pad, opens, draws back.
    right = Path(*right_knots[0][:2], tube="tube_r")
    right.hold(0.2)
    right.hold(0.3, CLOSED)
    for k, centre in enumerate(CENTRES):
        if k > 0:
            right_knots = turned_path(TROCAR_R, TIP_START + GRIP_R, TURN_R, centre)
            left_knots = turned_path(TROCAR_L, tip_after + GRIP_L, TURN_L, centre)
            # The hand-back, over the next pass's start with its arc's centre LIFT up (the arc
            # clear of the pad) and the needle half a turn from its start (the tip towards the
            # exit's side): there the left's grip near the tip and the right's near the tail keep
            # the shafts apart (held as at the start, they would cross). The left draws the needle
            # back DRAW along its shaft (the thread pulled through), carries it there turning it on
            # (the tail over the top) and holds; the right comes over the wire near the tail as the
            # left did near the tip and closes; the left opens and draws back; the right turns the
            # needle half a turn back (the tail over the top again, so that the thread it trails
            # unwinds rather than wraps round the arc) and puts it down at the start.
            previous = CENTRES[k - 1]
            back = add(previous, mul(N_AXIS, -DRAW))
            lifted = add(centre, (0.0, 0.0, LIFT))
            handback = math.pi - TURN_R      # the left's turn of the hand-back pose (tip at TIP_START + pi)
            while handback < TURN_L:
                handback += 2 * math.pi
            steps = max(1, int(round(abs(handback - TURN_L) / KNOT)))
            poses = [(previous, TURN_L), (back, TURN_L)]
            poses += [(add(back, mul(sub(lifted, back), i / steps)), TURN_L + (handback - TURN_L) * i / steps)
                      for i in range(1, steps + 1)]
            carry = carried_path(TROCAR_L, tip_after + GRIP_L, poses, previous)
            left.follow(carry[:2], 0.5)
            left.follow(carry[1:], KNOT / TURN_RATE)
            over = carried_path(TROCAR_R, TIP_START + GRIP_R,
                                [(lifted, math.pi - math.pi * i / 36) for i in range(37)] +
                                [(add(lifted, mul(sub(centre, lifted), i / 5)), 0.0) for i in range(1, 6)],
                                centre)
            rh, rq = over[0][:2]
            right.until(left.t)
            right.travel(TROCAR_R, add(rh, mul(N_AXIS, -0.03)), rq, 1.5)
            hand_over(right, left, over[0], giver_servo=lifted)
            right.follow(over[:37], aim=SERVO_AIM)
            right.follow(over[36:], 0.1, aim=SERVO_AIM)
        right.follow(right_knots, aim=SERVO_AIM)
        t_out = right.t
        # Left: waits away from the pass, comes over the wire near the tip, closes, then turns.
        lh, lq = left_knots[0][:2]
        if k == 0:
            left = Path(add(lh, mul(N_AXIS, -0.03)), lq, tube="tube_l")
        else:
            left.travel(TROCAR_L, add(lh, mul(N_AXIS, -0.03)), lq, 1.0)
        left.until(t_out - 1.0)
        hand_over(left, right, left_knots[0])
        left.follow(left_knots, aim=SERVO_AIM)
    left.move(add(left.at, mul(N_AXIS, -0.02)), left.q, 0.5)
    right.until(left.t + 0.5)
    left.until(left.t + 0.5)
    return right, left


def device_block(name, trocar, path, node, cob, attach=None):
    out = device_header(name, node, cob, attach, trocar, vec(TROCAR_ORIENTATION))
    start, q = path.start
    out += f"""
[device.trajectory]
source = "scripted"
start = {{ position = {vec(start)}, orientation = {vec(q)}, jaw = {OPEN:.6f} }}
"""
    if any(segment[6] is not None for segment in path.segments):
        out += f"""
[device.trajectory.servo]   # the hand looks at the needle it holds: its arc centre on each segment's servo_target
body = "needle"
point = {vec(NEEDLE_CENTRE_LOCAL)}   # the arc's centre in the needle's body frame
latency = {SERVO_LATENCY}
time_constant = {SERVO_TIME_CONSTANT}
max_offset = {SERVO_MAX_OFFSET}
"""
    for kind, to, q, spin, duration, jaw, servo in path.segments:
        out += f"[[device.trajectory.segment]]\ntype = \"{kind}\"\n"
        if kind == "line":
            out += f"to = {vec(to)}\n"
        out += f"duration = {duration:.6f}\norientation = {vec(q)}\n"
        if spin is not None and norm(spin) > 0:
            out += f"angular_velocity = {vec(spin)}\n"
        if jaw is not None:
            out += f"jaw = {jaw:.6f}\njaw_time = {JAW_TIME}\n"
        if servo is not None and len(servo) == 4 and isinstance(servo[1], str):
            target, body, point, frm = servo
            out += f"servo_target = {vec(target)}\nservo_body = \"{body}\"\nservo_point = {vec(point)}\n"
            if frm is not None:
                out += f"servo_from = {vec(frm)}\n"
        elif servo is not None:
            out += f"servo_target = {vec(servo)}\n"
    return out


HEADER = """# numen suturing: two suture passes (docs/suturing.md, "The suturing scene") — a tissue pad with
# an entry and an exit mark for each, the 26 mm half-circle needle (puncture threshold 1 N) with a 3-0 silk
# thread tied to its tail, two needle drivers (trocar instruments whose jaws have ten 1.5 mm
# spheres 1 mm apart, so that they hold a 0.7 mm wire) on two devices. Written by
# sim/data/make_suturing.py (its whole provenance; edit that and regenerate, not this file).
#
# The right driver holds the needle near its tail and rolls it about the arc's own axis: the tip
# punctures the pad at the entry mark, runs under the surface and comes out at the exit mark; the
# left driver takes the wire near the tip, the right lets go and draws back, the left rolls the
# needle on until its tail has left the pad. The left then hands the needle back to the right over
# the second pass's marks, 6 mm along the wound, and the pass is made again there. Each driver
# looks at the needle it holds and moves its hand until the needle's arc centre is where its
# script wants it (its [device.trajectory.servo], each segment's servo_target). The summary's
# needle figures (docs/outputs.md, `needle.*`): punctures, exits, tunnels, the tip force at the
# puncture against its threshold, the deviation from the arc, each pass's entry and exit errors
# from its marks.
"""


def perturbed(text, seed):
    """`text` with each device's path moved by a smooth offset of at most ±2 mm on each
    coordinate (PERTURB_WAVES sines a coordinate, frequencies in PERTURB_BAND, random phases and
    weights, seeded): every knot (`to = [...]` of a line segment) by the offset at its time, so
    that the perturbed paths keep the recordings' speeds (at most 2 pi f 2 mm = 13 mm/s added);
    ramped in over the first second (the needle starts in the right's jaws)."""
    rng = random.Random(seed)
    lines, out = text.split("\n"), []
    offset, t, pending = None, 0.0, None
    for line in lines:
        if line.startswith("[device.trajectory]"):
            waves = [[(rng.uniform(*PERTURB_BAND), rng.uniform(0, 2 * math.pi), rng.uniform(0.5, 1.0))
                      for _ in range(PERTURB_WAVES)] for _ in range(3)]
            offset = lambda t, w=waves: tuple(  # noqa: E731  ramped in over the first second
                PERTURB * min(1.0, t) * sum(a * math.sin(2 * math.pi * f * t + ph) for f, ph, a in c) / sum(a for _, _, a in c)
                for c in w)
            t = 0.0
        if offset and line.startswith("to = ["):
            pending = len(out)
        if offset and line.startswith("duration = "):
            t += float(line.split("=")[1])
            if pending is not None:
                p = [float(v) for v in out[pending][len("to = ["):-1].split(",")]
                out[pending] = "to = " + vec(add(p, offset(t)))
                pending = None
        out.append(line)
    return "\n".join(out)


def scene():
    right, left = paths()
    duration = max(right.t, left.t)
    out = [HEADER, f"""name = "suturing"
description = "Two suture passes through a tissue pad: the needle driven along its arc from an entry mark to an exit mark by one trocar needle driver, handed to the other, pulled through with its thread, handed back and driven through the next pair of marks"
dt = 0.001
gravity = [0.0, 0.0, 0.0]   # the needle is held from the first period: no weight to carry
integrator = "implicit-euler"
coupling = "god-object"
duration = {duration:.3f}

[solver]
tolerance = 1.0e-4
max_iterations = 100

[[material]]
name = "steel"

[[material]]
name = "tissue"

[contact_default]
stiffness = 2.0e4     # N/m per sphere contact
damping = 10.0        # N·s/m
friction = 0.5        # N·s/m, viscous tangential

# ---- the pad: a 24 x 26.7 x 8 mm box net (2 x 1.67 mm on its top face, 2.7 mm rows on its sides), each node tied to its rest place
# on an anchored core (the organ's constants per spring, as tests/core/needle_puncture_test.cpp's)

[[body]]
name = "pad_core"
mass = 0.1
inertia = [1.0e-4, 1.0e-4, 1.0e-4]
material = "tissue"
anchored = true
position = [0.0, 0.0, {-PAD_HALF[2]:.6f}]

[[deformable]]
name = "pad"
body = "pad_core"
mesh = "box"
half_extents = {vec(PAD_HALF)}
subdivisions = [{PAD_SUBDIVISIONS[0]}, {PAD_SUBDIVISIONS[1]}, {PAD_SUBDIVISIONS[2]}]   # x, y, z: {PAD_NODES} nodes
mass = {PAD_MASS:.6f}   # {PAD_MASS / PAD_NODES * 1e6:.0f} mg a node
stiffness = 200.0
damping = 0.1
bending_stiffness = 50.0
bending_damping = 0.03
tie_stiffness = {PAD_TIE_STIFFNESS:.1f}   # N/m a node: 100 on the 1 442-node pad, the same per area on the 24 x 20 mm pad of 496 nodes, kept per node
tie_damping = {PAD_TIE_DAMPING:.4f}
material = "tissue"

# ---- the needle: the 26 mm half circle, 0.7 mm wire; its marks where the arc meets the pad's top

[[needle]]
name = "needle"
material = "steel"
mass = {NEEDLE_MASS}   # kg: simulated (the wire's is 78 mg; docs/suturing.md, "The suturing scene")
position = {vec(NEEDLE_P0)}
orientation = {vec(NEEDLE_Q0)}
puncture_force = {PUNCTURE_FORCE}
entry_mark = [{", ".join(vec(m) for m in ENTRY_MARKS)}]   # one per pass
exit_mark = [{", ".join(vec(m) for m in EXIT_MARKS)}]

[[thread]]
name = "suture"
length = 0.15
segments = 100
material = "steel"
attach_body = "needle"
attach_point = {vec((-2 * R / math.pi, -R, 0.0))}   # the tail (the swage)
direction = [-0.957826, 0.0, 0.287348]   # pinned at the tail, away from the drivers over the pad: along the tail's tangent it would start through the pad

# ---- the needle drivers: the peg transfer's trocar-tube-jaws instrument with dense jaws
"""]
    out.append(instrument("r", JAW_SPHERES))
    out.append(instrument("l", JAW_SPHERES))
    out.append(device_block("right", TROCAR_R, right, 1, 0, attach="tube_r"))
    out.append(device_block("left", TROCAR_L, left, 6, 5))
    out.append(f"""
# ---- graspers: a grasp starts below 35 deg with both jaws on the wire (they meet it at about 24 deg)

[[grasp]]
name = "right_driver"
jaws = ["jaw_1_r", "jaw_2_r"]
close_angle_deg = 35.0
open_angle_deg = 45.0
stiffness = 2.0e4
grip_radius = 0.003
max_force = {GRIP_MAX_FORCE}
tissue = false

[[grasp]]
name = "left_driver"
jaws = ["jaw_1_l", "jaw_2_l"]
close_angle_deg = 35.0
open_angle_deg = 45.0
stiffness = 2.0e4
grip_radius = 0.003
max_force = {GRIP_MAX_FORCE}
tissue = false

[bus]
latency = 0.0001
drop_probability = 0.0
corruption_probability = 0.0
seed = 1
""")
    return "\n".join(out)


def main():
    args = sys.argv[1:]
    text = scene()
    if len(args) == 2 and args[0] == "--perturb":
        text = perturbed(text, int(args[1]))
    elif args:
        sys.exit("usage: make_suturing.py [--perturb SEED]")
    print(text, end="")


if __name__ == "__main__":
    main()
