"""Robot-robot collisions along a station schedule: a continuous check, waits that resolve conflicts the way
cells run (a robot holds where it is until the way is clear), and an independent dense verification.

Robots include the dresspack nodes they carry; the cables themselves are simulated and touch the other robots
physically (robot_model contact bits), so they are measured in the station replay, not checked here."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import mujoco
import numpy as np

from .collision import RobotCollisionChecker
from .station import Station
from .station_schedule import RobotSchedule, StationSchedule

ROBOT_MARGIN = 0.02  # [m] clearance kept between two robots (controllers' interference zones add more)
WAIT_STEP = 0.25  # [s] a waiting robot re-checks the way this often
MAX_WAIT = 120.0  # [s] a leg waiting longer than this is a conflict waits cannot resolve
DENSE_DT = 0.005  # [s] sampling of the independent verification


class RobotPairDistance:
    """Smallest surface distance between the geoms of two robots posed at given configurations (private MjData)."""

    def __init__(self, station: Station):
        self.station = station
        self.model = station.model
        self.data = mujoco.MjData(self.model)
        self.data.qpos[:] = self.model.qpos0
        self.data.qpos[station.robot_qpos] = station.home.ravel()
        self.data.qpos[station.load_qpos] = station.load_values
        mujoco.mj_kinematics(self.model, self.data)
        self.rbound = self.model.geom_rbound
        self._fromto = np.zeros(6)
        # the reach of each joint over every robot surface it moves (bounds how far any point moves per radian)
        self.reach = [RobotCollisionChecker(station, i).chain_reach() for i in range(station.n_robots)]

    def pose(self, q_robots: np.ndarray) -> None:
        self.data.qpos[self.station.robot_qpos] = np.asarray(q_robots, dtype=float).ravel()
        mujoco.mj_kinematics(self.model, self.data)

    def distance(self, i: int, j: int, cap: float = 10.0) -> float:
        """Distance between robots ``i`` and ``j`` as last posed (negative: penetration)."""
        gi, gj = self.station.robots[i].geom_ids, self.station.robots[j].geom_ids
        x = self.data.geom_xpos
        lb = (np.linalg.norm(x[gi][:, None] - x[gj][None], axis=2) - self.rbound[gi][:, None] - self.rbound[gj][None])
        best = cap
        flat = lb.ravel()
        for k in np.argsort(flat, kind="stable"):
            if flat[k] >= best:
                break
            a, b = divmod(int(k), len(gj))
            best = min(best, mujoco.mj_geomDistance(self.model, self.data, int(gi[a]), int(gj[b]), best,
                                                    self._fromto))
        return float(best)


@dataclass(frozen=True)
class Conflict:
    """Robots ``a`` and ``b`` closer than the margin at time ``time`` [s] (``distance`` [m])."""

    time: float
    a: int
    b: int
    distance: float


def first_conflict(pairs: RobotPairDistance, mover: RobotSchedule, others: list[RobotSchedule],
                   schedule: StationSchedule, t0: float, t1: float, margin: float = ROBOT_MARGIN) -> Conflict | None:
    """The first time in [t0, t1] that ``mover`` comes closer than ``margin`` to one of ``others`` (continuous:
    between checks no point moves farther than the joints' reach times their change, so the next check is placed
    where the clearance could first be used up)."""
    t = t0
    while True:
        q, _ = schedule.at([t])
        pairs.pose(q[0])
        step = np.inf
        for o in others:
            d = pairs.distance(mover.robot, o.robot)
            if d < margin:
                return Conflict(t, mover.robot, o.robot, d)
            step = min(step, _safe_step(pairs, schedule, (mover.robot, o.robot), t, t1, d - 0.5 * margin))
        if t >= t1:
            return None
        t = min(t1, t + step)


def _safe_step(pairs: RobotPairDistance, schedule: StationSchedule, robots: tuple[int, int], t: float, t1: float,
               clearance: float) -> float:
    """A time step after ``t`` over which the two robots together cannot close ``clearance``: the joint change over
    a trial step bounds the motion of every point (the time law is monotone within a segment; the trial step is
    halved until it crosses no segment boundary where a joint could turn back)."""
    h = max(t1 - t, 1e-3)
    q0, _ = schedule.at([t])
    while h > 1e-3:
        q1, _ = schedule.at([t + h])
        move = sum(float(pairs.reach[r] @ np.abs(q1[0, r] - q0[0, r])) for r in robots)
        crosses = any(np.any((s.segment_times() > t) & (s.segment_times() < t + h))
                      for s in schedule.robots if s.robot in robots)
        if move <= clearance and not crosses:
            return h
        h *= 0.5
    return 1e-3


def coordinate(station: Station, schedule: StationSchedule, pairs: RobotPairDistance | None = None,
               margin: float = ROBOT_MARGIN, order: tuple[int, ...] | None = None) -> tuple[StationSchedule, dict]:
    """Resolve robot-robot conflicts by waits: robots are placed one by one (``order``, default: every order
    tried, robots that stay Home first, then the longest programs first, until one works); a leg whose motion or following weld meets an already
    placed robot starts later, in ``WAIT_STEP`` steps, the robot holding where it is. Returns the schedule and
    ``{"order", "waits", "resolved"}``; unresolved conflicts stay (``resolved`` False) and are reported."""
    pairs = pairs or RobotPairDistance(station)
    # robots that stay Home are placed first (they cannot wait their way out of anything)
    idle = tuple(s.robot for s in schedule.robots if not s.welds)
    busy = sorted((s for s in schedule.robots if s.welds), key=lambda s: (-s.end_time, s.robot))
    orders = [tuple(order)] if order is not None else [idle + tuple(s.robot for s in p) for p in permutations(busy)]
    best = None
    for o in orders:
        result, ok = _place_in_order(pairs, schedule, o, margin)
        if ok:
            return result, {"order": list(o), "waits": result.total_wait(), "resolved": True}
        if best is None:
            best = result
    return best, {"order": list(orders[0]), "waits": best.total_wait(), "resolved": False}


def _place_in_order(pairs: RobotPairDistance, schedule: StationSchedule, order: tuple[int, ...],
                    margin: float) -> tuple[StationSchedule, bool]:
    # each robot is checked against the robots placed before it only (the others are not yet fixed)
    placed: list[int] = []
    current = schedule
    horizon = lambda: current.makespan + WAIT_STEP
    for r in order:
        mover = current.robot(r)
        others = [current.robot(p) for p in placed]
        view = StationSchedule(tuple([mover, *others]), schedule.homes)
        k = 0
        while k < len(mover.legs):
            t_from = mover.earliest_start(k) if k else 0.0
            end = mover.leg_end()[k] + (mover.weld_time if k < len(mover.welds) else 0.0)
            last = k == len(mover.legs) - 1
            hit = first_conflict(pairs, mover, others, view, t_from, horizon() if last else end, margin) \
                if others else None
            if hit is None:
                k += 1
                continue
            if mover.waits()[k] + WAIT_STEP > MAX_WAIT or hit.time < mover.leg_start[k]:
                # a conflict while holding still before the leg: waiting longer cannot help
                return current.with_robot(mover), False
            mover = mover.delayed(k, WAIT_STEP)
            view = StationSchedule(tuple([mover, *others]), schedule.homes)
        current = current.with_robot(mover)
        placed.append(r)
    return current, True


def verify(station: Station, schedule: StationSchedule, dt: float = DENSE_DT, pairs: RobotPairDistance | None = None,
           margin: float = 0.0) -> dict:
    """Independent dense check: every robot pair's distance sampled every ``dt`` over the whole cycle.
    ``{"min_distance", "at", "pair", "samples", "collisions"}`` (collisions: samples closer than ``margin``)."""
    pairs = pairs or RobotPairDistance(station)
    n = station.n_robots
    times = np.arange(0.0, schedule.makespan + dt, dt)
    qs, _ = schedule.at(times)
    best, at, pair, hits = np.inf, 0.0, (0, 0), 0
    for t, q in zip(times, qs):
        pairs.pose(q)
        for i in range(n):
            for j in range(i + 1, n):
                d = pairs.distance(i, j)
                hits += d < margin
                if d < best:
                    best, at, pair = d, float(t), (i, j)
    return {"min_distance": float(best), "at": at, "pair": list(pair), "samples": len(times),
            "collisions": int(hits)}
