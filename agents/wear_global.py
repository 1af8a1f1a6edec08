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

    def _start_leg(self, k: int, state: np.ndarray, a: np.ndarray, b: np.ndarray,
                   until: float) -> tuple[np.ndarray, float]:
        """The best of the explored routes (scored by cable simulation); the reference is the direct route."""
        explore_end = time.perf_counter() + self.explore_share * (until - time.perf_counter())
        cands = self.routes(a, b, explore_end)
        self._explored += len(cands)
        costs = [self.leg_cost.cost(state, c)[0] for c in cands]
        return cands[int(np.argmin(costs))], costs[0]

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        self._explored = 0
        traj, info = self._optimise_legs(task, {})
        info["routes_explored"] = self._explored
        return traj, info
