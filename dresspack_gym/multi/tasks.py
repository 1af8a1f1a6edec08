"""Station tasks: a set of welds shared by several robots, and every (robot, IK branch) that may weld each one.

A one-robot station is the one-robot case of the same task (no second code path). Weld options are filtered
exactly as single-robot tasks filter weld goals (:func:`tasks.allowed_weld_configurations`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, KinematicsError
from ..fields import check_number
from ..robots.kinematics import weld_configurations
from ..stations.station import Station
from ..stations.tasks import allowed_weld_configurations

DEFAULT_WELD_TIME = 1.0  # [s] a robot stands still at each weld (stud welding: arc ~0.1-0.5 s plus gun cycle)
DIVERSE_DEG = 15.0  # weld options closer than this in every joint are one option (the planners stop nearby)


@dataclass(frozen=True)
class WeldOption:
    """One way to weld: ``weld`` by ``robot`` (index) at configuration ``q`` [rad]."""

    weld: str
    robot: int
    q: np.ndarray


@dataclass(frozen=True)
class StationTask:
    """Weld every one of ``weld_names`` once, each by one of the robots that can, every robot starting and ending
    at its Home; ``weld_time`` [s] standing still per weld. ``options[w]`` lists the ways to weld ``w``."""

    weld_names: tuple[str, ...]
    homes: np.ndarray  # (n_robots, 6) rad
    options: dict[str, tuple[WeldOption, ...]]
    weld_time: float = DEFAULT_WELD_TIME

    @property
    def n_robots(self) -> int:
        return len(self.homes)

    def candidates(self, weld: str) -> list[int]:
        """The robots that can weld ``weld``."""
        return sorted({o.robot for o in self.options[weld]})


def robot_weld_configurations(station: Station, robot: int, weld: str) -> np.ndarray:
    """IK solutions of weld point ``weld`` for any robot of the station (the weld's own robot: the cached ones)."""
    cfg = station.config
    w = next(w for w in cfg.weld_points if w.name == weld)
    if cfg.robot_index(w.robot) == robot:
        return station.weld_configurations[weld]
    try:
        return weld_configurations(station.robots[robot].kinematics, w)
    except KinematicsError:
        return np.zeros((0, 6))


def diverse(q: np.ndarray, home: np.ndarray, min_deg: float = DIVERSE_DEG) -> np.ndarray:
    """``q`` sorted by their largest joint change from ``home``, keeping only those that differ from every kept
    one by more than ``min_deg`` in some joint (a deterministic thinning of near-duplicate IK branches)."""
    q = np.asarray(q, dtype=float).reshape(-1, 6)
    order = np.argsort(np.max(np.abs(q - home), axis=1), kind="stable")
    kept: list[np.ndarray] = []
    tol = np.radians(min_deg)
    for x in q[order]:
        if all(np.max(np.abs(x - k)) > tol for k in kept):
            kept.append(x)
    return np.array(kept).reshape(-1, 6)


def make_station_task(station: Station, collides_of, welds: list[str] | None = None, *,
                      weld_time: float = DEFAULT_WELD_TIME, fixed_assignment: bool = False,
                      field: str = "welds") -> StationTask:
    """The station task over ``welds`` (default: every weld point). ``collides_of(robot)`` gives that robot's
    station-collision query. Every robot that reaches a weld may take it (its YAML ``robot`` only with
    ``fixed_assignment``). A weld no robot can take is a ConfigError naming it and saying why."""
    weld_time = check_number(weld_time, "weld_time", lo=0.0, hi=600.0, unit="s")
    cfg = station.config
    names = [w.name for w in cfg.weld_points]
    if welds is not None:
        unknown = [w for w in welds if w not in names]
        if unknown:
            raise ConfigError(field, f"unknown weld point(s) {unknown}; the station's weld points are {names}")
        if len(set(welds)) != len(welds):
            raise ConfigError(field, "a weld point is listed twice: each is welded once")
        names = list(welds)
    if not names:
        raise ConfigError(field, f"station {cfg.name!r} has no weld points to plan")
    owner = {w.name: cfg.robot_index(w.robot) for w in cfg.weld_points}
    options: dict[str, tuple[WeldOption, ...]] = {}
    for name in names:
        robots = [owner[name]] if fixed_assignment else range(station.n_robots)
        found, why = [], []
        for r in robots:
            q = robot_weld_configurations(station, r, name)
            if not len(q):
                why.append(f"{cfg.robots[r].name}: out of reach")
                continue
            free = allowed_weld_configurations(station, r, name, collides_of(r), q=q)
            if not len(free):
                why.append(f"{cfg.robots[r].name}: every IK branch breaks a joint restriction, the robustness map "
                           "or collides with the station")
                continue
            found += [WeldOption(name, r, x) for x in diverse(free, cfg.robots[r].home)]
        if not found:
            raise ConfigError(f"weld_points.{name}", "no robot can weld it (" + "; ".join(why) + ")")
        options[name] = tuple(found)
    return StationTask(tuple(names), station.home.copy(), options, float(weld_time))
