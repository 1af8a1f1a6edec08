"""Welding tasks: start at Home, visit weld configurations in order, return Home (shared by env and planners)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ConfigError
from .station import Station


@dataclass(frozen=True)
class Task:
    """A cycle for one robot: ``start`` -> each of ``goals`` in order (weld configurations) -> ``end``."""

    robot: int
    start: np.ndarray  # (6,) rad
    weld_names: tuple[str, ...]
    goals: np.ndarray  # (n_welds, 6) rad
    end: np.ndarray  # (6,) rad, Home

    def waypoints(self) -> np.ndarray:
        """The configurations the cycle must pass through, in order: start, welds, end."""
        return np.vstack([self.start, self.goals, self.end])


def random_start(home: np.ndarray, noise: float, rng: np.random.Generator, valid, tries: int = 1000) -> np.ndarray:
    """A valid configuration within ``noise`` [rad] of ``home`` in every joint, by rejection sampling from
    ``rng`` (``valid(q) -> bool``); Home itself if ``tries`` samples find none."""
    for _ in range(tries):
        q = home + rng.uniform(-noise, noise, size=6)
        if valid(q):
            return q
    return home.copy()


def select_weld_goals(station: Station, robot: int, collides, welds: list[str] | None = None,
                      field: str = "welds") -> dict[str, np.ndarray]:
    """Per weld point: the restriction-passing (and, with a map, robust), collision-free IK branch closest to
    Home (smallest largest joint change). ``collides(q)`` is the robot-station collision query."""
    placement = station.config.robots[robot]
    home = placement.home
    names = [w.name for w in station.config.weld_points if w.robot == placement.name]
    if welds is not None:
        unknown = [w for w in welds if w not in names]
        if unknown:
            raise ConfigError(field, f"unknown weld point(s) {unknown}; this robot's weld points are {names}")
        names = list(welds)
    if not names:
        raise ConfigError(field, "the task has no weld points for this robot")
    goals = {}
    for name in names:
        free = [q for q in station.allowed_weld_configurations[name] if not collides(q)]
        if not free:
            robust = " and the robustness map" if placement.robustness_map is not None else ""
            raise ConfigError(f"weld_points.{name}", f"no IK solution passes the joint restrictions{robust} "
                                                      "without colliding with the station")
        free = np.array(free)
        goals[name] = free[np.argmin(np.max(np.abs(free - home), axis=1))]
    return goals


def make_task(station: Station, robot: int, collides, welds: list[str] | None = None) -> Task:
    goals = select_weld_goals(station, robot, collides, welds)
    home = station.config.robots[robot].home.copy()
    return Task(robot, home, tuple(goals), np.array(list(goals.values())).reshape(-1, 6), home)
