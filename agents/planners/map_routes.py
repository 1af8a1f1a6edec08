"""Route candidates of the global wear-aware planner: the direct route, the wear map's roadmap routes at several
time/wear trade-offs, then OMPL routes through random via configurations to fill the budget."""

from __future__ import annotations

import numpy as np

from .base import PlanningError
from .budget import Allowance
from .map_roadmap import MapRoadmap
from .routes import ViaRoutes

# Weights of the map cost against motion time in the roadmap searches: a spread of trade-offs, so the candidates
# cover different route classes; the cable simulation then ranks them by the true objective. Routes are
# deterministic (the roadmap depends on no seed), so these candidates are the same for every seed; neighbouring
# weights often give the same route (a duplicate is dropped and its place goes to a via route).
ROADMAP_WEIGHTS = (0.3, 1.0, 3.0, 10.0, 30.0)


class MapRoutes:
    """Up to ``n_routes`` candidates: the direct route, one roadmap route per weight (duplicates dropped), then
    via routes. Without a roadmap (no wear map for this robot and dresspack) only the direct and via routes.
    ``roadmap`` is any global search over the map with ``route(a, b, weight, rng)``: the lazy PRM*
    (:class:`~.map_roadmap.MapRoadmap`) or OMPL's FMT* (:class:`~.fmt_routes.FmtSearch`)."""

    def __init__(self, via: ViaRoutes, roadmap: MapRoadmap | None, n_routes: int,
                 weights: tuple[float, ...] = ROADMAP_WEIGHTS):
        self.via, self.roadmap, self.n_routes, self.weights = via, roadmap, n_routes, tuple(weights)

    def candidates(self, a: np.ndarray, b: np.ndarray, rng: np.random.Generator,
                   allowance: Allowance) -> list[np.ndarray]:
        out = []
        try:
            out += self.via.direct.candidates(a, b, rng, allowance)
        except PlanningError:
            pass
        if self.roadmap is not None:
            for w in self.weights:
                route = self.roadmap.route(a, b, w, rng)
                if route is not None and not any(_same(route, r) for r in out):
                    out.append(route)
        room = self.n_routes - len(out)
        if room > 0:
            try:
                extra = self.via.candidates(a, b, rng, allowance, include_direct=False, limit=room)
            except PlanningError:
                extra = []
            out += extra
        if not out:
            raise PlanningError(f"{self.via.connector.method}: no route found between "
                                f"{np.round(np.degrees(a), 1).tolist()} and {np.round(np.degrees(b), 1).tolist()} "
                                "deg within the budget")
        return out[:max(self.n_routes, 1)]


def _same(p: np.ndarray, q: np.ndarray) -> bool:
    return p.shape == q.shape and bool(np.allclose(p, q))
