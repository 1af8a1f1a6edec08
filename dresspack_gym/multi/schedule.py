"""Timed robot programs on one station clock: legs (paths under the time law, stopping at or flying by their via
points), welds, waits.

Where every robot is at any time ``t`` is answered here only (the coordination check, the station replay and the
Gantt chart all read it), so they cannot disagree about the timing."""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from itertools import pairwise
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..io.artefacts import read_json, read_npz, reading
from ..physics.trajectory import Trajectory
from ..robots import time_law

# what a robot does at a time of the station clock (RobotSchedule.phase_at indexes this); "done" is standing at
# Home after its last leg, until the station's makespan
PHASES = ("moving", "welding", "waiting", "done")


@dataclass(frozen=True)
class RobotSchedule:
    """Robot ``robot`` leaves Home, welds ``welds`` in order (``weld_time`` standing still at each) and returns
    Home. ``legs[k]`` are the waypoints of the motion into stop k (the welds, then Home); the motion of leg k
    starts at ``leg_start[k]`` [s]. ``fly_by[k]``: leg k flies by its via points instead of stopping at each
    (:class:`~dresspack_gym.robots.time_law.PathMotion`; empty: no leg does). A robot that is not moving, welding or
    done is waiting where it is."""

    robot: int
    welds: tuple[str, ...]
    legs: tuple[np.ndarray, ...]
    leg_start: np.ndarray
    limits: time_law.JointLimits  # (6,) joint limits of the time law (velocity at the programmed speed fraction)
    weld_time: float
    fly_by: tuple[bool, ...] = ()
    # per leg, its timed motion: built from ``legs`` and ``fly_by``, kept by ``delayed`` (same legs, other start
    # times); a copy with other legs must pass _motions=None
    _motions: tuple = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        fly = tuple(bool(x) for x in self.fly_by) or (False,) * len(self.legs)
        if len(fly) != len(self.legs):
            raise ValueError(f"fly_by has {len(fly)} entries for {len(self.legs)} legs")
        object.__setattr__(self, "fly_by", fly)
        motions = self._motions or tuple(time_law.PathMotion(leg, self.limits, f) for leg, f in zip(self.legs, fly))
        object.__setattr__(self, "_motions", motions)
        object.__setattr__(self, "_leg_durations", np.array([m.duration for m in motions]))
        # legs that move at all (a robot without welds has a leg from Home to Home): next_motion reads it often
        object.__setattr__(self, "_leg_moves", np.array([m.duration > 0 and bool(np.any(leg[1:] != leg[0]))
                                                         for m, leg in zip(motions, self.legs)], dtype=bool))
        object.__setattr__(self, "leg_start", np.asarray(self.leg_start, dtype=float))

    @staticmethod
    def as_soon_as_possible(robot: int, welds, legs, limits: time_law.JointLimits, weld_time: float,
                            start: float = 0.0, motions=None) -> RobotSchedule:
        """Every leg starts as soon as the previous weld is done (no waits). ``motions``: the legs' timed motions
        (time_law.PathMotion, e.g. flying by their via points); default: stopping at each."""
        legs = tuple(np.asarray(x, dtype=float) for x in legs)
        motions = tuple(motions) if motions is not None else tuple(time_law.PathMotion(leg, limits) for leg in legs)
        fly = tuple(m.fly_by for m in motions)
        starts, t = [], start
        for k, m in enumerate(motions):
            starts.append(t)
            t += m.duration
            if k < len(welds):
                t += weld_time
        return RobotSchedule(robot, tuple(welds), legs, np.array(starts), limits, float(weld_time), fly, motions)

    # ---------------------------------------------------------------------------- timing
    def motions(self) -> tuple:
        """Each leg's timed motion (time_law.PathMotion), as it runs."""
        return self._motions

    def leg_durations(self) -> np.ndarray:
        return self._leg_durations

    def leg_end(self) -> np.ndarray:
        return self.leg_start + self.leg_durations()

    @property
    def end_time(self) -> float:
        """When the robot is back Home."""
        return float(self.leg_end()[-1])

    def earliest_start(self, k: int) -> float:
        """The earliest the motion of leg ``k`` can start: when the weld before it is done."""
        return 0.0 if k == 0 else float(self.leg_end()[k - 1] + self.weld_time)

    def waits(self) -> np.ndarray:
        """Seconds waited before each leg (beyond the weld before it)."""
        return np.array([self.leg_start[k] - self.earliest_start(k) for k in range(len(self.legs))])

    def delayed(self, k: int, delay: float) -> RobotSchedule:
        """Leg ``k`` and every later leg start ``delay`` seconds later."""
        starts = self.leg_start.copy()
        starts[k:] += delay
        return replace(self, leg_start=starts)  # same legs: their timed motions are kept

    def intervals(self) -> dict[str, list[tuple[float, float]]]:
        """(start, end) of each motion, weld and wait (for the Gantt chart)."""
        ends = self.leg_end()
        out = {"motion": [], "weld": [], "wait": []}
        for k in range(len(self.legs)):
            if self.leg_start[k] > self.earliest_start(k) + 1e-9:
                out["wait"].append((self.earliest_start(k), float(self.leg_start[k])))
            out["motion"].append((float(self.leg_start[k]), float(ends[k])))
            if k < len(self.welds):
                out["weld"].append((float(ends[k]), float(ends[k] + self.weld_time)))
        return out

    def phase_at(self, t) -> np.ndarray:
        """(N,) indices into :data:`PHASES` of what the robot does at times ``t`` (N,): moving, welding, waiting
        (stood at its last stop before a leg) or done (Home again)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.full(len(t), PHASES.index("waiting"))
        intervals = self.intervals()
        for name, phase in (("motion", "moving"), ("weld", "welding")):
            for a, b in intervals[name]:
                out[(t >= a) & (t < b)] = PHASES.index(phase)
        out[t >= self.end_time] = PHASES.index("done")
        return out

    # --------------------------------------------------------------------------- where
    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities at times ``t`` (N,): ((N, 6), (N, 6)); Home before and after."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        k = np.searchsorted(self.leg_start, t, side="right") - 1  # the last leg started by t (-1: none yet)
        q = np.broadcast_to(self.legs[0][0], (len(t), 6)).copy()
        qd = np.zeros((len(t), 6))
        for leg in np.unique(k[k >= 0]):
            rows = np.flatnonzero(k == leg)
            q[rows], qd[rows] = self._motions[leg].at(t[rows] - self.leg_start[leg])  # at rest after its end
        return q, qd

    def next_motion(self, t: float) -> float:
        """The earliest time >= ``t`` at which the robot moves (``t`` if it is moving; inf once it is Home for
        good)."""
        live = (self.leg_end() > t) & self._leg_moves
        return float(max(t, self.leg_start[live].min())) if live.any() else np.inf

    def trajectory(self) -> Trajectory:
        """The robot's path as a single-robot trajectory (stops at the welds and Home; timing without waits)."""
        return Trajectory.from_legs(list(self.legs))


@dataclass(frozen=True)
class StationSchedule:
    """One schedule per robot of the station, on one clock."""

    robots: tuple[RobotSchedule, ...]
    homes: np.ndarray  # (n_robots, 6)

    @property
    def makespan(self) -> float:
        return max((r.end_time for r in self.robots), default=0.0)

    def at(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Every robot's joints and velocities at times ``t`` (N,): ((N, n_robots, 6), (N, n_robots, 6))."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q = np.broadcast_to(self.homes, (len(t), *self.homes.shape)).copy()
        qd = np.zeros_like(q)
        for r in self.robots:
            q[:, r.robot], qd[:, r.robot] = r.at(t)
        return q, qd

    def with_robot(self, schedule: RobotSchedule) -> StationSchedule:
        return replace(self, robots=tuple(schedule if r.robot == schedule.robot else r for r in self.robots))

    def robot(self, index: int) -> RobotSchedule | None:
        return next((r for r in self.robots if r.robot == index), None)

    def total_wait(self) -> float:
        return float(sum(r.waits().sum() for r in self.robots))


def load_schedule(folder, station) -> tuple[StationSchedule, dict]:
    """The schedule of a plan folder written by ``dresspack station-plan`` (plan.json and one trajectory per
    robot) on ``station`` (a ``Station``, whose robots the plan must name in order), and plan.json's content.
    Each leg is timed again by the time law, flying by its via points as the plan did."""
    folder = Path(folder)
    if not (folder / "plan.json").is_file():
        raise ConfigError("station_plans", f"{folder} holds no plan.json: give folders written by "
                                           "`dresspack station-plan` (e.g. station_plans/time)")
    what = "station plan (plan.json of `dresspack station-plan`)"
    data = read_json(folder / "plan.json", "station_plans", what, keys=("robots", "config"))
    cfg = station.config
    names = [r.name for r in cfg.robots]
    if not isinstance(data["robots"], dict) or not isinstance(data["config"], dict) \
            or "weld_time" not in data["config"]:
        raise ConfigError("station_plans", f"{folder / 'plan.json'} is not a {what}: its robots or config.weld_time "
                                           "are missing")
    if list(data["robots"]) != names:
        raise ConfigError("station", f"the plan in {folder} is for robots {list(data['robots'])}, station "
                                     f"{cfg.name!r} has {names}: give the station it was planned on")
    robots = []
    with reading(folder / "plan.json", "station_plans", what):  # wrong types or sizes inside a readable file
        weld_time = float(data["config"]["weld_time"])
        for r, (name, info) in enumerate(data["robots"].items()):
            limits = cfg.robots[r].robot.joint_motion_limits.at_speed(cfg.simulation.speed_fraction)
            npz = read_npz(folder / str(info["trajectory"]), "station_plans", "trajectory (.npz)",
                           keys=("waypoints", "stops"))
            waypoints, stops = npz["waypoints"], np.r_[0, npz["stops"]]
            meta = json.loads(str(npz["meta"])) if "meta" in npz else {}
            legs = tuple(waypoints[a:b + 1] for a, b in pairwise(stops))
            # the trajectory's meta keeps the legs' start times unrounded (plan.json rounds them to 0.1 ms)
            starts = np.array(meta.get("leg_start", info["leg_start"]), dtype=float)
            robots.append(RobotSchedule(r, tuple(info["welds"]), legs, starts, limits, weld_time,
                                        tuple(info.get("fly_by", ()))))
    return StationSchedule(tuple(robots), station.home.copy()), data
