"""A view recording given a net's fine surface (docs/viewer.md "Scene message", a net's
`surface`), for the browser test (viewer_browser_test.py): the scene keys that create fine
surfaces at load are not what it checks, so a recorded run's scene message gets one here.

The fine surface: each net triangle cut into a barycentric grid of `level` steps (vertices on the
net's edges and corners shared between its triangles), each vertex pushed out from its foot point
onto the sphere through the net's rest nodes (their mean distance from their mean), so that it
stands off the net as a user's rounder mesh would; the embeddings (triangle, weights, offset in
the triangle's frame) are computed at the first frame's node positions, the net's rest.
Python's standard library only.
"""
import json
import math
import struct

MAGIC = b"NMVREC01"


def read_recording(path):
    """(scene message as a dict, [frame bytes]) of a view recording."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != MAGIC:
        raise ValueError("%s: not a view recording" % path)
    (n,) = struct.unpack_from("<I", data, 8)
    scene = json.loads(data[12:12 + n])
    frames, off = [], 12 + n
    while off + 4 <= len(data):
        (n,) = struct.unpack_from("<I", data, off)
        frames.append(data[off + 4:off + 4 + n])
        off += 4 + n
    return scene, frames


def write_recording(path, scene, frames):
    """Writes a view recording of `scene` (dict) and `frames` (bytes each)."""
    text = json.dumps(scene, separators=(",", ":")).encode()
    with open(path, "wb") as f:
        f.write(MAGIC + struct.pack("<I", len(text)) + text)
        for fr in frames:
            f.write(struct.pack("<I", len(fr)) + fr)


def node_positions(frame):
    """The frame's node positions (docs/viewer.md "Frames"): [(x, y, z)] float32 as sent."""
    (header_bytes,) = struct.unpack_from("<H", frame, 6)
    num_bodies, num_nodes = struct.unpack_from("<II", frame, 12)
    off = header_bytes + 4 * (7 + 8) * num_bodies
    xs = struct.unpack_from("<%df" % (3 * num_nodes), frame, off)
    return [xs[3 * i:3 * i + 3] for i in range(num_nodes)]


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def unit(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def triangle_frame(x0, x1, x2):
    """(e1, e2, n) of a net triangle, as docs/viewer.md defines it; None if collapsed."""
    u, v = sub(x1, x0), sub(x2, x0)
    nn = cross(u, v)
    if dot(u, u) == 0 or dot(nn, nn) == 0:
        return None
    e1, n = unit(u), unit(nn)
    return e1, cross(n, e1), n


def fine_vertex(surface, i, x):
    """Fine vertex i of `surface` at the net's node positions x (net-local): the formula of
    docs/viewer.md, the weights divided by their sum."""
    f = surface["face"][i]
    c = [x[surface["net_triangles"][3 * f + k]] for k in range(3)]
    w = surface["weights"][3 * i:3 * i + 3]
    o = surface["offset"][3 * i:3 * i + 3]
    s = sum(w)
    p = [sum(w[m] / s * c[m][k] for m in range(3)) for k in range(3)]
    frame = triangle_frame(*c)
    if frame:
        for m in range(3):
            for k in range(3):
                p[k] += o[m] * frame[m][k]
    return p


def fine_surface(net, x, level):
    """The `surface` entry for `net` (a scene message's net entry) at its rest node positions x
    (net-local), its triangles cut into `level` steps (see the module comment)."""
    tris = [tuple(t) for t in net["triangles"]]
    centre = [sum(p[k] for p in x) / len(x) for k in range(3)]
    radius = sum(math.sqrt(dot(sub(p, centre), sub(p, centre))) for p in x) / len(x)
    ids, face, weights, offset, triangles = {}, [], [], [], []

    def vertex(f, i, j):
        """The fine vertex at grid point (i, j) of triangle f: weights ((L-i-j), i, j) / L."""
        t = tris[f]
        w = {t[0]: level - i - j, t[1]: i, t[2]: j}
        key = tuple(sorted((n, k) for n, k in w.items() if k))  # shared on edges and corners
        if key in ids:
            return ids[key]
        ids[key] = len(face)
        ws = [w[t[0]] / level, w[t[1]] / level, w[t[2]] / level]
        c = [x[t[0]], x[t[1]], x[t[2]]]
        foot = [sum(ws[m] * c[m][k] for m in range(3)) for k in range(3)]
        d = unit(sub(foot, centre))
        target = [centre[k] + radius * d[k] for k in range(3)]
        e1, e2, n = triangle_frame(*c)
        o = sub(target, foot)
        face.append(f)
        weights.extend(round(v, 6) for v in ws)
        offset.extend(round(dot(o, e), 7) for e in (e1, e2, n))
        return ids[key]

    for f in range(len(tris)):
        for i in range(level):
            for j in range(level - i):
                a, b, c = vertex(f, i, j), vertex(f, i + 1, j), vertex(f, i, j + 1)
                triangles.extend((a, b, c))
                if i + j < level - 1:
                    triangles.extend((b, vertex(f, i + 1, j + 1), c))
    return {"point_count": len(face), "triangle_count": len(triangles) // 3,
            "net_triangles": [k for t in tris for k in t], "face": face, "weights": weights,
            "offset": offset, "triangles": triangles}


def add_fine_surface(src, dst, net_name, level=6):
    """Copies the view recording `src` to `dst` with a fine surface on the net named `net_name`
    (embedded at the first frame); returns (the surface, the recording's frames)."""
    scene, frames = read_recording(src)
    net = next(n for n in scene["nets"] if n["name"] == net_name)
    x = node_positions(frames[0])[net["node_begin"]:net["node_begin"] + net["node_count"]]
    net["surface"] = fine_surface(net, x, level)
    write_recording(dst, scene, frames)
    return net, frames
