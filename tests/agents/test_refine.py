"""The local refinement: its moves keep the leg's joint turns when asked and straighten joints that turn where that
pays; refine_legs judges a leg with the legs
after it (its cable end state is the next leg's start), so the returned route never costs more than the given one."""

from __future__ import annotations

import numpy as np
import pytest
from dresspack.agents.planners.budget import Allowance, Budget
from dresspack.agents.planners.refine import LocalRefiner, keep_turns, refine_legs, route_cost, straighten

from dresspack_gym.physics.trajectory import _reversals, joint_reversals

# Legs are 2-waypoint arrays told apart by their first joint; the cable "state" is one number. Leg 2 (from the
# weld, joint 1 = 1 to home, joint 1 = 2) is cheap from state 0 and dear from state 1.
GIVEN = np.array([[0.0] * 6, [1.0] + [0.0] * 5])
CHEAP_BUT_BAD_END = np.array([[0.0] * 6, [0.5] * 6, [1.0] + [0.0] * 5])  # cheaper alone, leaves state 1
CHEAP_GOOD_END = np.array([[0.0] * 6, [0.25] * 6, [1.0] + [0.0] * 5])  # cheaper alone, leaves state 0
HOME_LEG = np.array([[1.0] + [0.0] * 5, [2.0] + [0.0] * 5])


class FakeCost:
    """A leg cost with the interface refine_legs uses: cost(state, leg, bound) -> (J, end state, summary), or
    (inf, None, None) where J exceeds the bound; counts queries."""

    def __init__(self):
        self.queries = 0
        self.jobs = 1  # LegCost's: legs simulated one at a time

    def cost(self, state, leg, bound=float("inf")):
        j, end, summary = self._cost(state, leg)
        return (j, end, summary) if j <= bound else (float("inf"), None, None)

    def _cost(self, state, leg):
        self.queries += 1
        s = float(state[0])
        if leg[-1][0] == 2.0:  # the leg home
            return (10.0 if s == 0 else 30.0), np.array([s]), {"unconverged_stops": 0}
        if len(leg) == 2:
            return 10.0, np.array([0.0]), {"unconverged_stops": 0}
        bad = leg[1][0] == 0.5
        return 5.0, np.array([1.0 if bad else 0.0]), {"unconverged_stops": 0}


class FakeRefiner:
    """Returns ``refined`` for the first leg (or the leg as given) without using queries."""

    def __init__(self, refined=None):
        self.cost, self.refined = FakeCost(), refined

    def improve(self, state, leg, queries, rng, allowance):
        return self.refined if self.refined is not None and leg[-1][0] == 1.0 else leg


class FakeRoutes:
    def __init__(self, first_leg):
        self.first_leg = first_leg

    def candidates(self, a, b, rng, allowance):
        return [self.first_leg] if b[0] == 1.0 else []


def _refine(refiner, routes=None):
    return refine_legs(refiner, np.array([0.0]), [GIVEN, HOME_LEG], 10, np.random.default_rng(0), None, routes)


def test_route_cost_chains_the_cable_states():
    cost = FakeCost()
    assert route_cost(cost, np.array([0.0]), [CHEAP_BUT_BAD_END, HOME_LEG]) == 5 + 30
    assert route_cost(cost, np.array([0.0]), [GIVEN, HOME_LEG]) == 10 + 10


@pytest.mark.parametrize("refined, routes, first, total", [
    (CHEAP_BUT_BAD_END, None, GIVEN, 20.0),  # the refined leg saves 5 and costs the next leg 20: kept as given
    (CHEAP_GOOD_END, None, CHEAP_GOOD_END, 15.0),
    (None, FakeRoutes(CHEAP_BUT_BAD_END), GIVEN, 20.0),  # a candidate judged alike
    (None, FakeRoutes(CHEAP_GOOD_END), CHEAP_GOOD_END, 15.0),
])
def test_a_leg_is_kept_only_where_it_and_the_legs_after_it_cost_less(refined, routes, first, total):
    route = _refine(FakeRefiner(refined), routes)
    np.testing.assert_array_equal(route.legs[0], first)
    np.testing.assert_array_equal(route.legs[1], HOME_LEG)
    assert route.cost_given == 20.0 and route.cost == total <= route.cost_given
    assert route.cost == route_cost(FakeCost(), np.array([0.0]), route.legs) and len(route.summaries) == 2
    assert route.rerouted == ((0,) if routes is not None and first is not GIVEN else ())


class NoRoutes:
    def candidates(self, a, b, rng, allowance):
        from dresspack.agents.planners.base import PlanningError

        raise PlanningError("no route found between a and b")


def test_a_leg_no_other_route_reaches_stands_as_given():
    """Where the route generator finds no route between a leg's stops, the found leg is kept (no failure)."""
    route = _refine(FakeRefiner(), NoRoutes())
    assert route.cost == route.cost_given == 20.0 and route.rerouted == ()
    np.testing.assert_array_equal(route.legs[0], GIVEN)


def _random_leg(rng, n=6):
    """A leg of n waypoints whose joints mix moving one way, turning back and standing still."""
    leg = np.cumsum(rng.normal(0, 0.3, (n, 6)) * (rng.random((n, 6)) < 0.7), axis=0)
    leg[:, rng.integers(6)] = 0.4  # a joint the leg does not use
    return leg


def test_a_clipped_move_never_adds_a_turn():
    """Every joint of a random move of any interior waypoint of 2,000 random legs: the leg turns back no more
    often than before (and the unclipped move would have added turns in most of them)."""
    rng, added = np.random.default_rng(7), 0
    for _ in range(2000):
        leg = _random_leg(rng)
        i = int(rng.integers(1, len(leg) - 1))
        moved = leg[i] + rng.normal(0, 0.5, 6)
        trial, free = leg.copy(), leg.copy()
        trial[i], free[i] = keep_turns(leg[i - 1], leg[i], leg[i + 1], moved), moved
        assert _reversals(trial) <= _reversals(leg)
        added += _reversals(free) > _reversals(leg)
    assert added > 1000


class _AlwaysValid:
    def segment_valid(self, a, b):
        return True


class _DistanceCost:
    """A leg cost that rewards wandering far from the straight line (what would add turns if moves were free)."""

    def __init__(self):
        self.queries, self.jobs = 0, 1

    def cost(self, state, leg, bound=None):  # J itself above the bound too: what a bound saves is only time
        self.queries += 1
        return -float(np.abs(np.diff(leg, axis=0)).sum()), state, {"unconverged_stops": 0}


@pytest.mark.parametrize("n_interior", [1, 3, 8])
def test_refinement_that_keeps_turns_adds_none(n_interior):
    """A straight leg refined under a cost that pays for every detour: without keep_turns the joints turn back;
    with it none does, so each joint's travel stays the straight leg's (a path without turns travels no farther)."""
    leg = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [1.0, -0.5, 0.2, 0.0, 0.0, 0.0]])
    results = {}
    for keep in (False, True):
        cost = _DistanceCost()
        refiner = LocalRefiner(_AlwaysValid(), cost, n_interior=n_interior, keep_turns=keep)
        out = refiner.improve(np.zeros(1), leg, 200, np.random.default_rng(0), Allowance(Budget()))
        results[keep] = (_reversals(out), cost.cost(None, out)[0])
    assert results[False][0] > 0 and results[True][0] == 0
    assert results[True][1] == pytest.approx(-1.7) and results[False][1] < -1.7


def test_a_straightened_joint_never_turns_and_nothing_else_moves():
    """2,000 random legs, a random joint each: it runs monotonically from the leg's start value to its end value,
    the ends and the other joints are as they were, a second pass changes nothing, and no other monotone profile
    between the ends (sorted random values in their range) lies nearer to the given one."""
    rng = np.random.default_rng(11)
    for _ in range(2000):
        leg = _random_leg(rng, n=int(rng.integers(3, 9)))
        j = int(rng.integers(6))
        out = straighten(leg, j)
        assert joint_reversals(out)[j] == 0
        others = np.arange(6) != j
        np.testing.assert_array_equal(out[:, others], leg[:, others])
        np.testing.assert_array_equal(out[[0, -1]], leg[[0, -1]])
        lo, hi = sorted((leg[0, j], leg[-1, j]))
        assert lo <= out[:, j].min() and out[:, j].max() <= hi
        np.testing.assert_allclose(straighten(out, j), out, atol=1e-12)
        other = np.sort(rng.uniform(lo, hi, len(leg) - 2))[:: 1 if leg[-1, j] >= leg[0, j] else -1]
        assert np.linalg.norm(out[1:-1, j] - leg[1:-1, j]) <= np.linalg.norm(other - leg[1:-1, j]) + 1e-12


class _TravelCost:
    """A leg cost that charges every joint's travel (what a turn adds), or with ``detours`` pays for it."""

    def __init__(self, detours=False):
        self.queries, self.sign, self.jobs = 0, -1.0 if detours else 1.0, 1

    def cost(self, state, leg, bound=None):
        self.queries += 1
        return self.sign * float(np.abs(np.diff(leg, axis=0)).sum()), state, {"unconverged_stops": 0}


# joints 0 and 2 turn back at the middle waypoint, joint 1 runs one way
TURNING_LEG = np.array([[0.0, 0.0, 0.0, 0, 0, 0], [0.8, 0.3, -0.4, 0, 0, 0], [0.5, 0.6, 0.2, 0, 0, 0],
                        [1.0, 0.9, 0.1, 0, 0, 0]])


@pytest.mark.parametrize("queries", [3, 5, 40])
def test_turns_are_straightened_where_that_costs_less_and_kept_where_not(queries):
    """Under a cost that charges travel, the refiner's first trials take out both joints' turns (two queries) and
    the leg never turns back; under one that pays for detours they are tried, refused, and the turns stay; the
    queries are the budget's (the start's among them) and the clean-up's either way."""
    for detours in (False, True):
        cost = _TravelCost(detours)
        refiner = LocalRefiner(_AlwaysValid(), cost, n_interior=1, keep_turns=True, straighten=True)
        out = refiner.improve(np.zeros(1), TURNING_LEG, queries, np.random.default_rng(0), Allowance(Budget()))
        # the clean-up: at most two queries per interior waypoint it tries to drop (n_interior 1: none added)
        assert cost.queries <= queries + 2 * (len(TURNING_LEG) - 2)
        assert joint_reversals(out).sum() == (joint_reversals(TURNING_LEG).sum() if detours else 0)
        assert cost.cost(None, out)[0] <= cost.cost(None, TURNING_LEG)[0]
