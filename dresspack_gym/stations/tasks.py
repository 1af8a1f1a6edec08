"""Welding tasks: start at Home, visit weld configurations in order, return Home (shared by env and planners).

This is the one place weld configurations are filtered (joint restrictions, robustness map, collision)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
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


def allowed_weld_configurations(station: Station, robot: int, name: str, collides=None,
                                q: np.ndarray | None = None) -> np.ndarray:
    """The IK solutions of weld ``name`` a task may use (in IK order): they pass the robot's joint restrictions,
    are robust where the robot has a robustness map (thesis 4.2) and, given ``collides(q)``, do not collide.
    ``q``: the robot's IK solutions when it is not the weld's own robot (default: the station's cached ones)."""
    placement = station.config.robots[robot]
    q = station.weld_configurations[name] if q is None else q
    if len(q):
        ok = placement.restrictions.allowed(q)
        if placement.robustness_map is not None:
            ok &= placement.robustness_map.robust_joints(q)
        q = q[ok]
    if collides is not None:
        q = np.array([x for x in q if not collides(x)]).reshape(-1, 6)
    return q


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
        if name in station.unreachable_welds:
            raise ConfigError(f"weld_points.{name}", station.unreachable_welds[name])
        free = allowed_weld_configurations(station, robot, name, collides)
        if not len(free):
            robust = " and the robustness map" if placement.robustness_map is not None else ""
            raise ConfigError(f"weld_points.{name}", f"no IK solution passes the joint restrictions{robust} "
                                                      "without colliding with the station")
        goals[name] = closest_branch(free, home)
    return goals


def closest_branch(configurations: np.ndarray, home: np.ndarray) -> np.ndarray:
    """The weld goal among allowed IK branches: the one with the smallest largest joint change from Home."""
    return configurations[np.argmin(np.max(np.abs(configurations - home), axis=1))]


def make_task(station: Station, robot: int, collides, welds: list[str] | None = None, field: str = "welds") -> Task:
    goals = select_weld_goals(station, robot, collides, welds, field)
    home = station.config.robots[robot].home.copy()
    return Task(robot, home, tuple(goals), np.array(list(goals.values())).reshape(-1, 6), home)
