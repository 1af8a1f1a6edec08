"""Local refinement of one leg: stochastic hill climbing on its interior waypoints under the leg cost."""

from __future__ import annotations

import numpy as np

from dresspack_gym.stations.validity import MotionValidity

from .budget import Allowance
from .leg_cost import LegCost


def densify(leg: np.ndarray, n_interior: int) -> np.ndarray:
    """Add interior waypoints on the leg's segments (at least ``n_interior`` in all) to give the optimiser
    handles; long segments get more."""
    seg = np.linalg.norm(np.diff(leg, axis=0), axis=1)
    extra = max(0, n_interior - (len(leg) - 2))
    if extra == 0 or seg.sum() == 0:
        return leg
    share = np.floor(extra * seg / seg.sum()).astype(int)
    share[np.argsort(-seg)[: extra - share.sum()]] += 1
    pts = [leg[0]]
    for a, b, k in zip(leg[:-1], leg[1:], share):
        pts.extend(a + (b - a) * t for t in np.linspace(0, 1, k + 2)[1:])
    return np.array(pts)


def leg_share(queries: int, used: int, legs_left: int) -> int:
    """The queries the next leg may use: what is left of ``queries``, shared evenly over the legs still to plan."""
    return max(0, queries - used) // legs_left


class LocalRefiner:
    """Random-perturbation hill climbing on a leg's interior waypoints (ends fixed); the step shrinks when a
    sweep finds nothing; then waypoints that do not pay for their stop are dropped. Bounded by leg-cost queries."""

    def __init__(self, validity: MotionValidity, cost: LegCost, n_interior: int = 3, step_deg: float = 15.0):
        self.validity = validity
        self.cost = cost
        self.n_interior = n_interior
        self.step = np.radians(step_deg)

    def improve(self, state: np.ndarray, leg: np.ndarray, queries: int, rng: np.random.Generator,
                allowance: Allowance) -> np.ndarray:
        """The improved leg after at most ``queries`` leg-cost queries (plus the final clean-up)."""
        limit = self.cost.queries + queries
        best = leg.copy()
        j_best = self.cost.cost(state, best)[0]
        cand = densify(best, self.n_interior)
        if len(cand) > len(best) and self.leg_valid(cand):
            best, j_best = cand, self.cost.cost(state, cand)[0]
        step = self.step

        def spent() -> bool:
            return self.cost.queries >= limit or allowance.out_of_time()

        while not spent() and step > np.radians(1.0):
            improved = False
            for i in rng.permutation(np.arange(1, len(best) - 1)):
                if spent():
                    break
                trial = best.copy()
                trial[i] = best[i] + rng.normal(0.0, step, 6)
                if not self.leg_valid(trial, around=i):
                    continue
                j = self.cost.cost(state, trial)[0]
                if j < j_best:
                    best, j_best, improved = trial, j, True
            if not improved:
                step *= 0.6
        return self._drop_useless(state, best, j_best)

    def _drop_useless(self, state, leg, j_best):
        """Remove interior waypoints that do not pay for their stop (time) — keeps trajectories lean."""
        i = 1
        while i < len(leg) - 1:
            trial = np.delete(leg, i, axis=0)
            if self.leg_valid(trial, around=i - 1) and self.cost.cost(state, trial)[0] <= j_best:
                leg, j_best = trial, self.cost.cost(state, trial)[0]
            else:
                i += 1
        return leg

    def leg_valid(self, leg: np.ndarray, around: int | None = None) -> bool:
        """All segments, or only the two touching waypoint ``around`` (a segment check covers its end points)."""
        ks = range(len(leg) - 1) if around is None else range(max(0, around - 1), min(len(leg) - 1, around + 1))
        return all(self.validity.segment_valid(leg[k], leg[k + 1]) for k in ks)


def refine_legs(refiner: LocalRefiner, state: np.ndarray, legs: list[np.ndarray], queries: int,
                rng: np.random.Generator, allowance: Allowance) -> tuple[list[np.ndarray], float, float, list[dict]]:
    """Each leg improved in path order from the cable state the ones before it left (``state``: the start's),
    ``queries`` leg-cost queries shared out over the legs; a leg the refiner made dearer is kept as it was (its
    added waypoints may not all be dropped again). The legs, their total leg cost before and after, and the kept
    legs' replay summaries (each with ``unconverged_stops``: whether its settle missed the equilibrium residual)."""
    cost, out, summaries, before, after, used = refiner.cost, [], [], 0.0, 0.0, 0
    for k, leg in enumerate(legs):
        given = cost.cost(state, leg)[0]  # from the end state of the legs kept before it
        q0 = cost.queries
        best = refiner.improve(state, leg, leg_share(queries, used, len(legs) - k), rng, allowance)
        used += cost.queries - q0
        j, end, summary = cost.cost(state, best)  # cached: no simulation
        if j > given:
            best, (j, end, summary) = leg, cost.cost(state, leg)
        state = end
        out.append(best)
        summaries.append(summary)
        before, after = before + given, after + j
    return out, before, after, summaries
