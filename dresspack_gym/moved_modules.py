"""The import paths of modules that moved into subpackages, kept as deprecated aliases for one release."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import types
import warnings

# old module (under dresspack_gym) -> where it lives now
MOVED = {
    "validation": "fields",
    "kinematics": "robots.kinematics",
    "robot_model": "robots.model",
    "robot_import": "robots.importer",
    "robot_check": "robots.checks",
    "joint_limits": "robots.joint_limits",
    "time_law": "robots.time_law",
    "restrictions": "robots.restrictions",
    "cable_shape": "cable.shape",
    "cable_model": "cable.model",
    "station": "stations.station",
    "station_checks": "stations.checks",
    "collision": "stations.collision",
    "validity": "stations.validity",
    "approach": "stations.approach",
    "weld_sampling": "stations.weld_sampling",
    "tasks": "stations.tasks",
    "rendering": "stations.rendering",
    "simulation": "physics.simulation",
    "measures": "physics.measures",
    "segment_state": "physics.segment_state",
    "damage": "physics.damage",
    "fatigue": "physics.fatigue",
    "wear_cost": "physics.wear_cost",
    "cost_variants": "physics.wear_cost",
    "physics_profiles": "physics.profiles",
    "trajectory": "physics.trajectory",
    "smoothness": "physics.trajectory",
    "twist_sweep": "physics.twist_sweep",
    "station_tasks": "multi.tasks",
    "station_schedule": "multi.schedule",
    "coordination": "multi.coordination",
    "station_replay": "multi.replay",
    "wear_map": "maps.wear_map",
    "map_cost": "maps.map_cost",
    "robustness": "maps.robustness",
    "robustness.algorithm": "maps.robustness.algorithm",
    "robustness.grid": "maps.robustness.grid",
    "robustness.paths": "maps.robustness.paths",
    "robustness.plots": "maps.robustness.plots",
    "robustness.query": "maps.robustness.query",
    "robustness.runner": "maps.robustness.runner",
    "robustness.store": "maps.robustness.store",
    "weld_cycle": "env.weld_cycle",
    "loading": "io.loading",
    "programs": "io.programs",
    "animation": "io.animation",
    "replay_plot": "plots.replay",
    "restriction_plot": "plots.restrictions",
    "damage_plot": "plots.damage",
    "station_plot": "plots.station_plan",
    "cli_args": "cli.args",
    "bench": "cli.bench",
}
# the old ``config`` module was split by what each dataclass configures
SPLIT = {"config": ("robots.config", "cable.config", "stations.config")}


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Resolves ``dresspack_gym.<old>`` to the module that holds its code now (the same module object)."""

    def __init__(self) -> None:
        self.real_specs: dict[str, importlib.machinery.ModuleSpec] = {}

    def find_spec(self, fullname, path=None, target=None):
        old = fullname.removeprefix("dresspack_gym.")
        if fullname.startswith("dresspack_gym.") and (old in MOVED or old in SPLIT):
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        old = spec.name.removeprefix("dresspack_gym.")
        new = MOVED.get(old)
        warnings.warn(f"dresspack_gym.{old} moved to dresspack_gym.{new or ', '.join(SPLIT[old])}; the old path goes "
                      "in the next release", DeprecationWarning, stacklevel=3)
        if new is not None:
            module = importlib.import_module(f"dresspack_gym.{new}")
            self.real_specs[spec.name] = module.__spec__
            return module
        merged = types.ModuleType(spec.name, f"dresspack_gym.{old}, split into {', '.join(SPLIT[old])}")
        for part in SPLIT[old]:
            module = importlib.import_module(f"dresspack_gym.{part}")
            merged.__dict__.update({k: v for k, v in vars(module).items() if not k.startswith("__")})
        return merged

    def exec_module(self, module):
        # the import system has just set the module's __spec__ to the alias's: give the module its own back
        real = self.real_specs.pop(module.__spec__.name, None)
        if real is not None:
            module.__spec__ = real


def install() -> None:
    """Puts the finder first: it answers only for the old names, and ``dresspack_gym.robustness.grid`` would otherwise
    be found again through the aliased package's ``__path__``, as a second copy of the module."""
    if not any(isinstance(f, _MovedModuleFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _MovedModuleFinder())
