#!/usr/bin/env python3
"""Latency of numen's OpenIGTLink loop: from a tracker's TRANSFORM sent to numen (`numen run
--bus igtl`) to the god-object's TRANSFORM that used it, sent by numen's world server (`--igtl`)
and received by a client: the path a tracked tool takes to 3D Slicer (docs/openigtlink.md,
"Figures"). A benchmark, not a test: run it by hand on a quiet machine.

    python3 tests/bench/igtl_loop_latency_bench.py [--numen build/numen] \
        [--scene sim/scenes/tracker.toml] [--rate 1000] [--duration 10] [--view-rate 1000]

This program is both ends, on loopback, on one clock (CLOCK_MONOTONIC): the tracker server
(the scene's tool, as PLUS sends it: device name and units of its [device.igtl], paced at
--rate on absolute deadlines and stamped with them on the wall clock) and the Slicer-side
client. The tool's pose is the first pose `numen igtl-replay` sends for the scene (a pose the
scene accepts), moved by 0.02 mm along the tracker's x every `toggle` messages (10 ms: every
10th message at 1 kHz, every message at 60 Hz) and back. Each move is one sample: from its
first message's send() to the recv() of the first world frame whose `<body>_target` TRANSFORM
(the ghost: the tracker's pose as the god-object step took it; the frame's god-object TRANSFORM
is in the same send) shows it. numen runs paced (`--realtime`), the state stream at
--view-rate (a frame every period at 1000 on a 1 kHz scene). Prints the samples' median, p99 and
max (µs) and numen's own summary figure of the received → applied part (igtl_latency_us), as
JSON with --json; fails (exit 1, with numen's stderr) when numen's run does not exit 0.
"""
import argparse
import json
import os
import re
import select
import socket
import statistics
import struct
import subprocess
import sys
import time

CRC_POLY = 0x42F0E1EBA9EA3693  # CRC-64 ECMA-182, as OpenIGTLink's igtl_crc64
CRC_TABLE = []
for i in range(256):
    c = i << 56
    for _ in range(8):
        c = ((c << 1) ^ CRC_POLY) if c & (1 << 63) else (c << 1)
    CRC_TABLE.append(c & 0xFFFFFFFFFFFFFFFF)


def crc64(data):
    c = 0
    for b in data:
        c = CRC_TABLE[((c >> 56) ^ b) & 0xFF] ^ ((c << 8) & 0xFFFFFFFFFFFFFFFF)
    return c


def transform_message(name, stamp_s, m):
    """A TRANSFORM (header version 1): m is the 3x4 [R t] as rows."""
    body = struct.pack(">12f", m[0][0], m[1][0], m[2][0], m[0][1], m[1][1], m[2][1],
                       m[0][2], m[1][2], m[2][2], m[0][3], m[1][3], m[2][3])
    sec = int(stamp_s)
    frac = int((stamp_s - sec) * 2**32) & 0xFFFFFFFF
    head = struct.pack(">H12s20sQQQ", 1, b"TRANSFORM", name.encode(), (sec << 32) | frac,
                       len(body), crc64(body))
    return head + body


def parse_messages(buf):
    """Whole messages out of buf: [(type, name, body)], rest."""
    out = []
    while len(buf) >= 58:
        size = struct.unpack(">Q", buf[42:50])[0]
        if len(buf) < 58 + size:
            break
        out.append((buf[2:14].rstrip(b"\0").decode(), buf[14:34].rstrip(b"\0").decode(),
                    buf[58:58 + size]))
        buf = buf[58 + size:]
    return out, buf


def matrix_of(body):
    f = struct.unpack(">12f", body[:48])
    return [[f[0], f[3], f[6], f[9]], [f[1], f[4], f[7], f[10]], [f[2], f[5], f[8], f[11]]]


def stderr_line(proc, pattern, timeout):
    """The first line of proc's stderr matching pattern (read unbuffered: the lines after it stay
    for communicate())."""
    end = time.monotonic() + timeout
    text = ""
    fd = proc.stderr.fileno()
    while time.monotonic() < end:
        r, _, _ = select.select([fd], [], [], 0.1)
        if not r:
            continue
        chunk = os.read(fd, 1)  # one byte at a time: nothing read past the line
        if not chunk:
            break
        text += chunk.decode(errors="replace")
        if text.endswith("\n"):
            m = re.search(pattern, text.splitlines()[-1])
            if m:
                return m
    sys.exit("no line matching %r from %s:\n%s" % (pattern, proc.args[1], text))


def first_replay_pose(numen, scene):
    """The tool's name and first pose as `numen igtl-replay` plays the scene."""
    proc = subprocess.Popen([numen, "igtl-replay", scene, "--port", "0", "--duration", "0.01"],
                            stderr=subprocess.PIPE, text=True)
    port = int(stderr_line(proc, r"listening on .*:(\d+)", 30).group(1))
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        buf = b""
        while True:
            msgs, buf = parse_messages(buf)
            if msgs:
                break
            chunk = s.recv(65536)
            if not chunk:
                sys.exit("numen igtl-replay sent nothing")
            buf += chunk
    proc.wait(timeout=30)
    _, name, body = msgs[0]
    return name, matrix_of(body)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--numen", default="build/numen")
    ap.add_argument("--scene", default="sim/scenes/tracker.toml")
    ap.add_argument("--rate", type=float, default=1000.0, help="tracker messages per second")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds of moves")
    ap.add_argument("--view-rate", type=float, default=1000.0, help="numen's --view-rate")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    name, pose = first_replay_pose(a.numen, a.scene)
    toggle = max(1, round(0.01 * a.rate))  # a move every 10 ms at most
    step_units = 0.02  # mm (the scene's units: PLUS's mm)

    tracker = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    tracker.bind(("127.0.0.1", 0))
    tracker.listen(1)
    tport = tracker.getsockname()[1]
    run_s = a.duration + 1.5  # the held pose 0.5 s, the moves, 1 s more of the held pose
    proc = subprocess.Popen([a.numen, "run", a.scene, "--bus", "igtl:127.0.0.1:%d" % tport,
                             "--realtime", "--duration", "%g" % run_s, "--igtl", "0",
                             "--view-rate", "%g" % a.view_rate, "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wport = int(stderr_line(proc, r"OpenIGTLink world on .*:(\d+)", 60).group(1))
    tracker.settimeout(30)
    conn, _ = tracker.accept()
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        world = socket.create_connection(("127.0.0.1", wport), timeout=10)
    except OSError as e:
        proc.kill()
        sys.exit("cannot reach numen's world (%s); numen's stderr:\n%s"
                 % (e, proc.communicate()[1]))
    world.setblocking(False)
    conn.setblocking(False)

    period = 1.0 / a.rate
    start = time.monotonic()
    wall0 = time.time()
    t0 = start + 0.5  # the moves start once numen has held the pose for 0.5 s
    k = 0
    moves = []  # (first message's send time, tracker x of the move)
    state_x = pose[0][3]
    buf = b""
    last_target = None
    seen = []  # (recv time, target position) at each change of the target
    events = []  # numen's STRING events (rejected samples, faults)
    while proc.poll() is None:  # the held pose until numen's run is over: it ends cleanly
        due = start + k * period
        now = time.monotonic()
        if now >= due:
            if due >= t0 and due < t0 + a.duration and k % toggle == 0:
                state_x = pose[0][3] + (step_units if (k // toggle) % 2 else 0.0)
                moved = True
            else:
                moved = False
            m = [row[:] for row in pose]
            m[0][3] = state_x
            msg = transform_message(name, wall0 + (due - start), m)  # stamped on the schedule
            try:
                conn.send(msg)
            except BlockingIOError:
                pass
            except (ConnectionResetError, BrokenPipeError):
                break  # numen's run ended
            if moved:
                moves.append((time.monotonic(), state_x))
            k += 1
            continue
        r, _, _ = select.select([world], [], [], max(0.0, min(due - now, 0.002)))
        if not r:
            continue
        try:
            chunk = world.recv(1 << 20)
        except (BlockingIOError, ConnectionResetError):
            continue
        t = time.monotonic()
        if not chunk:
            continue
        buf += chunk
        msgs, buf = parse_messages(buf)
        for typ, dev, body in msgs:
            if typ == "STRING":
                events.append(body[4:].decode(errors="replace"))
            if typ == "TRANSFORM" and dev.endswith("_target"):
                p = tuple(matrix_of(body)[i][3] for i in range(3))
                if last_target is None or max(abs(p[i] - last_target[i]) for i in range(3)) > 1e-3:
                    seen.append((t, p))
                last_target = p
    conn.close()
    out, err = proc.communicate(timeout=60)
    world.close()
    # Each move: the first target change received after it was sent (and before the next move).
    lat = []
    j = 0
    for i, (ts, _) in enumerate(moves):
        nxt = moves[i + 1][0] if i + 1 < len(moves) else float("inf")
        while j < len(seen) and seen[j][0] < ts:
            j += 1
        if j < len(seen) and seen[j][0] < nxt:
            lat.append((seen[j][0] - ts) * 1e6)
    if not lat or proc.returncode != 0:
        sys.exit("%d of %d moves came back; numen exit %d; its events: %s; its stderr:\n%s" %
                 (len(lat), len(moves), proc.returncode, events[:6], err))
    lat.sort()
    summary = json.loads(out) if out.strip().startswith("{") else {}
    figures = summary.get("figures", summary) if isinstance(summary, dict) else {}
    fig = {key: v for key, v in figures.items() if key.startswith("igtl_latency")}
    res = {"rate_hz": a.rate, "view_rate_hz": a.view_rate, "moves": len(moves),
           "samples": len(lat), "median_us": round(statistics.median(lat), 1),
           "p99_us": round(lat[min(len(lat) - 1, int(0.99 * len(lat)))], 1),
           "max_us": round(lat[-1], 1), "numen_exit": proc.returncode, "numen_figures": fig}
    if a.json:
        print(json.dumps(res))
    else:
        print("tracker %g Hz, stream %g Hz: %d moves, %d back; median %.0f us, p99 %.0f us, "
              "max %.0f us; numen exit %d; %s" % (a.rate, a.view_rate, len(moves), len(lat),
                                                  res["median_us"], res["p99_us"], res["max_us"],
                                                  proc.returncode, fig))


if __name__ == "__main__":
    main()
