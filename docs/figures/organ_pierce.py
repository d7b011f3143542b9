#!/usr/bin/python3
"""Piercing check of a deformable organ on numen-view recordings (docs/organs.md, "The rigid core").

    ./build/numen run [SCENE] [--replay] --record-view run.nmv --view-rate 100
    /usr/bin/python3 docs/figures/organ_pierce.py [--every N] run.nmv ...

For every N-th recorded frame (docs/viewer.md, "Recording file": body poses and node positions
as float32), every collision sphere of every body (the scene message's spheres, placed by the
frame's body pose) is tested against the recording's first net: a sphere centre inside the net's
closed deformed surface through the node centres (winding number of its triangles, |w| > 0.5)
has pierced the net. The first frame's nodes are the rest shape; a centre's depth below the rest
surface is its distance to the nearest rest node (exact to within half an edge). Prints, per
file, one JSON object: frames tested, pierced frames, the first pierced time, and the same after
the first 0.1 s (the start-up, where a trial may start with the instrument inside the organ),
the deepest sphere centre below the rest surface (all frames, and after 0.1 s). Needs NumPy.
"""
import argparse
import json
import struct

import numpy as np

START_UP_S = 0.1


def frames(path):
    """Yields (scene message, frame bytes) of a numen-view recording."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"NMVREC01":
        raise SystemExit("%s: not a numen-view recording" % path)
    n = struct.unpack_from("<I", data, 8)[0]
    scene = json.loads(data[12:12 + n])
    off = 12 + n
    while off < len(data):
        m = struct.unpack_from("<I", data, off)[0]
        yield scene, data[off + 4:off + 4 + m]
        off += 4 + m


def rotate(q, v):
    """v rotated by the unit quaternion q = (x, y, z, w)."""
    u, w = q[:3], q[3]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def winding(points, verts, tris):
    """Winding number of the closed triangle surface (verts, tris) about each point."""
    a0, b0, c0 = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    out = np.empty(len(points))
    for i, p in enumerate(points):
        a, b, c = a0 - p, b0 - p, c0 - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
               + np.einsum("ij,ij->i", c, a) * lb)
        out[i] = 2.0 * np.arctan2(num, den).sum() / (4.0 * np.pi)
    return out


def check(path, every):
    rest = None
    r = {"frames": 0, "pierced_frames": 0, "first_pierced_s": None, "late_frames": 0,
         "late_pierced": 0, "deepest_sphere_below_rest_mm": None, "late_deepest_below_rest_mm": None}
    deepest, late_deepest = -np.inf, -np.inf
    for k, (scene, fr) in enumerate(frames(path)):
        if rest is not None and k % every:
            continue
        header = struct.unpack_from("<H", fr, 6)[0]  # docs/viewer.md "Frames": header_bytes
        bodies, nodes = struct.unpack_from("<II", fr, 12)
        t = struct.unpack_from("<q", fr, 40)[0] * 1e-9
        # body_pose (7 floats a body), target_pose (8 a body), then node_position.
        pose = np.frombuffer(fr, "<f4", 7 * bodies, header).reshape(bodies, 7).astype(float)
        x = np.frombuffer(fr, "<f4", 3 * nodes, header + 60 * bodies).reshape(nodes, 3).astype(float)
        if rest is None:
            net = scene["nets"][0]
            begin = net["node_begin"]
            count = net["node_count"]
            tris = np.array(net["triangles"])
            rest = x[begin:begin + count].copy()
            spheres = [(i, np.array(s[:3])) for i, b in enumerate(scene["bodies"]) for s in b.get("spheres", [])]
            lo, hi = rest.min(0) - 0.01, rest.max(0) + 0.01
        late = t >= START_UP_S
        r["frames"] += 1
        r["late_frames"] += late
        pts = np.array([pose[i, :3] + rotate(pose[i, 3:], c) for i, c in spheres])
        pts = pts[np.all((pts > lo) & (pts < hi), axis=1)]  # near the organ only
        if not len(pts):
            continue
        inside_rest = np.abs(winding(pts, rest, tris)) > 0.5
        nearest = np.min(np.linalg.norm(pts[:, None, :] - rest[None], axis=2), axis=1)
        depth = np.where(inside_rest, nearest, -nearest).max()
        deepest = max(deepest, depth)
        if late:
            late_deepest = max(late_deepest, depth)
        if inside_rest.any() and (np.abs(winding(pts[inside_rest], x[begin:begin + count], tris)) > 0.5).any():
            r["pierced_frames"] += 1
            r["late_pierced"] += late
            if r["first_pierced_s"] is None:
                r["first_pierced_s"] = round(t, 4)
    r["deepest_sphere_below_rest_mm"] = round(1e3 * deepest, 2) if np.isfinite(deepest) else None
    r["late_deepest_below_rest_mm"] = round(1e3 * late_deepest, 2) if np.isfinite(late_deepest) else None
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--every", type=int, default=1, help="test every N-th frame (default 1)")
    ap.add_argument("recordings", nargs="+")
    a = ap.parse_args()
    for path in a.recordings:
        print(path, json.dumps(check(path, a.every)), flush=True)


if __name__ == "__main__":
    main()
