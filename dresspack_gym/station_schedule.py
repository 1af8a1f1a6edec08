"""Timed robot programs on one station clock: legs (straight joint segments under the time law), welds, waits.

Where every robot is at any time ``t`` is answered here only (the coordination check, the station replay and the
Gantt chart all read it), so they cannot disagree about the timing."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from . import time_law
from .trajectory import Trajectory

# what a robot does at a time of the station clock (RobotSchedule.phase_at indexes this); "done" is standing at
# Home after its last leg, until the station's makespan
PHASES = ("moving", "welding", "waiting", "done")


@dataclass(frozen=True)
class RobotSchedule:
    """Robot ``robot`` leaves Home, welds ``welds`` in order (``weld_time`` standing still at each) and returns
    Home. ``legs[k]`` are the waypoints of the motion into stop k (the welds, then Home); the motion of leg k
    starts at ``leg_start[k]`` [s]. A robot that is not moving, welding or done is waiting where it is."""

    robot: int
    welds: tuple[str, ...]
    legs: tuple[np.ndarray, ...]
    leg_start: np.ndarray
    limits: time_law.JointLimits  # (6,) joint limits of the time law (velocity at the programmed speed fraction)
    weld_time: float
    _table: tuple = field(default=None, repr=False, compare=False)
    # per leg, its segments' timed motions: built from ``legs``, kept by ``delayed`` (same legs, other start times);
    # a copy with other legs must pass _motions=None
    _motions: tuple = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        motions = self._motions or tuple(tuple(time_law.SegmentMotion(dq, self.limits) for dq in np.diff(leg, axis=0))
                                         for leg in self.legs)
        object.__setattr__(self, "_motions", motions)
        durations = [np.array([m.duration for m in leg]) for leg in motions]
        object.__setattr__(self, "_leg_durations", np.array([float(d.sum()) for d in durations]))
        t0, d, a, b = [], [], [], []
        for start, leg, dur in zip(self.leg_start, self.legs, durations):
            offsets = np.concatenate([[0.0], np.cumsum(dur)[:-1]])
            t0.append(start + offsets)
            d.append(dur)
            a.append(leg[:-1])
            b.append(leg[1:])
        table = (np.concatenate(t0), np.concatenate(d), np.concatenate(a), np.concatenate(b))
        object.__setattr__(self, "_table", table)
        object.__setattr__(self, "_segment_motions", [m for leg in motions for m in leg])
        object.__setattr__(self, "leg_start", np.asarray(self.leg_start, dtype=float))

    @staticmethod
    def as_soon_as_possible(robot: int, welds, legs, limits: time_law.JointLimits, weld_time: float,
                            start: float = 0.0) -> RobotSchedule:
        """Every leg starts as soon as the previous weld is done (no waits)."""
        starts, t = [], start
        for k, leg in enumerate(legs):
            starts.append(t)
            t += time_law.path_duration(leg, limits)
            if k < len(welds):
                t += weld_time
        return RobotSchedule(robot, tuple(welds), tuple(np.asarray(x, dtype=float) for x in legs),
                             np.array(starts), limits, float(weld_time))

    # ---------------------------------------------------------------------------- timing
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
        return replace(self, leg_start=starts, _table=None)  # same legs: their timed motions are kept

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
        t0, dur, a, b = self._table
        k = np.searchsorted(t0, t, side="right") - 1
        q = np.empty((len(t), 6))
        qd = np.zeros((len(t), 6))
        before = k < 0
        q[before] = self.legs[0][0]
        k = np.clip(k, 0, len(t0) - 1)
        tau = np.where(dur[k] > 0, (t - t0[k]) / np.where(dur[k] > 0, dur[k], 1.0), 1.0)
        moving = ~before & (tau < 1.0)
        resting = ~before & ~moving
        for seg in np.unique(k[moving]):  # each segment's own timed motion, over the times that fall in it
            rows = np.flatnonzero(moving & (k == seg))
            frac, rate = self._segment_motions[seg].at(t[rows] - t0[seg])
            q[rows] = a[seg] + frac[:, None] * (b[seg] - a[seg])
            qd[rows] = rate[:, None] * (b[seg] - a[seg])
        q[resting] = b[k[resting]]
        return q, qd

    def next_motion(self, t: float) -> float:
        """The earliest time >= ``t`` at which the robot moves (``t`` if it is moving; inf once it is Home for
        good)."""
        t0, dur, a, b = self._table
        live = (t0 + dur > t) & (dur > 0) & np.any(a != b, axis=1)
        return float(max(t, t0[live].min())) if live.any() else np.inf

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
