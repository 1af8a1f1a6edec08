"""OMPL in joint space: RRTConnect + simplification between two configurations, seeded per plan, iteration-bounded."""

from __future__ import annotations

import numpy as np

from dresspack_gym.stations.validity import MotionValidity

from .base import PlanningError
from .budget import Allowance

# Termination-condition checks the path simplifier may use per connection (it usually converges before).
SIMPLIFY_CHECKS = 200


def _ompl():
    try:
        import ompl.base as ob
        import ompl.geometric as og
        import ompl.util as ou
    except ImportError:  # plain `import ompl` may succeed without the compiled part
        raise PlanningError("the OMPL planners need OMPL's Python bindings: pip install 'ompl>=2.0.1'") from None
    return ob, og, ou


def seed_ompl(seed: int) -> None:
    """Restart OMPL's seed generator: every OMPL random number generator created afterwards (samplers, the
    planner's, the simplifier's) draws its seed from it in creation order, so a setup built after this call
    repeats exactly. OMPL logs an error when a seed is set after generators exist; that is the point here."""
    _, _, ou = _ompl()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    ou.RNG.setSeed(int(seed) + 1)  # OMPL reads 0 as "random"
    ou.setLogLevel(ou.LogLevel.LOG_WARN)


def joint_space(limits: np.ndarray):
    """OMPL's state space of a 6-axis robot's joints within ``limits`` (6, 2) [rad]."""
    ob, _, _ = _ompl()
    space = ob.RealVectorStateSpace(6)
    bounds = ob.RealVectorBounds(6)
    for j in range(6):
        bounds.setLow(j, float(limits[j, 0]))
        bounds.setHigh(j, float(limits[j, 1]))
    space.setBounds(bounds)
    return space


class _Counter:
    """A termination condition that stops after ``limit`` checks (one per planner iteration) or at the deadline."""

    def __init__(self, limit: int, allowance: Allowance):
        self.limit, self.allowance, self.count = limit, allowance, 0

    def __call__(self) -> bool:
        self.count += 1
        return self.count > self.limit or self.allowance.out_of_time()


class OmplConnector:
    """Connects two configurations with RRTConnect under ``validity`` (limits, joint restrictions, continuous
    collision checks); :meth:`reseed` once per plan makes every later connection of that plan reproducible."""

    def __init__(self, validity: MotionValidity, method: str, simplify: bool = True):
        self.ob, self.og, _ = _ompl()
        self.validity = validity
        self.method = method
        self.simplify = simplify
        self.setup = None
        self.iterations_used = 0

    def reseed(self, seed: int) -> None:
        """Seed OMPL and build a fresh setup (its simplifier's generator is seeded at construction)."""
        seed_ompl(seed)
        ob, og = self.ob, self.og
        space = joint_space(self.validity.limits)
        setup = og.SimpleSetup(space)
        validity = self.validity
        setup.setStateValidityChecker(lambda s: bool(validity.valid(_vector(s))))  # OMPL needs a bool
        si = setup.getSpaceInformation()

        class ContinuousMotionValidator(ob.MotionValidator):  # OMPL's default only samples the motion
            def checkMotion(self, a, b):
                return bool(validity.segment_valid(_vector(a), _vector(b)))

        self._motion_validator = ContinuousMotionValidator(si)  # kept alive: OMPL holds a raw reference
        si.setMotionValidator(self._motion_validator)
        self.space, self.setup, self.si = space, setup, si
        self.iterations_used = 0

    def _state(self, q):
        s = self.space.allocState()
        for j in range(6):
            s[j] = float(q[j])
        return s

    def connect(self, q0: np.ndarray, q1: np.ndarray, iterations: int, allowance: Allowance) -> np.ndarray:
        """Waypoints (K, 6) from q0 to q1: the straight segment if it is valid, else an OMPL path found within
        ``iterations`` planner iterations (and the wall cap, if any)."""
        if self.validity.segment_valid(q0, q1):
            return np.array([q0, q1])
        if self.setup is None:
            raise RuntimeError("OmplConnector.reseed() must be called before connect()")
        ob = self.ob
        self.setup.clear()
        self.setup.setStartAndGoalStates(self._state(q0), self._state(q1))
        self.setup.setPlanner(self.og.RRTConnect(self.si))
        stop = _Counter(iterations, allowance)
        solved = self.setup.solve(ob.PlannerTerminationCondition(stop))
        self.iterations_used += stop.count
        if not solved or not self.setup.haveExactSolutionPath():
            a, b = np.round(np.degrees(q0), 1).tolist(), np.round(np.degrees(q1), 1).tolist()
            why = "the wall-time cap" if allowance.out_of_time() else f"{iterations} iterations"
            raise PlanningError(f"{self.method}: no collision-free path found within {why} between {a} and "
                                f"{b} deg")
        if self.simplify:
            self.setup.simplifySolution(ob.PlannerTerminationCondition(_Counter(SIMPLIFY_CHECKS, allowance)))
        path = self.setup.getSolutionPath()
        pts = np.array([[path.getState(i)[j] for j in range(6)] for i in range(path.getStateCount())])
        pts[0], pts[-1] = q0, q1
        return self.shortcut(pts)

    def shortcut(self, pts: np.ndarray) -> np.ndarray:
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


def _vector(s) -> np.ndarray:
    return np.fromiter((s[j] for j in range(6)), float, 6)
