"""Global wear-aware planner: explores different route classes with OMPL (via random intermediate
configurations), scores every candidate route by simulating the cable along it in path order, keeps the
best and refines it locally. Unlike the thesis's local optimiser it can switch to another route class
(e.g. under an obstacle instead of over it)."""

from __future__ import annotations

import time

import numpy as np

from dresspack_gym.tasks import Task
from dresspack_gym.trajectory import Trajectory

from .base import PlanningError
from .thesis_local import ThesisLocalPlanner


class OmplWearPlanner(ThesisLocalPlanner):
    name = "ompl-wear"

    def __init__(self, *args, n_routes: int = 12, explore_share: float = 0.6, via_spread_deg: float = 90.0,
                 **kwargs):
        super().__init__(*args, **kwargs)
        self.n_routes = n_routes
        self.explore_share = explore_share
        self.via_spread = np.radians(via_spread_deg)

    def _sample_via(self, a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
        """A valid configuration near the leg's midpoint (half the samples) or anywhere in the limits."""
        lim = self.validity.limits
        for _ in range(50):
            if self.rng.random() < 0.5:
                q = 0.5 * (a + b) + self.rng.uniform(-1, 1, 6) * self.via_spread
            else:
                q = self.rng.uniform(lim[:, 0], lim[:, 1])
            q = np.clip(q, lim[:, 0], lim[:, 1])
            if self.validity.valid(q):
                return q
        return None

    def routes(self, a: np.ndarray, b: np.ndarray, until: float) -> list[np.ndarray]:
        """Candidate legs a -> b: the direct/OMPL route and routes through random via configurations."""
        out = []
        try:
            out.append(self.connect(a, b, max(0.1, 0.2 * (until - time.perf_counter()))))
        except PlanningError:
            pass
        while len(out) < self.n_routes and time.perf_counter() < until:
            via = self._sample_via(a, b)
            if via is None:
                continue
            try:
                budget = max(0.05, 0.1 * (until - time.perf_counter()))
                first, second = self.connect(a, via, budget), self.connect(via, b, budget)
            except PlanningError:
                continue
            out.append(self._shortcut(np.vstack([first, second[1:]])))
        if not out:
            raise PlanningError(f"{self.name}: no route found between {np.round(np.degrees(a), 1).tolist()} and "
                                f"{np.round(np.degrees(b), 1).tolist()} deg within the time budget")
        return out

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        stops = task.waypoints()
        state = self.leg_cost.start_state(task.start)
        legs, before, after, explored = [], 0.0, 0.0, 0
        n = len(stops) - 1
        for k, (a, b) in enumerate(zip(stops[:-1], stops[1:])):
            leg_end = self.deadline - self.remaining() * (1 - 1 / (n - k))
            explore_end = time.perf_counter() + self.explore_share * (leg_end - time.perf_counter())
            cands = self.routes(a, b, explore_end)
            scored = sorted(((self.leg_cost.cost(state, c)[0], i) for i, c in enumerate(cands)))
            explored += len(cands)
            best, j_direct = cands[scored[0][1]], self.leg_cost.cost(state, cands[0])[0]
            best, _ = self.improve(state, best, leg_end)
            j, state, _ = self.leg_cost.cost(state, best)
            legs.append(best)
            before, after = before + j_direct, after + j
        info = {"objective_nominal": before, "objective": after, "routes_explored": explored,
                "cable_evaluations": self.leg_cost.evaluations}
        return Trajectory.from_legs(legs), info
