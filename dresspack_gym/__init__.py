"""dresspack-gym: wear-aware motion planning for industrial robots with simulated cable dresspacks."""

import importlib
import os
import sys
import types

# Offscreen rendering on headless machines needs EGL, chosen when mujoco is first imported (an empty DISPLAY, as
# some containers set it, is no display either).
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

from .errors import ConfigError, DresspackError, KinematicsError, SimulationError
from .moved_modules import install as _install_moved_modules

__version__ = "0.1.0"

ENV_IDS = {
    "dresspack_gym/StudWelding-v0": "default",
    "dresspack_gym/ThesisCurvature-v0": "thesis_curvature",
    "dresspack_gym/ThesisTension-v0": "thesis_tension",
    "dresspack_gym/ThesisDistance-v0": "thesis_distance",
}

# The names a user's script needs, importable from the package itself; each loads its subpackage on first use, so
# ``import dresspack_gym`` stays light (no MuJoCo until a name that needs it is asked for).
PUBLIC = {
    "load_station": "io.loading", "Station": "stations.station", "CableSimulator": "physics.simulation",
    "wear_cost": "physics.wear_cost", "Trajectory": "physics.trajectory", "replay": "physics.trajectory",
    "DresspackEnv": "env.dresspack_env", "EnvConfig": "env.config",
}


def __getattr__(name: str):
    if name in PUBLIC:
        return getattr(importlib.import_module(f".{PUBLIC[name]}", __name__), name)
    raise AttributeError(f"module 'dresspack_gym' has no attribute {name!r}")


class _Package(types.ModuleType):
    """The package keeps its public names: importing the old module path of the same name (``dresspack_gym.wear_cost``,
    the module that holds the function ``wear_cost``) would otherwise bind that module over the function."""

    def __setattr__(self, name, value):
        if name in PUBLIC and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def _register_envs() -> None:
    import gymnasium

    for env_id, station in ENV_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="dresspack_gym.env:DresspackEnv",
                               kwargs={"station": station})


_register_envs()
_install_moved_modules()

__all__ = ["ENV_IDS", "ConfigError", "DresspackError", "KinematicsError", "SimulationError", "__version__", *PUBLIC]
