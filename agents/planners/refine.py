"""Local refinement of one leg: stochastic hill climbing on its interior waypoints under the leg cost."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import isotonic_regression

from dresspack_gym.physics.trajectory import STILL_JOINT, joint_reversals
from dresspack_gym.stations.validity import MotionValidity

from .base import PlanningError
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


def keep_turns(before: np.ndarray, q: np.ndarray, after: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """``moved``, a new place for the waypoint ``q`` between ``before`` and ``after``, clipped joint by joint so
    that no joint turns back where it did not (at the waypoint or at its neighbours): a joint that moves one way
    through ``q`` (or stands) stays between its neighbours' values; a joint that turns back at ``q`` stays beyond
    both, so it still turns there and its neighbours' directions are kept."""
    lo, hi = np.minimum(before, after), np.maximum(before, after)
    out = np.clip(moved, lo, hi)
    # a turn shorter than STILL_JOINT is no turn (smoothness counts moves above it): such a joint stays between
    above, below = q > hi + STILL_JOINT, q < lo - STILL_JOINT
    out[above] = np.maximum(moved[above], hi[above])
    out[below] = np.minimum(moved[below], lo[below])
    return out


def straighten(leg: np.ndarray, joint: int) -> np.ndarray:
    """The leg with ``joint`` never turning back between its ends: its interior values replaced by the nearest
    (least-squares) sequence that runs monotonically from the leg's start value to its end value (isotonic
    regression, clipped into the ends' range); the other joints and the ends as they were."""
    out = leg.copy()
    a, b = leg[0, joint], leg[-1, joint]
    if len(leg) > 2:
        fit = isotonic_regression(leg[1:-1, joint], increasing=bool(b >= a)).x
        out[1:-1, joint] = np.clip(fit, min(a, b), max(a, b))
    return out


def leg_share(queries: int, used: int, legs_left: int) -> int:
    """The queries the next leg may use: what is left of ``queries``, shared evenly over the legs still to plan."""
    return max(0, queries - used) // legs_left


class LocalRefiner:
    """Random-perturbation hill climbing on a leg's interior waypoints (ends fixed); the step shrinks when a
    sweep finds nothing; then waypoints that do not pay for their stop are dropped. Bounded by leg-cost queries.

    ``keep_turns``: each move of a waypoint is clipped (:func:`keep_turns`) so that the refined leg's joints turn
    back no more often than the given leg's: the refinement then never adds the small back-and-forth a random move
    of every joint leaves in joints the leg barely uses. ``straighten``: before the random moves, each joint that
    turns back within the leg (most turns first) is tried without its turns (:func:`straighten`), kept where the
    leg stays valid and costs less; these trials spend the same queries."""

    def __init__(self, validity: MotionValidity, cost: LegCost, n_interior: int = 3, step_deg: float = 15.0,
                 keep_turns: bool = False, straighten: bool = False):
        self.keep_turns, self.straighten = keep_turns, straighten
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

        if self.straighten:
            turns = joint_reversals(best)
            for joint in np.argsort(-turns, kind="stable")[:np.count_nonzero(turns)]:
                if spent():
                    break
                trial = straighten(best, int(joint))
                if self.leg_valid(trial) and (j := self.cost.cost(state, trial, j_best)[0]) < j_best:
                    best, j_best = trial, j
        while not spent() and step > np.radians(1.0):
            improved = False
            order = rng.permutation(np.arange(1, len(best) - 1))
            for k, i in enumerate(order):
                if spent():
                    break
                trial = self._moved(best, i, rng.normal(0.0, step, 6))
                if not self.leg_valid(trial, around=i):
                    continue
                self._speculate(state, best, j_best, trial, order[k + 1:], rng, step, limit - self.cost.queries - 1)
                j = self.cost.cost(state, trial, j_best)[0]  # inf where it certainly costs more
                if j < j_best:
                    best, j_best, improved = trial, j, True
            if not improved:
                step *= 0.6
        return self._drop_useless(state, best, j_best)

    def _moved(self, best: np.ndarray, i: int, move: np.ndarray) -> np.ndarray:
        """``best`` with waypoint ``i`` moved by ``move`` (clipped to keep the joints' turns when asked)."""
        trial = best.copy()
        trial[i] = best[i] + move
        if self.keep_turns:
            trial[i] = keep_turns(best[i - 1], best[i], best[i + 1], trial[i])
        return trial

    def _speculate(self, state, best, j_best, trial, later, rng: np.random.Generator, step: float,
                   queries_left: int) -> None:
        """With leg workers: ``trial`` and the next valid trials of the sweep, moved from the same ``best``, start
        simulating at once. The sweep then draws and checks them again itself: the random stream and the collision
        check count are put back, so the plan is the one a single process makes; a trial drawn anew after an
        improvement differs from the speculated one and is simulated on its own."""
        if self.cost.jobs == 1:
            return
        legs, drawn, checks = [trial], rng.bit_generator.state, self.validity.n_checks
        for i in later:
            if len(legs) >= min(self.cost.jobs, 1 + queries_left):
                break
            ahead = self._moved(best, i, rng.normal(0.0, step, 6))
            if self.leg_valid(ahead, around=i):
                legs.append(ahead)
        rng.bit_generator.state, self.validity.n_checks = drawn, checks
        self.cost.prefetch(state, legs, j_best)

    def _drop_useless(self, state, leg, j_best):
        """Remove interior waypoints that do not pay for their stop (time) — keeps trajectories lean."""
        i = 1
        while i < len(leg) - 1:
            trial = np.delete(leg, i, axis=0)
            if self.leg_valid(trial, around=i - 1) and self.cost.cost(state, trial, j_best)[0] <= j_best:
                leg, j_best = trial, self.cost.cost(state, trial)[0]
            else:
                i += 1
        return leg

    def leg_valid(self, leg: np.ndarray, around: int | None = None) -> bool:
        """All segments, or only the two touching waypoint ``around`` (a segment check covers its end points)."""
        ks = range(len(leg) - 1) if around is None else range(max(0, around - 1), min(len(leg) - 1, around + 1))
        return all(self.validity.segment_valid(leg[k], leg[k + 1]) for k in ks)


def _candidates_or_none(routes, leg: np.ndarray, rng: np.random.Generator, allowance: Allowance) -> list:
    """The route generator's candidates between the leg's ends; none where it finds no route (the leg stands)."""
    try:
        return routes.candidates(leg[0], leg[-1], rng, allowance)
    except PlanningError:
        return []


def route_cost(cost: LegCost, state: np.ndarray, legs: list[np.ndarray], bound: float = math.inf) -> float:
    """The legs' total leg cost, each from the cable state the one before it left (``state``: the first's); inf
    where it certainly exceeds ``bound`` (each leg's query bounded by what the legs before it left of it)."""
    total = 0.0
    for leg in legs:
        j, state, _ = cost.cost(state, leg, bound - total)
        if not math.isfinite(j):
            return math.inf
        total += j
    return total


@dataclass(frozen=True)
class RefinedRoute:
    """:func:`refine_legs`' answer: the legs, the given and the returned route's total leg cost, the kept legs'
    replay summaries (each with ``unconverged_stops``: whether its settle missed the equilibrium residual) and the
    indexes of the legs that start from another route than the given one."""

    legs: list[np.ndarray]
    cost_given: float
    cost: float
    summaries: list[dict]
    rerouted: tuple[int, ...]


def refine_legs(refiner: LocalRefiner, state: np.ndarray, legs: list[np.ndarray], queries: int,
                rng: np.random.Generator, allowance: Allowance, routes=None) -> RefinedRoute:
    """Each leg improved in path order from the cable state the ones before it left (``state``: the start's),
    ``queries`` leg-cost queries shared out over the legs. With ``routes`` (a route generator), its candidate legs
    between the same stops compete with the given leg as the refiner's start (those cheaper than it on their own
    leg).

    A leg's cable end state is the next leg's start, so a leg is judged with what follows it: its cost plus the
    given later legs' from its end state. A candidate or refined leg is kept only where that sum is lower than the
    given leg's, so the route never costs more than the given one (the refined leg alone may be cheaper and still
    leave the cable where the next leg pays for it)."""
    cost, out, summaries, used, after, rerouted = refiner.cost, [], [], 0, 0.0, []
    before = route_cost(cost, state, legs)

    def with_rest(leg, k, bound=math.inf):  # the leg's cost and the given later legs' after it (inf: above bound)
        j, end, _ = cost.cost(state, leg, bound)
        return j + route_cost(cost, end, legs[k + 1:], bound - j) if math.isfinite(j) else math.inf

    for k, leg in enumerate(legs):
        start, v_start = leg, with_rest(leg, k)
        if routes is not None:
            j_given = cost.cost(state, leg)[0]
            for cand in _candidates_or_none(routes, leg, rng, allowance):
                # only a candidate cheaper than the found leg on its own is worth simulating the legs after it
                if cost.cost(state, cand, j_given)[0] < j_given and (v := with_rest(cand, k, v_start)) < v_start:
                    start, v_start = cand, v
        q0 = cost.queries
        best = refiner.improve(state, start, leg_share(queries, used, len(legs) - k), rng, allowance) if queries \
            else start
        used += cost.queries - q0
        if with_rest(best, k, v_start) > v_start:
            best = start
        j, state, summary = cost.cost(state, best)  # cached: no simulation
        out.append(best)
        summaries.append(summary)
        after += j
        if start is not leg:
            rerouted.append(k)
    return RefinedRoute(out, before, after, summaries, tuple(rerouted))
