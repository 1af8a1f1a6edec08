"""Global routes from OMPL's asymptotically optimal FMT* over the wear map: the least ∫(1 + weight x map cost rate) dt
between two configurations, on a fixed number of samples (the work unit), seeded per search.

Why FMT* and how the objective is written (both measured on thesis_tension, see the README):
- FMT* checks motions for collisions lazily (~700 continuous checks per search, in Python) where RRT*,
  BIT* and PRM* check every candidate edge; with a fixed sample count it is deterministic and single-threaded.
- The objective is an ``ob.OptimizationObjective`` written here: the state-cost integral over *time*
  (trapezoid of the two ends' rates x the move's time). OMPL's own ``StateCostIntegralObjective`` integrates over
  joint-space length, and in the ompl 2.0.1 bindings its C++ ``motionCost`` does not call a ``stateCost``
  overridden in Python (it silently optimises path length).
- FMT* asks for hundreds of thousands of edge costs per search; each call is a few microseconds of plain Python
  (rates cached per sample, the time from :class:`~dresspack_gym.robots.time_law.AccelerationBound`), so a search of
  1,000 samples takes seconds. The candidate routes are then ranked by the real cable simulation in path order.
"""

from __future__ import annotations

import numpy as np

from dresspack_gym.errors import ConfigError
from dresspack_gym.maps.map_cost import MapStateCost
from dresspack_gym.robots import time_law
from dresspack_gym.stations.validity import MotionValidity

from .map_roadmap import simplify_route
from .ompl_connect import _ompl, _vector, joint_space, seed_ompl

# Samples per FMT* search (its work unit) and the time/wear weights searched per leg (one search each). Measured on
# thesis_tension and its variants (scripts/studies/tension_route_study.py --planner ompl-wear-fmt): see the README's
# "OMPL's FMT* over the map".
FMT_SAMPLES = 1000
FMT_WEIGHTS = (1.0, 10.0)


class TimeWearObjective:
    """∫(1 + weight x C_map) dt along straight moves, as an OMPL optimisation objective (built per search)."""

    @staticmethod
    def build(si, cost: MapStateCost, bound: time_law.AccelerationBound, weight: float):
        ob, _, _ = _ompl()
        rates: dict[tuple, float] = {}  # per sampled state: the rate 1 + weight x C_map (FMT* asks for it often)

        def rate(s) -> tuple[tuple, float]:
            q = (s[0], s[1], s[2], s[3], s[4], s[5])
            r = rates.get(q)
            if r is None:
                r = rates[q] = 1.0 + weight * cost.cost(np.array(q))
            return q, r

        class Objective(ob.OptimizationObjective):
            def stateCost(self, s):
                return ob.Cost(rate(s)[1])

            def motionCost(self, s1, s2):
                q1, r1 = rate(s1)
                q2, r2 = rate(s2)
                return ob.Cost(bound(q1, q2) * 0.5 * (r1 + r2))

        return Objective(si)


class FmtSearch:
    """One robot's FMT* searches over the wear map: :meth:`route` returns the best route found between two
    configurations for one time/wear ``weight`` (ends included, shortened where a direct move is valid and costs
    no more), or None when the samples do not connect them."""

    def __init__(self, validity: MotionValidity, cost: MapStateCost, limits: time_law.JointLimits, *,
                 samples: int = FMT_SAMPLES, radius_multiplier: float = 1.0):
        if isinstance(samples, bool) or not isinstance(samples, int) or not 10 <= samples <= 10**6:
            raise ConfigError("fmt_samples",
                              f"must be an integer in [10, 1000000] (samples per search), got {samples!r}")
        if not 0.1 <= radius_multiplier <= 10.0:
            raise ConfigError("fmt_radius_multiplier", f"must be in [0.1, 10], got {radius_multiplier!r}")
        self.validity, self.cost = validity, cost
        self.bound = time_law.AccelerationBound(limits)
        self.limits = limits
        self.samples, self.radius_multiplier = samples, float(radius_multiplier)
        self.motion_checks = 0
        self._valid: dict[tuple, bool] = {}  # state validity by joint values (the same samples recur per seed)

    def forget(self) -> None:
        """Start a plan afresh (only the work counter: a state's validity never changes)."""
        self.motion_checks = 0

    def route(self, a: np.ndarray, b: np.ndarray, weight: float, rng: np.random.Generator) -> np.ndarray | None:
        """The search's samples come from a seed drawn from ``rng`` (the plan's, reset per plan): they depend on
        the plan's seed and the searches before it in the plan only, never on what ran before the plan."""
        ob, og, _ = _ompl()
        seed_ompl(int(rng.integers(1, 2**31 - 1)))
        space = joint_space(self.validity.limits)
        si = ob.SpaceInformation(space)
        validity, known = self.validity, self._valid

        def state_valid(s) -> bool:
            q = (s[0], s[1], s[2], s[3], s[4], s[5])
            ok = known.get(q)
            if ok is None:
                ok = known[q] = bool(validity.valid(np.array(q)))
            return ok

        search = self

        class ContinuousMotionValidator(ob.MotionValidator):
            def checkMotion(self, s1, s2):
                search.motion_checks += 1
                return bool(validity.segment_valid(_vector(s1), _vector(s2)))

        si.setStateValidityChecker(state_valid)
        checker = ContinuousMotionValidator(si)  # kept alive while OMPL holds a raw reference
        si.setMotionValidator(checker)
        si.setup()
        objective = TimeWearObjective.build(si, self.cost, self.bound, weight)
        pdef = ob.ProblemDefinition(si)
        start, goal = space.allocState(), space.allocState()
        for j in range(6):
            start[j], goal[j] = float(a[j]), float(b[j])
        pdef.setStartAndGoalStates(start, goal)
        pdef.setOptimizationObjective(objective)
        planner = og.FMT(si)
        planner.setNumSamples(self.samples)
        planner.setRadiusMultiplier(self.radius_multiplier)
        planner.setProblemDefinition(pdef)
        planner.setup()
        planner.solve(ob.PlannerTerminationCondition(lambda: False))  # FMT* ends when its samples are used
        if not pdef.hasExactSolution():
            return None
        path = pdef.getSolutionPath()
        pts = np.array([_vector(path.getState(i)) for i in range(path.getStateCount())])
        pts[0], pts[-1] = a, b
        return simplify_route(pts, weight, self.cost, self.limits, self.validity)
