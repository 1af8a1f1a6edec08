"""The routing problem of a station plan: every robot's travel times between its nodes (planned legs exact,
unplanned moves estimated), the options' settled cost rates, the legs' simulated wear and the conflicting options."""

from __future__ import annotations

import numpy as np

from dresspack_gym.multi.coordination import RobotPairDistance
from dresspack_gym.multi.tasks import StationTask, WeldOption
from dresspack_gym.robots import time_law
from dresspack_gym.stations.station import Station

from .legs import LegBook
from .option_costs import OptionCosts
from .solver import RoutingProblem

BLOCKED = 1e4  # [s] the travel time of a move no leg was found for: the solver avoids it
# Two robots' weld options closer than this [m] are a conflict (they cannot weld at once; their legs around
# them likely meet): CONFLICT_WAIT x (weld time + a typical leg) is the time the solver keeps between two such
# welds' starts (for the first robot to weld and leave before the second arrives: an interlock zone), or, in
# its charged model, the wait it charges the pair (solver.INTERLOCKS)
CONFLICT_DISTANCE = 0.15
CONFLICT_WAIT = 1.0


def straight_times(qs: np.ndarray, limits: list[time_law.JointLimits]) -> np.ndarray:
    """(R, N, N) [s] each robot's straight-move time between the nodes ``qs``: a lower bound of any motion
    between them (for the shipped robots' proportional limits the synchronised straight move takes exactly
    its slowest joint's minimum time, and no path is shorter for that joint)."""
    return np.stack([time_law.segment_durations(qs[None, :, :] - qs[:, None, :], limits[r])
                     for r in range(len(limits))])


class ProblemBuilder:
    """Builds :class:`~.solver.RoutingProblem` s of one station; the conflicting option pairs are found once per
    node list (cached)."""

    def __init__(self, station: Station):
        self.station = station
        self._conflicts: dict[bytes, np.ndarray] = {}

    def build(self, task: StationTask, options: list[WeldOption], legs: LegBook, costs: OptionCosts,
              blocked_estimate: str) -> RoutingProblem:
        """The problem over the Homes and ``options``: the legs ``legs`` knows (planned or re-routed) are exact,
        the other moves are straight-move times, or (``blocked_estimate="planned_ratio"``) straight-move times
        slowed like the detours planned so far."""
        R = task.n_robots
        qs = np.vstack([task.homes, np.array([o.q for o in options]).reshape(-1, 6)])
        node_robot = np.concatenate([np.arange(R), [o.robot for o in options]]).astype(int)
        index = {w: k for k, w in enumerate(task.weld_names)}
        node_weld = np.concatenate([np.full(R, -1), [index[o.weld] for o in options]]).astype(int)
        straight = straight_times(qs, legs.limits)
        travel = straight.copy()
        node_of = {}
        for n, (r, q) in enumerate(zip(node_robot, qs)):
            node_of.setdefault((int(r), q.tobytes()), []).append(n)
        simulated = np.full(travel.shape, np.nan)
        weld_after = np.where(node_weld >= 0, task.weld_time, 0.0)
        planned = {k: legs.paths[k] for k in legs.known if k in legs.paths}
        exact, detour = np.zeros(travel.shape, bool), np.zeros(travel.shape, bool)
        for (r, qa, qb), leg in {**planned, **legs.rerouted}.items():  # planned legs are exact
            for i in node_of.get((r, qa), ()):
                for j in node_of.get((r, qb), ()):
                    exact[r, i, j], detour[r, i, j] = True, leg is not None and len(leg) > 2
                    travel[r, i, j] = BLOCKED if leg is None else legs.motion(r, leg).duration
                    run = None if leg is None else legs.runs.get((r, leg.tobytes(), float(weld_after[j])))
                    if run is not None:
                        simulated[r, i, j] = run.wear
        if blocked_estimate == "planned_ratio" and detour.any():
            # every unplanned move is blocked (the valid straight ones are planned legs already): estimate it
            # as its straight move slowed like the detours planned so far, not at the straight move's time
            ratio = float(np.median(travel[detour] / np.maximum(straight[detour], 1e-9)))
            mine = node_robot[None, :] == np.arange(R)[:, None]  # (R, N): robot r's Home and options
            own = mine[:, :, None] & mine[:, None, :]
            travel = np.where(own & ~exact, travel * max(ratio, 1.0), travel)
        rates = np.array([costs.rate(r, q) for r, q in zip(node_robot, qs)])
        key = qs.tobytes() + node_robot.tobytes()
        if key not in self._conflicts:
            self._conflicts[key] = self._find_conflicts(qs, node_robot)
        own = [travel[r][np.ix_(node_robot == r, node_robot == r)] for r in range(R)]
        typical_leg = float(np.median(np.concatenate([t[t > 0] for t in own if (t > 0).any()] or [[0.0]])))
        return RoutingProblem(travel, rates, node_robot, node_weld, task.weld_time, len(task.weld_names),
                              self._conflicts[key], CONFLICT_WAIT * (task.weld_time + typical_leg), simulated)

    def _find_conflicts(self, qs: np.ndarray, node_robot: np.ndarray) -> np.ndarray:
        """Option pairs of different robots whose robots, both at their options (the rest at Home), come within
        CONFLICT_DISTANCE: welding them at once is impossible, and the legs around them likely meet too."""
        pairs = RobotPairDistance(self.station)
        poses = self.station.home.copy()
        R = self.station.n_robots
        out = []
        nodes = np.arange(R, len(qs))
        for a in nodes:
            for b in nodes[nodes > a]:
                ra, rb = int(node_robot[a]), int(node_robot[b])
                if ra == rb:
                    continue
                poses[:] = self.station.home
                poses[ra], poses[rb] = qs[a], qs[b]
                pairs.pose(poses)
                if pairs.distance(ra, rb, cap=CONFLICT_DISTANCE) < CONFLICT_DISTANCE:
                    out.append((int(a), int(b)))
        return np.array(out, dtype=int).reshape(-1, 2)
