"""dresspack-gym: wear-aware motion planning for industrial robots with simulated cable dresspacks."""

import os

# Offscreen rendering on headless machines needs EGL, chosen when mujoco is first imported.
if "DISPLAY" not in os.environ:
    os.environ.setdefault("MUJOCO_GL", "egl")

from .errors import ConfigError, DresspackError, KinematicsError, SimulationError

__version__ = "0.1.0"

__all__ = ["ConfigError", "DresspackError", "KinematicsError", "SimulationError", "__version__"]
