#!/usr/bin/python3
"""Browser test of the viewer (docs/viewer.md "Tests"), run by CTest as viewer_browser.

Records a run of a scene (`numen run --duration D --record-view F.nmv`), serves it with
`numen view F.nmv --port 0`, and drives the page in headless Chromium (SwiftShader WebGL) over
the DevTools protocol (cdp.py: --remote-debugging-pipe, real time). For each scene it shows the
frame where the hand goes deepest (?frame=I, paused), takes a screenshot and checks it with PIL:
  - the page shows the frame and logged no JavaScript error (its own error list and
    Chromium's runtime exceptions and console errors);
  - the tool's colour appears where the page's camera projects the tool's spheres, and the
    ghost's colour where it projects the ghost's (the hand's target pose), and most of the
    tool-coloured pixels lie on the tool's projection.
On the lattice scene (the default scene's instrument with a rigid organ) also:
  - the favicon is served, and the page opened as file:// says how to serve it;
  - the camera (following the tool, as by default) keeps the tool's projected position inside
    the canvas on 60 frames spread over the whole recording;
  - reconnect: `numen view` is killed, the page says the connection is lost, `numen view` is
    started again on the same port, and the page shows a frame again within RECONNECT_S;
Live (`numen run --view 0 --wait-for-viewer`): the page gets every frame from period 0; paused,
it holds its frame while frames keep arriving, steps back, scrubs and returns to live.
On a 2 s run of tests/data/mesh_body.toml (a probe pushing a free body whose shape is a mesh):
  - the body is drawn as its mesh (every triangle sent), in its grey where the surface's middle
    projects, and the surface moves with the body from the first frame to the last.
On a run of tests/data/node_contacts.toml whose recording is given a fine surface on the organ's
net (fine_surface_recording.py):
  - the organ is drawn as its fine surface (every triangle sent), in the net's green where its
    middle projects, with the coarse net hidden until its toggle shows it; the page's fine
    vertices are where the formula of docs/viewer.md puts them from the frame's node positions.
On 5 s of the default scene (its organ given by its material, a 500-node net):
  - the page draws the tool's dimple in the organ (more than 1 mm), and no drawn vertex of the
    organ is inside a sphere of another body.
On a run that latches a fault (the lattice scene on a bus losing 30 % of its frames):
  - the fault banner shows, with its cause, and the replay timeline has its mark.

On the default scene with a grasper on its jaws (7.3 s of the recording, which grasps the organ):
  - the timeline marks each grasp and release, and at the grasp's frame the panel names what
    the grasper holds.
On 0.3 s of the two-device bimanual scene:
  - the panel has a line for the second device ("right"): its state, feedback force and the
    torques sent to its axes.
On 1 s of the suturing scene (issue 69):
  - the needle is drawn as its arc (a shape of its body, not its spheres) and the thread as its
    100 segments through its 101 nodes, its first node at the needle's tail.
Exit 0: passed; 1: failed; 77: skipped, only when Chromium or the Python module PIL
(python3-pil) is not installed.

    tests/sim/view/viewer_browser_test.py --numen build/numen --out DIR \\
        [--scene FILE] [--figure PNG]
    tests/sim/view/viewer_browser_test.py --numen build/numen --out DIR --figures docs/figures
        (the screenshots of docs/viewer.md: default, lattice, construction, deformable)
"""
import argparse
import colorsys
import math
import os
import re
import shutil
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cdp  # noqa: E402
import fine_surface_recording  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
FIGURE_SCENES = [("default", None), ("lattice", "sim/scenes/lattice.toml"),
                 ("construction", "sim/scenes/construction.toml"), ("deformable", "sim/scenes/deformable.toml")]
# The scene of the test run by CTest: the lattice scene (the default scene's instrument, hand and
# recording with a rigid organ; a few µs a step against the default scene's net, ~60x that).
LATTICE = os.path.join(ROOT, "sim", "scenes", "lattice.toml")
INSTRUMENT = ("default", "lattice")  # the scenes of the articulated instrument and the hand
# A probe pushing a free body whose shape is a mesh (docs/meshes.md "Mesh bodies"): its whole 2 s.
MESH_BODY = os.path.join(ROOT, "tests", "data", "mesh_body.toml")
MESH_BODY_S = 2.0
# A probe pressed into a small icosphere organ (tests/data/node_contacts.toml, its 0.6 s), given a
# fine surface on the organ's net (fine_surface_recording.py).
FINE_SURFACE_SCENE = os.path.join(ROOT, "tests", "data", "node_contacts.toml")
WIDTH, HEIGHT = 1200, 760  # the window
VIEW_W, VIEW_H = 860, 760  # the 3D view in it (the rest: the side panel)
RECONNECT_S = 5.0          # the page resumes within this after the server is back (backoff ≤ 2 s)


def chromium_path():
    for name in ("chromium", "chromium-browser"):
        p = shutil.which(name)
        if p:
            return p
    return None


def is_tool(p):
    h, s, v = colorsys.rgb_to_hsv(p[0] / 255, p[1] / 255, p[2] / 255)
    return 18 / 360 <= h <= 48 / 360 and s > 0.5 and v > 0.25


def is_ghost(p):
    return p[2] - p[0] > 40 and p[2] > 90


def count_in_discs(img, discs, pred, grow=1.0, extra=0.0):
    """Pixels satisfying `pred` within the union of `discs` (x, y, r) scaled by grow, + extra."""
    w, h = img.size
    px = img.load()
    seen = set()
    for d in discs:
        r = max(3.0, d["r"] * grow + extra)
        for y in range(max(0, int(d["y"] - r)), min(h, int(d["y"] + r) + 1)):
            for x in range(max(0, int(d["x"] - r)), min(w, int(d["x"] + r) + 1)):
                if (x - d["x"]) ** 2 + (y - d["y"]) ** 2 <= r * r and (x, y) not in seen:
                    seen.add((x, y))
    return sum(1 for (x, y) in seen if pred(px[x, y]))


def count_all(img, pred):
    """Pixels of the 3D view (not the side panel: its legend and plots use the same colours)."""
    return sum(1 for p in img.crop((0, 0, VIEW_W, VIEW_H)).getdata() if pred(p))


def deepest_hand_frame(path):
    """Index of the frame of a view recording (docs/viewer.md "Recording file") where the hand
    (target) goes deepest below the tool: hand penetration - tool penetration, the frame's
    `penetration` array, the last but one (the `device_loop` array's 3 float32 follow it).
    There the ghost stands apart from the tool."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:8] == b"NMVREC01", path
    (n,) = struct.unpack_from("<I", data, 8)
    off, best, best_i, i = 12 + n, -1.0, 0, 0
    while off + 4 <= len(data):
        (n,) = struct.unpack_from("<I", data, off)
        tool, hand = struct.unpack_from("<ff", data, off + 4 + n - 8 - 12)
        if hand - tool > best:
            best, best_i = hand - tool, i
        off += 4 + n
        i += 1
    return best_i


class Viewer:
    """`numen view REC --port P` running; .url, .frames; stop() ends it (SIGTERM)."""

    def __init__(self, numen, rec, port=0):
        self.proc = subprocess.Popen([numen, "view", rec, "--port", str(port)], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()  # "numen view: F: N frames, T s; open URL (Ctrl-C ends)"
        m = re.search(r": (\d+) frames, .* open (http://\S+)", line)
        if not m:
            err = self.proc.stderr.read() if self.proc.poll() is not None else ""
            self.stop()
            raise RuntimeError("numen view printed %r, stderr %r" % (line, err))
        self.frames, self.url = int(m.group(1)), m.group(2)
        self.port = int(re.search(r":(\d+)/$", self.url).group(1))

    def stop(self):
        """Ends the server; returns a failure text or None."""
        self.proc.terminate()
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            return "numen view did not end on SIGTERM"
        if self.proc.returncode not in (0, -15):
            return "numen view exited %d: %s" % (self.proc.returncode, self.proc.stderr.read())
        return None


def record(numen, out, name, scene, duration, extra=()):
    """Records `duration` s of `scene` (None: the default) to OUT/NAME.nmv; returns its path."""
    rec = os.path.join(out, name + ".nmv")
    run = [numen, "run"] + ([scene] if scene else []) + ["--duration", str(duration), "--record-view", rec, *extra]
    r = subprocess.run(run, capture_output=True, text=True, timeout=300)
    if not os.path.exists(rec):
        raise RuntimeError("%s: exit %d, no recording\n%s" % (" ".join(run), r.returncode, r.stderr))
    return rec, r


def open_page(browser, url, query, timeout=60):
    """Opens the page, waits until it shows a frame (?frame=I: that frame); returns the Page."""
    page = browser.open(url + query, (WIDTH, HEIGHT))
    waited = page.wait("window.numenView && numenView.probe().framesShown > 0 && "
                       "document.title.endsWith('ready')", timeout)
    if waited is None:
        raise RuntimeError("the page showed no frame within %d s (%s)" % (timeout, url + query))
    time.sleep(0.3)  # a few animation frames: the shown frame is rendered
    return page


def page_failures(page, name):
    failures = ["%s: JavaScript: %s" % (name, e) for e in page.console_errors()]
    errs = page.eval("numenView.errors")
    if errs:
        failures.append("%s: the page logged errors: %s" % (name, errs))
    return failures


def expected_plot_points(frames, max_points=2000):
    """The replay plot's points for a recording of `frames` frames (docs/viewer.md "Replay"):
    frames 0, s, 2s, ... with s = max(1, ceil(frames / max_points)), and the last frame."""
    s = max(1, -(-frames // max_points))
    return len(range(0, frames, s)) + (1 if frames and (frames - 1) % s else 0)


def near_colour(img, x, y, rad, pred):
    """Pixels within `rad` of (x, y) satisfying `pred`."""
    px, (w, h) = img.load(), img.size
    return sum(1 for yy in range(max(0, int(y - rad)), min(h, int(y + rad) + 1))
               for xx in range(max(0, int(x - rad)), min(w, int(x + rad) + 1)) if pred(px[xx, yy]))


def is_arrow(p):
    """A contact's depth colour (contacts.js: hue 60° to 280°, saturated) or its blend; the
    deepest end renders at up to 287° on the canvas (the colour space's conversion), so the band
    reaches 300° (the organ's red and the tool's orange stay out)."""
    h, s, v = colorsys.rgb_to_hsv(p[0] / 255, p[1] / 255, p[2] / 255)
    return s > 0.45 and v > 0.3 and 55 / 360 <= h <= 300 / 360


def check_shapes(img, probe, name):
    """Tool parts drawn as shapes, force arrows where the contacts are, the ghost visible."""
    failures = []
    if name in INSTRUMENT:
        for part in ("sleeve", "tube", "jaw_1", "jaw_2"):
            if part not in probe.get("shapes", []):
                failures.append("%s: %s is not drawn as a shape (shapes %s)" % (name, part, probe.get("shapes")))
    arrows = [a for a in probe.get("arrows", []) if a["from"]["inside"] and a["to"]["inside"]
              and abs(a["to"]["x"] - a["from"]["x"]) + abs(a["to"]["y"] - a["from"]["y"]) > 12]
    # Not on the default scene's organ: its net is drawn over the arrows where the tool dents it.
    if name in ("lattice", "deformable", "construction"):
        if not arrows:
            failures.append("%s: no contact force arrow long enough to see in the frame (%s)" % (name, probe.get("arrows")))
        else:
            a = arrows[0]
            mx, my = (a["from"]["x"] + a["to"]["x"]) / 2, (a["from"]["y"] + a["to"]["y"]) / 2
            n = near_colour(img, mx, my, 3, is_arrow)
            print("%s: contact force arrow of %.2f N, %d arrow-coloured pixels at its middle" % (name, a["n"], n))
            if n < 1:
                failures.append("%s: the force arrow of a contact is not drawn where it acts" % name)
    if name == "deformable":  # the hidden core's ghost: the hand's target
        g = probe.get("ghostPx")
        n = near_colour(img, g["x"], g["y"], 10, is_ghost) if g and g["inside"] else 0
        print("deformable: %d ghost-coloured pixels around the hidden core's ghost" % n)
        if n < 10:
            failures.append("deformable: the hidden core's ghost is not visible (%d pixels, %s)" % (n, g))
    return failures


def is_body(p):
    """The grey of a body that is not the tool (geometry.js COLORS.body, 0x9aa4b0: blue above
    green above red), lit: not the background (0x20242a, darker) nor the floor (green first)."""
    return max(p) > 70 and p[2] >= p[1] >= p[0] and p[2] - p[0] >= 8


def mesh_bodies_at(page, i):
    """The probe's mesh bodies at frame i (shown paused), by name; None if never shown."""
    page.eval("numenView.seek(%d)" % i)
    if page.wait("numenView.probe().index === %d" % i, 10) is None:
        return None
    return {b["name"]: b for b in page.eval("numenView.probe().meshBodies")}


def check_mesh_bodies(page, probe, shot, name, frames):
    """A body with a mesh is drawn as its surface: every triangle the scene message sent, in the
    body's grey where the surface's middle projects, moving with the body: from the first to the
    last of the recording's `frames` frames, the surface's middle moves as the body's origin does
    (within 0.5 mm)."""
    from PIL import Image  # python3-pil
    shown = probe.get("meshBodies", [])
    if not shown:
        return []
    failures = []
    img = Image.open(shot).convert("RGB")
    first, last = mesh_bodies_at(page, 0), mesh_bodies_at(page, frames - 1)
    if first is None or last is None:
        return ["%s: the first or last frame is never shown" % name]
    for b in shown:
        n = b["name"]
        if n not in probe.get("shapes", []):
            failures.append("%s: the mesh body %s is not drawn as a shape (shapes %s)" % (name, n, probe.get("shapes")))
        if b["drawn"] != b["sent"]:
            failures.append("%s: %s: %d triangles drawn of the %d sent" % (name, n, b["drawn"], b["sent"]))
        if b["middle"] is None or first[n]["middle"] is None or last[n]["middle"] is None:
            failures.append("%s: %s: no surface drawn" % (name, n))
            continue
        px = b["middlePx"]
        grey = near_colour(img, px["x"], px["y"], 3, is_body) if px["inside"] else 0
        moved = [last[n]["position"][k] - first[n]["position"][k] for k in range(3)]
        followed = [last[n]["middle"][k] - first[n]["middle"][k] for k in range(3)]
        off = max(abs(moved[k] - followed[k]) for k in range(3))
        print("%s: mesh body %s: %d of %d triangles drawn, %d body-grey pixels at its middle; the body "
              "moved %.1f mm over the recording, its surface's middle %.1f mm (%.2f mm apart)"
              % (name, n, b["drawn"], b["sent"], grey, 1e3 * sum(m * m for m in moved) ** 0.5,
                 1e3 * sum(f * f for f in followed) ** 0.5, 1e3 * off))
        if grey < 10:
            failures.append("%s: %s: the body's grey is not where its surface projects (%d pixels)" % (name, n, grey))
        if off > 0.5e-3:
            failures.append("%s: %s: the surface does not move with the body (%.2f mm apart)" % (name, n, 1e3 * off))
    return failures


def is_net(p):
    """The nets' green (geometry.js COLORS.net, 0x60c060), lit: green well above red and blue
    (the floor's 0x707a68 is not)."""
    return p[1] > 60 and p[1] - p[0] > 25 and p[1] - p[2] > 25


def check_fine_surface(numen, browser, out):
    """A recording whose organ net carries a fine surface: drawn as that surface, in the net's
    green, its vertices placed by the documented formula (within 2 µm of this script's, from
    the same float32 node positions), the coarse net a toggle."""
    from PIL import Image  # python3-pil
    name = "fine_surface"
    try:
        plain, r = record(numen, out, name + "_plain", FINE_SURFACE_SCENE, 0.6)
    except RuntimeError as e:
        return [str(e)]
    if r.returncode != 0:
        return ["%s: exit %d\n%s" % (name, r.returncode, r.stderr)]
    rec = os.path.join(out, name + ".nmv")
    net, frames = fine_surface_recording.add_fine_surface(plain, rec, "organ")
    surface = net["surface"]
    viewer = Viewer(numen, rec)
    failures = []
    try:
        last = len(frames) - 1
        page = open_page(browser, viewer.url, "?frame=%d&w=%d&h=%d" % (last, VIEW_W, VIEW_H))
        shot = os.path.join(out, "viewer_%s.png" % name)
        page.screenshot(shot)
        probe = page.eval("numenView.probe()")
        shown = probe.get("netSurfaces", [])
        if len(shown) != 1 or shown[0]["name"] != "organ":
            return failures + ["%s: the page shows fine surfaces %s, not the organ's" % (name, shown)]
        fs = shown[0]
        x = fine_surface_recording.node_positions(frames[last])[net["node_begin"]:net["node_begin"] + net["node_count"]]
        off = max(math.dist(fine_surface_recording.fine_vertex(surface, i, x), p)
                  for i, p in zip(fs["sample"], fs["samplePositions"]))
        px = fs["middlePx"]
        img = Image.open(shot).convert("RGB")
        green = near_colour(img, px["x"], px["y"], 3, is_net) if px["inside"] else 0
        print("%s: %d fine vertices, %d of %d triangles drawn on a net of %d nodes, %d net-green pixels at "
              "its middle, sample vertices %.2g m from the formula's"
              % (name, fs["points"], fs["drawn"], fs["sent"], net["node_count"], green, off))
        if fs["points"] != surface["point_count"] or fs["drawn"] != surface["triangle_count"] or fs["sent"] != fs["drawn"]:
            failures.append("%s: %d triangles drawn of the %d sent (%d vertices)" % (name, fs["drawn"], fs["sent"], fs["points"]))
        if off > 2e-6:
            failures.append("%s: the page's fine vertices are %.3g m from where the formula puts them" % (name, off))
        if green < 10:
            failures.append("%s: the net's green is not where the fine surface's middle projects (%d pixels)" % (name, green))
        if fs["coarseShown"]:
            failures.append("%s: the coarse net is shown before its toggle is" % name)
        page.eval("document.getElementById('net').click()")
        if page.wait("numenView.probe().netSurfaces[0].coarseShown", 5) is None:
            failures.append("%s: the coarse-net toggle does not show the net" % name)
        failures += page_failures(page, name)
        page.send("Page.close")
    finally:
        f = viewer.stop()
        if f:
            failures.append(f)
    return failures


def check_page_files(browser, numen, viewer):
    """The favicon the page links is served (no 404 on a page load), and the page opened as a
    file says how to serve it instead of "connecting…"."""
    import urllib.request
    failures = []
    try:
        with urllib.request.urlopen(viewer.url + "favicon.svg", timeout=10) as r:
            kind = r.headers.get("Content-Type", "")
        if kind != "image/svg+xml":
            failures.append("favicon.svg served as %r" % kind)
    except Exception as e:  # noqa: BLE001 (any failure is the finding)
        failures.append("favicon.svg: %s" % e)
    index = os.path.join(os.path.dirname(os.path.abspath(numen)), "viewer", "index.html")
    if os.path.exists(index):
        page = browser.open("file://" + index, (WIDTH, HEIGHT))
        page.wait("document.readyState === 'complete'", 10)
        text = page.eval("document.getElementById('status').textContent")
        print("file://: the page says %r" % text.splitlines()[0])
        if "numen run --view" not in text or "numen view" not in text:
            failures.append("file://: the page does not say how to serve it (%r)" % text)
        page.send("Page.close")
    else:
        print("file://: no %s beside numen: not checked" % index)
    return failures


def check_pick(page, probe, name):
    """A click on the tool (the middle of its projected spheres) shows its name and pose."""
    discs = [d for d in probe.get("tool", []) if d["inside"]]
    if not discs:
        return []
    d = discs[len(discs) // 2]
    for kind in ("mousePressed", "mouseReleased"):
        page.send("Input.dispatchMouseEvent", {"type": kind, "x": d["x"], "y": d["y"], "button": "left", "clickCount": 1})
    text = page.eval("numenView.probe().pick.text")
    print("%s: a click on the tool shows %r" % (name, text.splitlines()[:2]))
    if not text.startswith(probe["toolName"]) or "position" not in text or "contacts" not in text:
        return ["%s: a click on the tool did not show it (%r)" % (name, text)]
    return []


def check_pixels(img, probe, name):
    """The tool's and the ghost's colours where the page projects them; returns failures."""
    failures = []
    tool = [d for d in probe.get("tool", []) if d["inside"]]
    ghost = [d for d in probe.get("ghost", []) if d["inside"]]
    if probe.get("tool") == [] and name not in INSTRUMENT:
        print("%s: the tool (%s) has no spheres of its own (a net's hidden core)" % (name, probe.get("toolName")))
    elif not tool:
        failures.append("the tool is not in the view (probe %s)" % probe)
    else:
        on = count_in_discs(img, tool, is_tool, 0.8)
        near = count_in_discs(img, tool, is_tool, 1.5, 4)
        total = count_all(img, is_tool)
        print("%s: tool %s, %d tool-coloured pixels on its projection, %d near it, %d in all"
              % (name, probe.get("toolName"), on, near, total))
        if on < 10:
            failures.append("%s: the tool's colour is not where its projection says (%d pixels)" % (name, on))
        if total and near < 0.7 * total:
            failures.append("%s: tool-coloured pixels away from the tool: %d of %d" % (name, total - near, total))
    if name in INSTRUMENT:  # the scenes whose hand goes into the organ: the ghost must show
        if not ghost:
            failures.append("no ghost (target pose) in the frame")
        else:
            g = count_in_discs(img, ghost, is_ghost, 0.8)
            print("%s: %d ghost-coloured pixels on the ghost's projection" % (name, g))
            if g < 10:
                failures.append("%s: the ghost's colour is not where its projection says (%d pixels)" % (name, g))
    return failures


def check_reconnect(numen, browser, viewer, rec):
    """Kills the server under a page and starts it again; returns (failures, new viewer)."""
    page = open_page(browser, viewer.url, "?w=%d&h=%d" % (VIEW_W, VIEW_H))
    failures = []
    viewer.stop()
    lost = page.wait("numenView.probe().link.state !== 'open'", 10)
    said = page.eval("document.getElementById('connection').textContent")
    if lost is None or "reconnecting" not in said:
        failures.append("reconnect: the page did not say the connection was lost (%r)" % said)
    time.sleep(3)  # a few failed attempts: the backoff grows
    shown = page.eval("numenView.probe().framesShown")
    again = Viewer(numen, rec, viewer.port)
    resumed = page.wait("numenView.probe().link.state === 'open' && numenView.probe().framesShown > %d" % shown,
                        RECONNECT_S)
    print("reconnect: the page said %r; resumed %s after the server's restart"
          % (said, "in %.2f s" % resumed if resumed is not None else "not within %g s" % RECONNECT_S))
    if resumed is None:
        failures.append("reconnect: the page did not resume within %g s of the server's return" % RECONNECT_S)
    failures += page_failures(page, "reconnect")
    page.send("Page.close")
    return failures, again


def check_camera(browser, viewer, samples=60):
    """The camera keeps the tool in view: the page opened at frame 0 (follow the tool on, as by
    default), then `samples` frames spread over the whole recording shown in order; the tool's
    projected position (its body's origin) must be inside the canvas on every one."""
    page = open_page(browser, viewer.url, "?frame=0&w=%d&h=%d" % (VIEW_W, VIEW_H))
    n = viewer.frames
    frames = sorted(set([round(k * (n - 1) / (samples - 1)) for k in range(samples)]))
    outside = []
    for i in frames:
        page.eval("numenView.seek(%d)" % i)
        if page.wait("numenView.probe().index === %d && numenView.probe().framesShown > 0" % i, 10) is None:
            outside.append((i, "never shown"))
            continue
        t = page.eval("numenView.probe().toolPx")
        if not t or not t["inside"]:
            outside.append((i, t))
    print("camera: the tool's projection inside the canvas on %d of %d sampled frames"
          % (len(frames) - len(outside), len(frames)))
    failures = ["camera: the tool leaves the view at frames %s" % outside[:5]] if outside else []
    failures += page_failures(page, "camera")
    page.send("Page.close")
    return failures


def check_live(numen, browser, duration=8.0):
    """`numen run --view 0 --wait-for-viewer`: the run starts when the page connects, so the
    page receives every frame from period 0; paused, the view holds its frame while frames keep
    arriving, steps back and scrubs through its buffer, and goes back to live."""
    run = subprocess.Popen([numen, "run", LATTICE, "--view", "0", "--wait-for-viewer=60", "--duration", str(duration)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    failures = []
    try:
        url = None
        for _ in range(20):
            line = run.stderr.readline()
            m = re.search(r"viewer on (http://\S+)", line)
            if m:
                url = m.group(1)
                break
        if not url:
            return ["live: numen run --view printed no URL"]
        time.sleep(1.0)  # the run must still be waiting
        page = open_page(browser, url, "?w=%d&h=%d" % (VIEW_W, VIEW_H))
        p = page.eval("numenView.probe()")
        if p["live"]["firstPeriod"] != 0:
            failures.append("live: the first frame the page got is of period %s, not 0" % p["live"]["firstPeriod"])
        # Pause the view, and read its state at once (the page may be rendering behind).
        p0 = page.eval("(() => { document.getElementById('play').click(); return numenView.probe(); })()")
        time.sleep(1.0)
        p1 = page.eval("numenView.probe()")
        if not p0["live"]["paused"] or p1["period"] != p0["period"]:
            failures.append("live: the paused view did not hold its frame (%s, then %s)" % (p0["period"], p1["period"]))
        if p1["live"]["buffered"] <= p0["live"]["buffered"]:
            failures.append("live: no frame arrived while the view was paused")
        page.eval("document.getElementById('back').click()")
        back = page.eval("numenView.probe().period")
        page.eval("(() => { const s = document.getElementById('slider'); s.value = '0'; s.dispatchEvent(new Event('input')); })()")
        first = page.eval("numenView.probe().period")
        page.eval("document.getElementById('play').click()")  # back to live
        time.sleep(0.5)
        again = page.eval("numenView.probe()")
        print("live: paused at period %d while %d -> %d frames arrived; back a step: %d; scrubbed to %d; "
              "live again at %d" % (p0["period"], p0["live"]["buffered"], p1["live"]["buffered"], back, first, again["period"]))
        if not back < p0["period"] or first != 0 or again["live"]["paused"] or again["period"] <= p0["period"]:
            failures.append("live: step / scrub / back to live did not show the expected frames")
        run.wait(timeout=60)
        err = run.stderr.read()
        m = re.search(r"viewer: 1 clients, (\d+) frames sent, (\d+) dropped", err)
        if m:  # the page may still be reading what was sent
            page.wait("numenView.probe().framesReceived >= %d" % int(m.group(1)), 30)
        received = page.eval("numenView.probe().framesReceived")
        print("live: the page received %d frames; numen: %s" % (received, m.group(0) if m else err.strip()[-200:]))
        if run.returncode != 0 or not m or int(m.group(1)) != received or int(m.group(2)) != 0:
            failures.append("live: exit %s, the page received %d frames (numen: %s)" % (run.returncode, received, err[-300:]))
        failures += page_failures(page, "live")
        page.send("Page.close")
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    return failures


def record_scene_text(numen, out, name, text, duration):
    """Records `duration` s of the scene `text` (a shipped scene changed) as record() does; the
    scene is written to OUT/NAME/scenes/NAME.toml beside links to the shipped data and device
    files, so that it finds them by the shipped scenes' relative paths."""
    scenes = os.path.join(out, name, "scenes")
    os.makedirs(scenes, exist_ok=True)
    for link, target in ((os.path.join(out, name, "data"), os.path.join(ROOT, "sim", "data")),
                         (os.path.join(scenes, "devices"), os.path.join(ROOT, "sim", "scenes", "devices"))):
        if not os.path.islink(link):
            os.symlink(target, link)
    scene = os.path.join(scenes, name + ".toml")
    with open(scene, "w") as f:
        f.write(text)
    return record(numen, out, name, scene, duration)


def check_tissue_dimple(numen, browser, out):
    """The default scene, its organ given by its material (E = 100 kPa, ν = 0.45, on a 500-node
    net; docs/tissue.md): 5 s of the excerpt, where the tool is in the surface the net carries.
    The page draws the dimple under it (tissue_dimple.js): a move of more than 1 mm, and no drawn
    vertex of the organ inside a sphere of another body."""
    name = "tissue_dimple"
    with open(os.path.join(ROOT, "sim", "scenes", "default.toml")) as f:
        text = f.read()
    try:
        rec, r = record_scene_text(numen, out, name, text, 5.0)
    except RuntimeError as e:
        return [str(e)]
    if r.returncode != 0:
        return ["%s: exit %d\n%s" % (name, r.returncode, r.stderr)]
    viewer = Viewer(numen, rec)
    failures = []
    try:
        page = open_page(browser, viewer.url, "?frame=%d&w=%d&h=%d" % (viewer.frames - 1, VIEW_W, VIEW_H))
        page.screenshot(os.path.join(out, "viewer_%s.png" % name))
        nets = page.eval("numenView.probe()").get("tissueNets", [])
        print("%s: %s" % (name, nets))
        if len(nets) != 1 or nets[0]["name"] != "organ":
            return failures + ["%s: the page has organs given by their material %s, not the organ" % (name, nets)]
        if not nets[0]["dimpleMove"] > 1e-3:
            failures.append("%s: the largest dimple drawn is %.3g m, not over 1 mm" % (name, nets[0]["dimpleMove"]))
        if nets[0]["inside"] > 1e-6:
            failures.append("%s: a drawn vertex of the organ is %.3g m inside a tool's sphere" % (name, nets[0]["inside"]))
        failures += page_failures(page, name)
        page.send("Page.close")
    finally:
        f = viewer.stop()
        if f:
            failures.append(f)
    return failures


def check_fault(numen, browser, out):
    """A run that latches (the default scene on a bus losing 30 % of its frames): the replay's
    last frame shows the fault banner with its cause, and the timeline marks it."""
    with open(LATTICE) as f:
        text = f.read()
    text, n = re.subn(r"(?m)^drop_probability = 0\.0", "drop_probability = 0.3", text)
    if n != 1:
        return ["fault: lattice.toml has no [bus] drop_probability = 0.0 line to change"]
    rec, r = record_scene_text(numen, out, "latch", text, 2.0)
    if r.returncode != 3:
        return ["fault: the lossy-bus run exited %d, not 3 (safety stop)\n%s" % (r.returncode, r.stderr)]
    viewer = Viewer(numen, rec)
    failures = []
    try:
        page = open_page(browser, viewer.url, "?frame=%d&w=%d&h=%d" % (viewer.frames - 1, VIEW_W, VIEW_H))
        p = page.eval("numenView.probe()")
        page.screenshot(os.path.join(out, "viewer_latch.png"))
        print("fault: banner %r, %d timeline mark(s)" % (p["banner"], p["marks"]))
        if not p["banner"].startswith("FAULT"):
            failures.append("fault: no fault banner on the last frame of a latched run (%r)" % p["banner"])
        if "since t =" not in p["banner"]:
            failures.append("fault: the banner does not say since when (%r)" % p["banner"])
        # The supervisor's cause, as the run's summary names it ("safety: … first: CAUSE (id …").
        cause = re.search(r"safety: .*?first: ([a-z -]+?) \(", r.stdout)
        if not cause:
            failures.append("fault: the run's summary names no first fault:\n%s" % r.stdout)
        elif cause.group(1) not in p["banner"]:
            failures.append("fault: the banner does not name the cause %r (%r)" % (cause.group(1), p["banner"]))
        if p["marks"] < 1:
            failures.append("fault: the replay timeline has no mark")
        failures += page_failures(page, "fault")
    finally:
        f = viewer.stop()
        if f:
            failures.append(f)
    return failures


def check_grasp(numen, browser, out):
    """The default scene with a grasper on its jaws (docs/grasping.md "On the shipped recording":
    the recorded motion grasps the organ's tissue at ~6.97 s): the replay timeline marks each
    grasp and release of the recording's series, and at a grasp's frame the panel says what the
    grasper holds."""
    with open(os.path.join(ROOT, "sim", "scenes", "default.toml")) as f:
        text = f.read()
    text += '\n[[grasp]]\nname = "grasper"\njaws = ["jaw_1", "jaw_2"]\n'
    rec, r = record_scene_text(numen, out, "grasp", text, 7.3)
    if r.returncode != 0:
        return ["grasp: the run exited %d\n%s" % (r.returncode, r.stderr)]
    viewer = Viewer(numen, rec)
    failures = []
    try:
        page = open_page(browser, viewer.url, "?frame=0&w=%d&h=%d" % (VIEW_W, VIEW_H))
        p = page.eval("numenView.probe()")
        events = p["graspEvents"]
        kinds = [e["event"] for e in events]
        print("grasp: the series' grasp events %s, %d timeline marks" % (kinds, p["marks"]))
        if "grasp" not in kinds or "release" not in kinds:
            failures.append("grasp: the recording's series has no grasp and release (%s)" % events)
        elif p["marks"] < len(events):
            failures.append("grasp: %d timeline marks for %d grasp events" % (p["marks"], len(events)))
        else:
            first = next(e for e in events if e["event"] == "grasp")
            page.eval("numenView.seek(%d)" % first["frame"])
            if page.wait("numenView.probe().index === %d" % first["frame"], 10) is None:
                failures.append("grasp: frame %d never shown" % first["frame"])
            else:
                text = page.eval("numenView.probe().grasps")
                print("grasp: at frame %d (t = %.3f s) the panel says %r" % (first["frame"], first["t"], text))
                if "grasp grasper: holds organ (tissue)" not in text:
                    failures.append("grasp: at the grasp's frame the panel says %r" % text)
        failures += page_failures(page, "grasp")
        page.send("Page.close")
    finally:
        f = viewer.stop()
        if f:
            failures.append(f)
    return failures


def check_last_frame(numen, browser, out, name, scene, duration, check_page):
    """Records `duration` s of `scene` (a file of sim/scenes), serves it, opens its last frame and
    returns check_page(page, frame)'s failures, the page's errors and the server's."""
    rec, r = record(numen, out, name, os.path.join(ROOT, "sim", "scenes", scene), duration)
    if r.returncode != 0:
        return ["%s: the run exited %d\n%s" % (name, r.returncode, r.stderr)]

    def check(viewer):
        last = viewer.frames - 1
        page = open_page(browser, viewer.url, "?frame=%d&w=%d&h=%d" % (last, VIEW_W, VIEW_H))
        failures = check_page(page, last)
        failures += page_failures(page, name)
        page.send("Page.close")
        return failures
    return served(numen, rec, check)


def check_devices(numen, browser, out):
    """The two-device bimanual scene (issue 70: the view carried device 0's state alone): the
    panel has a line for the loop's other device, "right", with its lifecycle, samples,
    feedback force and the torques sent to its axes, and the page logs no error."""
    def check(page, last):
        text = page.eval("numenView.probe().devices")
        print("bimanual: at frame %d the panel says %r" % (last, text))
        if not re.search(r"^device 1 'right': .*samples valid, \|F\| = \d+\.\d\d N, "
                         r"τ = \[-?\d+\.\d{3}(, -?\d+\.\d{3})*\]$", text):
            return ["bimanual: the panel's line of device 1 is %r" % text]
        return []
    return check_last_frame(numen, browser, out, "bimanual", "bimanual.toml", 0.3, check)


def check_suturing(numen, browser, out):
    """The suturing scene (issue 69: the view did not draw the needle and the thread): at the last
    frame of 1 s (the needle held by the right driver since 0.317 s) the needle's body has its arc
    as a shape, the thread "suture" is drawn whole (100 segments, 101 nodes) and its first node is
    at the needle's tail (within 1 mm: the thread's tie), and the page logs no error."""
    def check(page, last):
        p = page.eval("numenView.probe()")
        tail = page.eval("(() => { const n = numenView.scene().needles[0]; const g = numenView.body(n.body);"
                         " g.updateMatrixWorld(); const a = n.tail_angle; return g.localToWorld(new g.position.constructor("
                         "n.centre[0] + n.radius * Math.cos(a), n.centre[1] + n.radius * Math.sin(a), n.centre[2]))"
                         ".toArray(); })()")
        print("suturing: at frame %d needles %s, threads %s, the needle's tail at %s"
              % (last, p["needles"], [{k: t[k] for k in ("name", "nodes", "segmentsDrawn", "broken")}
                                      for t in p["threads"]], tail))
        failures = []
        if [n["name"] for n in p["needles"]] != ["needle"] or not p["needles"][0]["shape"] \
                or "needle" not in p["shapes"]:
            failures.append("suturing: the needle is not drawn as its arc: %s, shapes %s" % (p["needles"], p["shapes"]))
        threads = p["threads"]
        if len(threads) != 1 or threads[0]["name"] != "suture" or threads[0]["nodes"] != 101 \
                or threads[0]["segmentsDrawn"] != 100 or threads[0]["broken"] != -1:
            failures.append("suturing: the thread is not drawn whole: %s" % threads)
        elif math.dist(threads[0]["first"], tail) > 1e-3:
            failures.append("suturing: the thread's first node %s is %.2f mm from the needle's tail %s"
                            % (threads[0]["first"], 1e3 * math.dist(threads[0]["first"], tail), tail))
        return failures
    return check_last_frame(numen, browser, out, "suturing", "suturing.toml", 1.0, check)


def served(numen, rec, check):
    """`check(viewer)`'s failures on `rec` served by `numen view`, and the server's own."""
    viewer = Viewer(numen, rec)
    failures = []
    try:
        failures += check(viewer)
    finally:
        f = viewer.stop()
        if f:
            failures.append(f)
    return failures


def check_scene(numen, browser, out, name, scene, duration, figure):
    """Records, serves, shoots and checks one scene; returns a list of failures."""
    from PIL import Image  # python3-pil
    failures = []
    os.makedirs(out, exist_ok=True)
    try:
        rec, r = record(numen, out, name, os.path.join(ROOT, scene) if scene else None, duration)
    except RuntimeError as e:
        return [str(e)]
    if r.returncode != 0:
        return ["%s: exit %d\n%s" % (name, r.returncode, r.stderr)]
    viewer = Viewer(numen, rec)
    try:
        if viewer.frames == 0:
            return ["%s holds no frame" % rec]
        shown = deepest_hand_frame(rec)
        page = open_page(browser, viewer.url, "?frame=%d&w=%d&h=%d" % (shown, VIEW_W, VIEW_H))
        shot = os.path.join(out, "viewer_%s.png" % name)
        page.screenshot(shot)
        probe = page.eval("numenView.probe()")
        failures += check_pick(page, probe, name)
        failures += check_mesh_bodies(page, probe, shot, name, viewer.frames)
        failures += page_failures(page, name)
        page.send("Page.close")
        img = Image.open(shot).convert("RGB")
        failures += check_pixels(img, probe, name)
        failures += check_shapes(img, probe, name)
        want = expected_plot_points(viewer.frames)
        print("%s: replay plot of %d points, the recording %d frames (%d expected)"
              % (name, probe["plotPoints"], viewer.frames, want))
        if probe["plotPoints"] != want:
            failures.append("%s: the replay plot has %d points, not %d" % (name, probe["plotPoints"], want))
        if figure:
            os.makedirs(os.path.dirname(os.path.abspath(figure)), exist_ok=True)
            shutil.copyfile(shot, figure)
            print("wrote " + figure)
        if name in INSTRUMENT:
            failures += check_page_files(browser, numen, viewer)
            failures += check_camera(browser, viewer)
            f, viewer = check_reconnect(numen, browser, viewer, rec)
            failures += f
    finally:
        f = viewer.stop()
        if f:
            failures.append(f)
    return failures


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--numen", required=True, help="the numen program")
    ap.add_argument("--out", required=True, help="folder for the recording, screenshot, profile")
    ap.add_argument("--scene", help="scene file (default: the lattice scene, sim/scenes/lattice.toml)")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds of the recorded run")
    ap.add_argument("--figure", help="copy the screenshot here")
    ap.add_argument("--figures", help="folder: the screenshots of the scenes of docs/viewer.md")
    ap.add_argument("--skip", help="skip the test with this reason (a build that cannot run it)")
    a = ap.parse_args()
    if a.skip:
        print("SKIPPED: " + a.skip)
        return 77
    exe = chromium_path()
    if not exe:
        print("SKIPPED: chromium is not installed (Debian: apt-get install chromium; "
              "CI installs it: .ci/run, viewer step)")
        return 77
    try:  # the screenshots' checks read the pixels with PIL: without it the test cannot judge
        import PIL.Image  # noqa: F401  (python3-pil)
    except ImportError:
        print("SKIPPED: the Python module PIL is not installed: the screenshots' pixels cannot be "
              "checked (Debian: apt-get install python3-pil; CI installs it: .ci/run, viewer step)")
        return 77
    os.makedirs(a.out, exist_ok=True)
    jobs = ([(n, s, a.duration, os.path.join(a.figures, "viewer_%s.png" % n)) for n, s in FIGURE_SCENES]
            if a.figures else [(os.path.splitext(os.path.basename(a.scene))[0], a.scene, a.duration, a.figure)]
            if a.scene else [("lattice", LATTICE, a.duration, a.figure), ("mesh_body", MESH_BODY, MESH_BODY_S, None)])
    failures = []
    profile = os.path.join(a.out, "chromium-profile")
    shutil.rmtree(profile, ignore_errors=True)
    with cdp.Browser(exe, profile, (WIDTH, HEIGHT)) as browser:
        for name, scene, duration, figure in jobs:
            failures += check_scene(a.numen, browser, a.out, name, scene, duration, figure)
        if not a.scene and not a.figures:
            failures += check_live(a.numen, browser)
            failures += check_fine_surface(a.numen, browser, a.out)
            failures += check_tissue_dimple(a.numen, browser, a.out)
            failures += check_fault(a.numen, browser, a.out)
            failures += check_grasp(a.numen, browser, a.out)
            failures += check_devices(a.numen, browser, a.out)
            failures += check_suturing(a.numen, browser, a.out)
    shutil.rmtree(profile, ignore_errors=True)
    for f in failures:
        print("FAIL: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
