"""Wear-unaware baseline: OMPL RRTConnect + path simplification per leg (today's practice, no cable)."""

from __future__ import annotations

import time

import numpy as np

from dresspack_gym.tasks import Task
from dresspack_gym.trajectory import Trajectory

from .base import Planner, PlanningError


def _ompl():
    try:
        import ompl.base as ob
        import ompl.geometric as og
        import ompl.util as ou
    except ImportError:  # plain `import ompl` may succeed without the compiled part
        raise PlanningError("the OMPL planners need OMPL's Python bindings: pip install 'ompl>=2.0.1'") from None
    return ob, og, ou


_SEEDED = []


def _seed_ompl(ou, seed: int) -> None:
    """OMPL takes one global seed, before its first random number generator exists (once per process)."""
    if not _SEEDED:
        ou.RNG.setSeed(seed + 1)  # OMPL treats 0 as "random"
        ou.setLogLevel(ou.LogLevel.LOG_WARN)
        _SEEDED.append(seed)


class OmplPlanner(Planner):
    """Joint-space RRTConnect with limits + joint restrictions + collision as validity; shortest-time leg."""

    name = "ompl"

    def __init__(self, *args, simplify: bool = True, **kwargs):
        super().__init__(*args, **kwargs)
        self.simplify = simplify
        self.ob, self.og, ou = _ompl()
        _seed_ompl(ou, self.seed)
        ob, og = self.ob, self.og
        limits = self.validity.limits
        self.space = ob.RealVectorStateSpace(6)
        bounds = ob.RealVectorBounds(6)
        for j in range(6):
            bounds.setLow(j, float(limits[j, 0]))
            bounds.setHigh(j, float(limits[j, 1]))
        self.space.setBounds(bounds)
        self.setup = og.SimpleSetup(self.space)
        self.setup.setStateValidityChecker(self._valid_state)
        si = self.setup.getSpaceInformation()
        validity = self.validity

        class ContinuousMotionValidator(ob.MotionValidator):  # OMPL's default only samples the motion
            def checkMotion(self, a, b):
                return bool(validity.segment_valid(np.fromiter((a[j] for j in range(6)), float, 6),
                                                   np.fromiter((b[j] for j in range(6)), float, 6)))

        self._motion_validator = ContinuousMotionValidator(si)  # kept alive: OMPL holds a raw reference
        si.setMotionValidator(self._motion_validator)
        self.si = si

    def _valid_state(self, s) -> bool:
        return bool(self.validity.valid(np.fromiter((s[j] for j in range(6)), float, 6)))  # OMPL needs a bool

    def _state(self, q):
        s = self.space.allocState()
        for j in range(6):
            s[j] = float(q[j])
        return s

    def connect(self, q0: np.ndarray, q1: np.ndarray, budget: float, planner: str = "RRTConnect") -> np.ndarray:
        """Waypoints (K, 6) from q0 to q1: the straight segment if it is valid, else an OMPL path."""
        if self.validity.segment_valid(q0, q1):
            return np.array([q0, q1])
        self.setup.clear()
        self.setup.setStartAndGoalStates(self._state(q0), self._state(q1))
        self.setup.setPlanner(getattr(self.og, planner)(self.si))
        solved = self.setup.solve(max(0.05, budget))
        if not solved or not self.setup.haveExactSolutionPath():
            a, b = np.round(np.degrees(q0), 1).tolist(), np.round(np.degrees(q1), 1).tolist()
            raise PlanningError(f"{self.name}: no collision-free path found within {budget:.1f} s between {a} and "
                                f"{b} deg")
        if self.simplify:
            self.setup.simplifySolution(max(0.05, min(1.0, self.remaining())))
        path = self.setup.getSolutionPath()
        pts = np.array([[path.getState(i)[j] for j in range(6)] for i in range(path.getStateCount())])
        pts[0], pts[-1] = q0, q1
        return self._shortcut(pts)

    def _shortcut(self, pts: np.ndarray) -> np.ndarray:
        """Drop waypoints whose neighbours can be joined directly (each stop costs time)."""
        out = [pts[0]]
        i = 0
        while i < len(pts) - 1:
            j = len(pts) - 1
            while j > i + 1 and not self.validity.segment_valid(pts[i], pts[j]):
                j -= 1
            out.append(pts[j])
            i = j
        return np.array(out)

    def connect_stops(self, task: Task, budget: float) -> list[np.ndarray]:
        """One path per leg (start -> welds -> Home); the budget is shared out over the remaining legs."""
        stops = task.waypoints()
        end = min(self.deadline, time.perf_counter() + budget)
        n = len(stops) - 1
        return [self.connect(a, b, max(0.0, end - time.perf_counter()) / (n - k))
                for k, (a, b) in enumerate(zip(stops[:-1], stops[1:]))]

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        traj = Trajectory.from_legs(self.connect_stops(task, self.time_budget))
        return traj, {"duration": self.duration(traj), "waypoints": len(traj.waypoints)}
