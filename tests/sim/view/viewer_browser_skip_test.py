#!/usr/bin/env python3
"""viewer_browser's skip on a machine with Chromium but without PIL (issue 66).

viewer_browser_test.py failed (exit 1, ModuleNotFoundError: PIL) on a machine with Chromium and
without python3-pil, after running numen and the browser: it skips (77) like a machine without
Chromium, naming the module, before it runs anything. This test runs it with a stand-in
`chromium` on PATH (never started) and a PIL package that cannot be imported first on
PYTHONPATH, whatever the machine has.

Exit 0: passed; 1: failed.
"""

import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    with tempfile.TemporaryDirectory() as tmp:
        bin_dir = os.path.join(tmp, "bin")
        os.makedirs(bin_dir)
        chromium = os.path.join(bin_dir, "chromium")
        with open(chromium, "w") as f:
            f.write("#!/bin/sh\nexit 1\n")
        os.chmod(chromium, 0o755)
        pil = os.path.join(tmp, "py", "PIL")
        os.makedirs(pil)
        with open(os.path.join(pil, "__init__.py"), "w") as f:
            f.write("raise ModuleNotFoundError(\"No module named 'PIL'\", name='PIL')\n")
        env = dict(os.environ)
        env["PATH"] = bin_dir + os.pathsep + env.get("PATH", "")
        env["PYTHONPATH"] = os.path.join(tmp, "py")
        r = subprocess.run([sys.executable, os.path.join(HERE, "viewer_browser_test.py"),
                            "--numen", "/bin/false", "--out", os.path.join(tmp, "out")],
                           env=env, capture_output=True, text=True, timeout=60)
        out = r.stdout + r.stderr
        if r.returncode != 77 or "SKIPPED: the Python module PIL is not installed" not in out:
            print("FAIL: expected exit 77 and a skip naming PIL, got %d:\n%s" % (r.returncode, out))
            return 1
        print("ok: " + r.stdout.strip())
        return 0


if __name__ == "__main__":
    sys.exit(main())
