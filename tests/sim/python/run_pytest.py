"""CTest entry of the Python module's tests (tests/CMakeLists.txt): runs pytest on this folder.

Exits 77 (CTest: skipped) only when pytest or numpy is missing from this interpreter
(Debian: python3-pytest, python3-numpy); PYTHONPATH names the build's module folder.
"""
import os
import sys

try:
    import numpy  # noqa: F401
    import pytest
except ImportError as e:
    print(f"skipped: {e} (install python3-pytest python3-numpy)")
    sys.exit(77)

sys.exit(pytest.main([os.path.dirname(os.path.abspath(__file__)), "-q", "-p", "no:cacheprovider",
                      *sys.argv[1:]]))
