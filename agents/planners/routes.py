"""Route generators: candidate legs between two configurations (the first is the wear-unaware reference)."""

from __future__ import annotations

import numpy as np

from dresspack_gym.stations.validity import MotionValidity

from .base import PlanningError
from .budget import Allowance
from .ompl_connect import OmplConnector

VIA_TRIES_PER_ROUTE = 3  # random vias tried per via route wanted (a via may leave no route through it)


class DirectRoute:
    """One candidate: the straight segment, else OMPL's shortest path (today's practice, no cable)."""

    def __init__(self, connector: OmplConnector, iterations: int):
        self.connector = connector
        self.iterations = iterations

    def candidates(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator,
                   allowance: Allowance) -> list[np.ndarray]:
        return [self.connector.connect(a, b, self.iterations, allowance)]


class ViaRoutes:
    """Up to ``n_routes`` candidates: the direct route, then OMPL routes through random via configurations
    (near the leg's midpoint or anywhere in the limits), so other route classes (under an obstacle instead of
    over it) are explored. At most ``VIA_TRIES_PER_ROUTE`` vias per route wanted are tried; each half-route gets
    ``via_iterations``."""

    def __init__(self, connector: OmplConnector, validity: MotionValidity, iterations: int, n_routes: int = 12,
                 via_spread_deg: float = 90.0, via_iterations: int | None = None):
        self.direct = DirectRoute(connector, iterations)
        self.connector = connector
        self.validity = validity
        self.n_routes = n_routes
        self.via_spread = np.radians(via_spread_deg)
        self.via_iterations = via_iterations if via_iterations is not None else max(50, iterations // 10)

    def _sample_via(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> np.ndarray | None:
        lim = self.validity.limits
        for _ in range(50):
            if rng.random() < 0.5:
                q = 0.5 * (a + b) + rng.uniform(-1, 1, 6) * self.via_spread
            else:
                q = rng.uniform(lim[:, 0], lim[:, 1])
            q = np.clip(q, lim[:, 0], lim[:, 1])
            if self.validity.valid(q):
                return q
        return None

    def candidates(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator, allowance: Allowance, *,
                   include_direct: bool = True, limit: int | None = None,
                   via_tries: int | None = None) -> list[np.ndarray]:
        """The direct route (unless ``include_direct`` is False), then via routes: ``limit`` candidates in all
        (default ``n_routes``), from at most ``via_tries`` vias (default ``VIA_TRIES_PER_ROUTE`` per candidate)."""
        limit = self.n_routes if limit is None else limit
        out = []
        if include_direct:
            try:
                out += self.direct.candidates(a, b, rng, allowance)
            except PlanningError:
                pass
        for _ in range(VIA_TRIES_PER_ROUTE * limit if via_tries is None else via_tries):
            if len(out) >= limit or allowance.out_of_time():
                break
            via = self._sample_via(a, b, rng)
            if via is None:
                continue
            try:
                first = self.connector.connect(a, via, self.via_iterations, allowance)
                second = self.connector.connect(via, b, self.via_iterations, allowance)
            except PlanningError:
                continue
            out.append(self.connector.shortcut(np.vstack([first, second[1:]])))
        if not out:
            raise PlanningError(f"{self.connector.method}: no route found between "
                                f"{np.round(np.degrees(a), 1).tolist()} and {np.round(np.degrees(b), 1).tolist()} "
                                "deg within the budget")
        return out
