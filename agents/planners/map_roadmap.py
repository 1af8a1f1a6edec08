"""Global routes over the wear map: a lazy PRM* whose milestones are the map's own settled configurations, searched
for the least ∫(1 + weight x map cost rate) dt between two configurations. The roadmap is built once per planner
and reused by every leg; edges are checked for collisions and costed finely only when a search wants them."""

from __future__ import annotations

import heapq
import math

import numpy as np

from dresspack_gym.maps.map_cost import MapStateCost
from dresspack_gym.maps.wear_map import WearMap
from dresspack_gym.robots import time_law
from dresspack_gym.stations.validity import MotionValidity

# [rad] longest joint change between two cost samples of a straight motion when an edge is costed finely.
COST_STEP = math.radians(10.0)
# Searches per route before giving up (each one either returns a route or retires edges it found invalid).
MAX_SEARCHES = 200


def motion_time(a: np.ndarray, b: np.ndarray, limits: time_law.JointLimits) -> float:
    """Seconds of the straight joint motion a -> b under the simulator's time law (stop at b)."""
    return float(time_law.segment_durations(b - a, limits))


def fine_wear(cost: MapStateCost, a: np.ndarray, b: np.ndarray, t: float) -> float:
    """∫ C_map dt of the straight motion a -> b lasting t seconds, the map cost sampled every COST_STEP."""
    steps = max(1, int(math.ceil(float(np.max(np.abs(b - a))) / COST_STEP)))
    rates = [cost.cost(a + (b - a) * (s / steps)) for s in range(steps + 1)]
    return t * (0.5 * (rates[0] + rates[-1]) + sum(rates[1:-1])) / steps


def simplify_route(route: np.ndarray, weight: float, cost: MapStateCost, limits: time_law.JointLimits,
                   validity: MotionValidity) -> np.ndarray:
    """Drop waypoints whose neighbours join directly (a valid segment) at no higher objective, motion time +
    ``weight`` x the map's ∫C dt, than the route between them: every waypoint is a stop."""
    def objective(p, q):
        t = motion_time(p, q, limits)
        return t + weight * fine_wear(cost, p, q, t)

    along = np.concatenate([[0.0], np.cumsum([objective(p, q) for p, q in zip(route[:-1], route[1:])])])
    out, i = [route[0]], 0
    while i < len(route) - 1:
        j = len(route) - 1
        while j > i + 1 and not (objective(route[i], route[j]) <= along[j] - along[i]
                                 and validity.segment_valid(route[i], route[j])):
            j -= 1
        out.append(route[j])
        i = j
    return np.array(out)


class MapRoadmap:
    """Milestones: the map's configurations that are valid in this station (limits, restrictions, reach,
    collisions), joined to their ``neighbours`` nearest in motion time (k of PRM*: e(1 + 1/d) log n). A route
    query adds its two ends, searches (Dijkstra) on endpoint cost estimates, then checks the chosen edges:
    an invalid edge is retired, an edge whose fine cost exceeds its estimate is re-priced, and the search repeats
    until the best route consists of checked, finely costed edges."""

    def __init__(self, wear_map: WearMap, validity: MotionValidity, cost: MapStateCost,
                 limits: time_law.JointLimits, neighbours: int | None = None):
        self.validity, self.cost = validity, cost
        self.limits = limits
        qs = [q for q in wear_map.configurations if validity.valid(q)]
        self.nodes = np.array(qs).reshape(-1, 6)
        n = len(self.nodes)
        self.k = neighbours or max(4, int(math.ceil(math.e * (1 + 1 / 6) * math.log(max(n, 2)))))
        self.rates = np.array([cost.cost(q) for q in self.nodes])
        self.edges: list[dict[int, float]] = [{} for _ in range(n)]  # node -> {neighbour: motion time}
        for i in range(n):
            for j, t in self._nearest(self.nodes[i], exclude=i).items():  # symmetric: one edge, both directions
                self.edges[i][j] = self.edges[j][i] = t
        self.checked: dict[tuple[int, int], bool] = {}  # edge -> valid (robot collision, reach, limits)
        self.fine: dict[tuple[int, int], float] = {}  # edge -> ∫ C_map dt, finely sampled

    def forget(self) -> None:
        """Drop what earlier searches learnt about edges. A lazy search returns the first route whose edges are
        all checked, so a fine cost learnt in an earlier plan can change a later route: each plan starts
        afresh, so that it never depends on what the planner planned before."""
        self.checked.clear()
        self.fine.clear()

    def _nearest(self, q: np.ndarray, exclude: int = -1) -> dict[int, float]:
        """The k nodes nearest to ``q`` in motion time, with their times. Exact, though only a few are timed by
        the time law: the k nearest by the cheap lower bound give an upper bound of the k-th time, and only
        nodes whose lower bound is within it can be among the k nearest."""
        bound = time_law.velocity_bound(self.nodes - q, self.limits)
        if 0 <= exclude < len(bound):
            bound[exclude] = np.inf
        k = min(self.k, int(np.isfinite(bound).sum()))
        if k == 0:
            return {}
        first = np.argpartition(bound, k - 1)[:k]
        kth = float(np.max(time_law.segment_durations(self.nodes[first] - q, self.limits)))
        cand = np.flatnonzero(bound <= kth)
        t = time_law.segment_durations(self.nodes[cand] - q, self.limits)
        near = np.argsort(t, kind="stable")[:k]
        return {int(cand[m]): float(t[m]) for m in near}

    def route(self, a: np.ndarray, b: np.ndarray, weight: float, rng=None) -> np.ndarray | None:
        """The best route a -> b found on the roadmap (waypoints, ends included), or None. ``rng`` is not used:
        the roadmap's routes depend on no seed."""
        n = len(self.nodes)
        pts = {n: a, n + 1: b}
        ends = {}
        for e, q in ((n, a), (n + 1, b)):
            ends[e] = self._nearest(q)
        rate = {n: self.cost.cost(a), n + 1: self.cost.cost(b)}

        def point(i):
            return pts[i] if i >= n else self.nodes[i]

        local_checked: dict[tuple[int, int], bool] = {}
        local_fine: dict[tuple[int, int], float] = {}

        def books(i, j):
            """(key, validity store, fine-cost store) of edge i -> j: roadmap edges are kept (both directions
            alike), the query's own edges to its ends only for this query."""
            if i < n and j < n:
                return (min(i, j), max(i, j)), self.checked, self.fine
            return (i, j), local_checked, local_fine

        def neighbours(i):
            if i >= n:
                yield from ends[i].items()
                if i == n:
                    yield n + 1, motion_time(a, b, self.limits)
                return
            yield from self.edges[i].items()
            if i in ends[n + 1]:
                yield n + 1, ends[n + 1][i]

        def edge_cost(i, j, t):
            key, _, fine = books(i, j)
            wear = fine.get(key)
            if wear is None:
                ri = rate[i] if i >= n else self.rates[i]
                rj = rate[j] if j >= n else self.rates[j]
                wear = 0.5 * (ri + rj) * t
            return t + weight * wear

        def retired(i, j):
            key, checked, _ = books(i, j)
            return checked.get(key) is False

        for _ in range(MAX_SEARCHES):
            path = self._dijkstra(n, n + 1, neighbours, edge_cost, retired)
            if path is None:
                return None
            changed = False
            for i, j in zip(path[:-1], path[1:]):
                key, checked, fine = books(i, j)
                if key not in checked:
                    checked[key] = bool(self.validity.segment_valid(point(i), point(j)))
                    if not checked[key]:
                        changed = True
                        break
                if key not in fine:
                    t = motion_time(point(i), point(j), self.limits)
                    estimate = edge_cost(i, j, t)
                    fine[key] = fine_wear(self.cost, point(i), point(j), t)
                    if edge_cost(i, j, t) > estimate + 1e-12:
                        changed = True
                        break
            if not changed:
                return simplify_route(np.array([point(i) for i in path]), weight, self.cost, self.limits, self.validity)
        return None

    @staticmethod
    def _dijkstra(source, target, neighbours, edge_cost, retired):
        dist = {source: 0.0}
        prev = {}
        heap = [(0.0, source)]
        done = set()
        while heap:
            d, i = heapq.heappop(heap)
            if i in done:
                continue
            if i == target:
                path = [i]
                while path[-1] in prev:
                    path.append(prev[path[-1]])
                return path[::-1]
            done.add(i)
            for j, t in neighbours(i):
                if retired(i, j):
                    continue
                nd = d + edge_cost(i, j, t)
                if nd < dist.get(j, math.inf):
                    dist[j] = nd
                    prev[j] = i
                    heapq.heappush(heap, (nd, j))
        return None
