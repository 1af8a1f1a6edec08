"""Headless test runs render through EGL, whichever module a test imports first (mujoco fixes its GL at import)."""

import os

import pytest

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture
def busy_machine():
    """Two processes spinning on the CPU (a machine busy with other work) while the test runs."""
    import subprocess
    import sys

    spin = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    yield
    for p in spin:
        p.kill()
        p.wait()
