"""dresspack-gym: wear-aware motion planning for industrial robots with simulated cable dresspacks."""

import os

# Offscreen rendering on headless machines needs EGL, chosen when mujoco is first imported.
if "DISPLAY" not in os.environ:
    os.environ.setdefault("MUJOCO_GL", "egl")

from .errors import ConfigError, DresspackError, KinematicsError, SimulationError

__version__ = "0.1.0"

ENV_IDS = {
    "dresspack_gym/StudWelding-v0": "default",
    "dresspack_gym/ThesisCurvature-v0": "thesis_curvature",
    "dresspack_gym/ThesisTension-v0": "thesis_tension",
    "dresspack_gym/ThesisDistance-v0": "thesis_distance",
}


def _register_envs() -> None:
    import gymnasium

    for env_id, station in ENV_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="dresspack_gym.env:DresspackEnv", kwargs={"station": station})


_register_envs()

__all__ = ["ENV_IDS", "ConfigError", "DresspackError", "KinematicsError", "SimulationError", "__version__"]
