#!/usr/bin/python3
"""The viewer page's frame rate and cost per frame (docs/viewer.md "What it costs").

For each scene: records a run (`numen run SCENE --duration D --record-view`), serves it with
`numen view`, plays it at 1x in headless Chromium (SwiftShader WebGL: no GPU) over the DevTools
pipe (cdp.py), lets it play WARMUP_S, then counts over MEASURE_S of wall time the frames the
page drew and rendered, the time in its draw() (JavaScript: poses, contacts, arrows, panel) and
in renderer.render() followed by gl.finish() (?perf=1: the rendering itself), and the mean
contacts and nodes per frame. Prints a Markdown table.

    tests/sim/view/viewer_perf.py --numen build/numen --out /tmp/perf [--scene NAME=PATH ...]
"""
import argparse
import os
import shutil
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cdp  # noqa: E402
from viewer_browser_test import (ROOT, WIDTH, HEIGHT, VIEW_W, VIEW_H, Viewer, chromium_path,  # noqa: E402
                                 record)

SCENES = [("default", None), ("lattice", "sim/scenes/lattice.toml"), ("construction", "sim/scenes/construction.toml"),
          ("deformable", "sim/scenes/deformable.toml"), ("endobag", "sim/scenes/endobag.toml")]
WARMUP_S, MEASURE_S = 2.0, 8.0


def measure(browser, viewer, query=""):
    page = browser.open(viewer.url + "?perf=1&w=%d&h=%d%s" % (VIEW_W, VIEW_H, query), (WIDTH, HEIGHT))
    if page.wait("window.numenView && numenView.probe().framesShown > 0", 60) is None:
        raise RuntimeError("no frame shown")
    time.sleep(WARMUP_S)
    a = page.eval("({...numenView.perf})")
    t0 = time.time()
    time.sleep(MEASURE_S)
    b = page.eval("({...numenView.perf})")
    wall = time.time() - t0
    page.send("Page.close")
    d = {k: b[k] - a[k] for k in ("drawn", "drawMs", "rendered", "renderMs", "contacts", "nodes")}
    n, r = max(1, d["drawn"]), max(1, d["rendered"])
    return {"fps": d["rendered"] / wall, "draw_ms": d["drawMs"] / n, "render_ms": d["renderMs"] / r,
            "contacts": d["contacts"] / n, "nodes": d["nodes"] / n, "drawn": d["drawn"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--numen", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--duration", type=float, default=12.0)
    ap.add_argument("--query", default="", help="more URL parameters of the page, e.g. &aa=1")
    ap.add_argument("--scenes", default=",".join(n for n, _ in SCENES), help="names, comma-separated")
    ap.add_argument("--scene", action="append", default=[], metavar="NAME=PATH",
                    help="one more scene file to measure (repeatable), e.g. an organ of the user's size")
    a = ap.parse_args()
    extra = []
    for item in a.scene:
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            ap.error("--scene %r: expected NAME=PATH" % item)
        if not os.path.isfile(path):
            ap.error("--scene %s: no such file: %s" % (name, path))
        extra.append((name, os.path.abspath(path)))
    exe = chromium_path()
    if not exe:
        print("chromium is not installed")
        return 77
    os.makedirs(a.out, exist_ok=True)
    rows = []
    profile = os.path.join(a.out, "chromium-profile")
    shutil.rmtree(profile, ignore_errors=True)
    with cdp.Browser(exe, profile, (WIDTH, HEIGHT)) as browser:
        for name, scene in [x for x in SCENES if x[0] in a.scenes.split(",")] + extra:
            rec, r = record(a.numen, a.out, name, os.path.join(ROOT, scene) if scene else None, a.duration)
            viewer = Viewer(a.numen, rec)
            try:
                m = measure(browser, viewer, a.query)
            finally:
                viewer.stop()
            rows.append((name, m))
            print("%s: %s" % (name, m), file=sys.stderr)
    print("| scene | contacts (mean) | nodes | frames per second | draw(), ms per frame | render + finish, ms per frame |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name, m in rows:
        print("| %s | %.1f | %d | %.1f | %.2f | %.1f |" % (name, m["contacts"], m["nodes"], m["fps"], m["draw_ms"], m["render_ms"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
