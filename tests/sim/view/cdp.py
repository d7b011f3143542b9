"""A minimal Chrome DevTools Protocol client over Chromium's --remote-debugging-pipe (file
descriptors 3 and 4, messages ended by a NUL byte): real time, no WebSocket library. Used by
viewer_browser_test.py for what needs a running page (reconnect, sampled frames, frame rate).

    with Browser(exe, profile, (1200, 760)) as b:
        page = b.open(url, (1200, 760))
        page.wait("window.numenView && numenView.framesShown > 0", 20)
        page.eval("numenView.probe()")
"""
import base64
import json
import os
import subprocess
import time


class CdpError(RuntimeError):
    pass


class Browser:
    """Headless Chromium (SwiftShader WebGL) driven over the pipe."""

    def __init__(self, exe, profile, size, extra=()):
        r_cmd, w_cmd = os.pipe()  # we write commands; Chromium reads fd 3
        r_ev, w_ev = os.pipe()    # Chromium writes fd 4; we read
        self._cmd = [exe, "--headless", "--no-sandbox", "--use-angle=swiftshader",
                     "--enable-unsafe-swiftshader", "--no-first-run",
                     "--disable-background-networking", "--disable-component-update",
                     "--disable-sync", "--hide-scrollbars", "--force-device-scale-factor=1",
                     "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
                     "--user-data-dir=" + profile, "--window-size=%d,%d" % size,
                     "--remote-debugging-pipe", *extra, "about:blank"]

        def fds():  # fresh copies first: dup2(3, 3) would keep 3's close-on-exec
            a, b = os.dup(r_cmd), os.dup(w_ev)
            os.dup2(a, 3)
            os.dup2(b, 4)
        # close_fds would run after preexec_fn and close 3 and 4: the child closes nothing
        # (the pipes' other ends are not inheritable, os.pipe()'s default).
        self.proc = subprocess.Popen(self._cmd, close_fds=False, preexec_fn=fds,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        os.close(r_cmd)
        os.close(w_ev)
        self._w = os.fdopen(w_cmd, "wb", buffering=0)
        self._r = os.fdopen(r_ev, "rb", buffering=0)
        self._buf = b""
        self._id = 0
        self.events = []

    def __enter__(self):
        return self

    def __exit__(self, *a):
        self.close()

    def close(self):
        try:
            self.send("Browser.close", timeout=5)
        except Exception:
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()

    def _read_message(self):
        while b"\0" not in self._buf:
            chunk = self._r.read(65536)
            if not chunk:
                raise CdpError("Chromium closed the pipe")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method, params=None, session=None, timeout=60):
        self._id += 1
        m = {"id": self._id, "method": method, "params": params or {}}
        if session:
            m["sessionId"] = session
        self._w.write(json.dumps(m).encode() + b"\0")
        end = time.time() + timeout
        while time.time() < end:
            r = self._read_message()
            if r.get("id") == self._id:
                if "error" in r:
                    raise CdpError("%s: %s" % (method, r["error"]))
                return r.get("result", {})
            self.events.append(r)
        raise CdpError(method + ": no answer in %g s" % timeout)

    def open(self, url, size):
        """A new page at `url` with a viewport of `size` (w, h) CSS pixels; returns a Page."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        page = Page(self, session)
        page.send("Runtime.enable")
        page.send("Page.enable")
        page.send("Emulation.setDeviceMetricsOverride", {"width": size[0], "height": size[1],
                                                          "deviceScaleFactor": 1, "mobile": False})
        page.send("Page.navigate", {"url": url})
        return page


class Page:
    def __init__(self, browser, session):
        self.b = browser
        self.session = session

    def send(self, method, params=None, timeout=60):
        return self.b.send(method, params, self.session, timeout)

    def eval(self, expr, timeout=60):
        """The value of the JavaScript expression `expr` (awaited, returned by value)."""
        r = self.send("Runtime.evaluate", {"expression": expr, "returnByValue": True,
                                           "awaitPromise": True}, timeout)
        if "exceptionDetails" in r:
            raise CdpError("%s: %s" % (expr, r["exceptionDetails"].get("exception", {}).get(
                "description", r["exceptionDetails"].get("text"))))
        return r["result"].get("value")

    def wait(self, expr, timeout, poll=0.1):
        """Waits until `expr` is truthy; returns the seconds waited, or None on timeout."""
        t0 = time.time()
        while time.time() - t0 < timeout:
            try:
                if self.eval(expr, timeout=max(1, timeout)):
                    return time.time() - t0
            except CdpError:
                pass
            time.sleep(poll)
        return None

    def screenshot(self, path):
        data = self.send("Page.captureScreenshot", {"format": "png"})["data"]
        with open(path, "wb") as f:
            f.write(base64.b64decode(data))

    def console_errors(self):
        """Runtime exceptions and console errors the page reported so far."""
        out = []
        for e in self.b.events:
            if e.get("sessionId") != self.session:
                continue
            if e.get("method") == "Runtime.exceptionThrown":
                d = e["params"]["exceptionDetails"]
                out.append(d.get("exception", {}).get("description") or d.get("text"))
            elif e.get("method") == "Runtime.consoleAPICalled" and e["params"].get("type") == "error":
                out.append(" ".join(str(a.get("value", a.get("description"))) for a in e["params"]["args"]))
        return out
