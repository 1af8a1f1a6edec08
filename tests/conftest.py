"""Headless test runs render through EGL, whichever module a test imports first (mujoco fixes its GL at import)."""

import os

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")
