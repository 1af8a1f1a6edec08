"""Robot-robot collisions along a station schedule: a continuous check, waits that resolve conflicts the way
cells run (a robot holds where it is until the way is clear), and an independent dense verification.

Robots include the dresspack nodes they carry; the cables themselves are simulated and touch the other robots
physically (robot_model contact bits), so they are measured in the station replay, not checked here."""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import mujoco
import numpy as np

from ..stations.collision import RobotCollisionChecker
from ..stations.station import Station
from .schedule import RobotSchedule, StationSchedule

# [m] clearance kept between two robots while both may move: half what each keeps from the others parked at Home
# (collision.ROBOT_CLEARANCE; segments keep at least that less half the planner margin), so any conflict can be
# waited out
ROBOT_MARGIN = 0.01
WAIT_STEP = 0.25  # [s] a waiting robot re-checks the way this often
MAX_WAIT = 120.0  # [s] a leg waiting longer than this is a conflict waits cannot resolve
DENSE_DT = 0.005  # [s] sampling of the independent verification
MIN_STEP = 1e-3  # [s] smallest step of the continuous check (a clearance this small is a conflict anyway)


class RobotPairDistance:
    """Smallest surface distance between the geoms of two robots posed at given configurations (private MjData)."""

    def __init__(self, station: Station):
        self.station = station
        self.model = station.model
        self.data = station.data_at_home()
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
    """The first time in [t0, t1] that ``mover`` comes closer than ``margin`` to one of ``others``. Continuous,
    not sampled: no robot point moves faster than the joints' reach times their peak speeds (the time law never
    exceeds them), so after a check with clearance d the next can wait until d - margin / 2 could be used up."""
    speed = {s.robot: float(pairs.reach[s.robot] @ s.limits.velocity) for s in [mover, *others]}
    t = t0
    while True:
        q, _ = schedule.at([t])
        pairs.pose(q[0])
        step = np.inf
        for o in others:
            d = pairs.distance(mover.robot, o.robot)
            if d < margin:
                return Conflict(t, mover.robot, o.robot, d)
            step = min(step, _clear_for(d - 0.5 * margin, t, (mover, speed[mover.robot]), (o, speed[o.robot])))
        if t >= t1:
            return None
        t = min(t1, t + max(step, MIN_STEP))


def _clear_for(clearance: float, t: float, a: tuple[RobotSchedule, float], b: tuple[RobotSchedule, float]) -> float:
    """How long after ``t`` two robots (schedule, peak point speed) certainly keep apart by ``clearance``: the
    best of the bounds valid while both move, while only one moves, and while neither does."""
    (sa, va), (sb, vb) = a, b
    ta, tb = sa.next_motion(t) - t, sb.next_motion(t) - t  # how long each still stands still
    bounds = [clearance / (va + vb)]
    bounds.append(min(ta, clearance / vb) if vb > 0 else ta)  # only b moves while a stands
    bounds.append(min(tb, clearance / va) if va > 0 else tb)  # only a moves while b stands
    bounds.append(min(ta, tb))  # neither moves
    return max(bounds)


def coordinate(station: Station, schedule: StationSchedule, pairs: RobotPairDistance | None = None,
               margin: float = ROBOT_MARGIN, order: tuple[int, ...] | None = None,
               cap: float = np.inf) -> tuple[StationSchedule | None, dict]:
    """Resolve robot-robot conflicts by waits: robots are placed one by one in an ``order`` (default: every order
    tried, robots that stay Home first, and the resolved one of the least makespan kept; the first of equals,
    trying the longest programs first); a leg whose motion or following weld meets an already placed robot starts
    later, in ``WAIT_STEP`` steps, the robot holding where it is. Which robot yields changes the waits a lot (one
    order may add seconds where another adds none), so every order is worth its check; an order is dropped as soon
    as its waits already make it no shorter than the best, and the search ends at an order whose waits end no later
    than the program without them. Returns the schedule and
    ``{"order", "waits", "resolved"}``; unresolved conflicts stay (``resolved`` False) and are reported. ``cap``
    [s]: a makespan in hand elsewhere; orders are dropped once they end no sooner, and if every order is, the
    schedule returned is None."""
    pairs = pairs or RobotPairDistance(station)
    # robots that stay Home are placed first (they cannot wait their way out of anything)
    idle = tuple(s.robot for s in schedule.robots if not s.welds)
    busy = sorted((s for s in schedule.robots if s.welds), key=lambda s: (-s.end_time, s.robot))
    orders = [tuple(order)] if order is not None else [idle + tuple(s.robot for s in p) for p in permutations(busy)]
    best, best_order, first = None, None, None
    for o in orders:
        result, ok = _place_in_order(pairs, schedule, o, margin, best.makespan if best is not None else cap)
        if ok:
            best, best_order = result, o
            if best.makespan <= schedule.makespan + 1e-9:
                break  # no waits lengthen it: no order can end sooner
        elif first is None and result is not None:
            first = result
    if best is not None:
        return best, {"order": list(best_order), "waits": best.total_wait(), "resolved": True}
    if first is None:
        return None, {"order": list(orders[0]), "waits": None, "resolved": False}
    return first, {"order": list(orders[0]), "waits": first.total_wait(), "resolved": False}


def _place_in_order(pairs: RobotPairDistance, schedule: StationSchedule, order: tuple[int, ...],
                    margin: float, cap: float = np.inf) -> tuple[StationSchedule | None, bool]:
    """Place the robots one by one; each is checked against those placed before it (the others are not fixed
    yet). A conflict in leg k's motion or weld delays leg k; a conflict while the robot holds at the stop before
    leg k (another robot passes through it there) delays its arrival at that stop, leg k - 1, instead, and the
    check goes back to it. A leg is delayed only as far as needed; later legs keep their times when they can.
    Waits only ever delay, so once the makespan reaches ``cap`` (a better order's) the order is given up:
    (None, False)."""
    placed: list[int] = []
    current = schedule
    for r in order:
        mover = current.robot(r)
        others = [current.robot(p) for p in placed]
        k = 0
        while k < len(mover.legs):
            view = StationSchedule(tuple([mover, *others]), schedule.homes)
            t_from = mover.earliest_start(k) if k else 0.0
            last = k == len(mover.legs) - 1
            t_to = max(view.makespan, current.makespan) + WAIT_STEP if last else \
                mover.leg_end()[k] + (mover.weld_time if k < len(mover.welds) else 0.0)
            hit = first_conflict(pairs, mover, others, view, t_from, t_to, margin) if others else None
            if hit is None:
                k += 1
                continue
            blocker = current.robot(hit.b)
            j = k if hit.time >= mover.leg_start[k] else k - 1  # moving/welding: wait before; holding: arrive later
            if j < 0 or hit.time >= blocker.end_time or mover.waits().sum() + WAIT_STEP > MAX_WAIT:
                # the other robot comes to this one's Home, or is Home for good in its way: waits cannot help
                return current.with_robot(mover), False
            mover = mover.delayed(j, WAIT_STEP)
            if mover.end_time >= cap - 1e-9:
                return None, False
            k = j
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
