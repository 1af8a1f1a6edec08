"""A leg-cost query with a bound: the leg's J where J <= bound, else inf after simulating only until that was
certain; the bound it stops on never exceeds J; the wear-aware planners choose the same routes with and without it."""

import math

import numpy as np
import pytest

pytest.importorskip("ompl.base")

from dresspack.agents.planners.leg_cost import LegCost, _LowerBound  # noqa: E402
from dresspack.agents.planners.registry import make_planner  # noqa: E402

from dresspack_gym.io.loading import load_station  # noqa: E402
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, make_simulator  # noqa: E402
from dresspack_gym.physics.trajectory import Trajectory, replay  # noqa: E402
from dresspack_gym.stations.collision import RobotCollisionChecker  # noqa: E402
from dresspack_gym.stations.station import Station  # noqa: E402
from dresspack_gym.stations.tasks import make_task  # noqa: E402


@pytest.fixture(scope="module")
def tension_leg():
    """thesis_tension's straight side_a -> side_b, through a via: the cable dragged over the cuboid (a tension peak
    over 100 N), three segments."""
    station = Station(load_station("thesis_tension"))
    a, b = make_task(station, 0, RobotCollisionChecker(station).collides).goals[:2]
    via = (a + b) / 2 + np.radians([0.0, -3.0, 3.0, 0.0, 0.0, 0.0])
    return station, np.array([a, via, b])


@pytest.mark.parametrize("weights", [dict(), dict(time_weight=0.0, tension_peak_time=1.0)])
def test_a_bound_returns_the_leg_cost_at_or_above_it_and_inf_below_it_having_stopped_early(tension_leg, weights):
    station, leg = tension_leg
    full = LegCost(station, **weights)
    state = full.start_state(leg[0])
    j, end, summary = full.cost(state, leg)
    assert summary["max_tension"] > 100.0 and full.given_up == 0
    for bound in (j, j * 1.01, math.inf):  # at or above J: J itself, its end state and summary
        cost = LegCost(station, **weights)
        jb, end_b, summary_b = cost.cost(state, leg, bound)
        assert jb == j and np.array_equal(end_b, end) and summary_b == summary and cost.given_up == 0
    for share in (0.99, 0.6):  # below J: inf, the simulation ended before the leg's end
        cost = LegCost(station, **weights)
        assert cost.cost(state, leg, j * share) == (math.inf, None, None)
        assert cost.given_up == 1 and cost.evaluations == 1
        assert cost.sim.motion_time < summary["cycle_time"] - 0.01 or share == 0.99


def test_a_bound_below_the_legs_motion_time_stops_before_the_first_step(tension_leg):
    station, leg = tension_leg
    cost = LegCost(station, time_weight=1.0)
    state = cost.start_state(leg[0])
    _, _, summary = LegCost(station).cost(state, leg)
    assert cost.cost(state, leg, 0.5 * summary["cycle_time"])[0] == math.inf
    assert cost.sim.motion_time == 0.0  # given up at the start sample: its motion time alone is over the bound


@pytest.mark.parametrize("time_weight,peak_time", [(1.0, 0.25), (3.0, 0.0)])
def test_the_lower_bound_never_exceeds_the_legs_cost_and_ends_at_it(tension_leg, time_weight, peak_time):
    """At every sample the bound is at most J; at the last sample it is J less time_weight x (the replay's motion
    time - the time law's), which is under one step per segment (each segment runs whole steps)."""
    station, leg = tension_leg
    cost = LegCost(station, time_weight=time_weight, tension_peak_time=peak_time)
    state = cost.start_state(leg[0])
    j, _, summary = cost.cost(state, leg)
    bound = cost._above(Trajectory(leg, (2,)), math.inf)
    assert bound is None  # no bound: no give_up at all
    bound = cost._above(Trajectory(leg, (2,)), 1e12)
    lower = []

    def watch(t, c):
        out = bound(t, c)
        lower.append(bound.lower)
        return out

    rep = replay(make_simulator(station, DEFAULT_ENGINE), Trajectory(leg, (2,)), start_state=state,
                 record_states=False, give_up=watch)
    assert not rep.given_up and len(lower) == len(rep.time)
    assert max(lower) <= j * (1 + 1e-12)
    # a segment runs whole motion steps: MuJoCo's timestep, or the rod engine's samples
    dt = cost.record_every if cost.sim.engine == "fast" else station.config.simulation.timestep
    assert 0.0 <= j - lower[-1] <= time_weight * 2 * dt + 1e-9
    assert np.all(np.diff(lower) >= -1e-12)  # it only grows


def test_replay_gives_up_at_the_first_sample_asked_and_is_unchanged_otherwise(tension_leg):
    station, leg = tension_leg
    sim = make_simulator(station, DEFAULT_ENGINE)
    traj = Trajectory(leg, (2,))
    plain = replay(sim, traj, record_states=False)
    never = replay(sim, traj, record_states=False, give_up=lambda t, c: False)
    assert not never.given_up and np.array_equal(never.time, plain.time) and np.array_equal(never.cost, plain.cost)
    asked = []
    cut = replay(sim, traj, record_states=False, give_up=lambda t, c: asked.append(t) or len(asked) == 7)
    assert cut.given_up and len(cut.time) == 7 and np.array_equal(cut.time, plain.time[:7])
    assert np.allclose(cut.cost, plain.cost[:7]) and sim.motion_time == pytest.approx(plain.time[6])


def test_the_wear_aware_planner_chooses_the_same_route_with_bounded_queries(monkeypatch):
    """The bound only ends simulations whose legs the planner would not keep: the plan is the one every query
    simulated to its end would give. (ppo-search refines with the same LocalRefiner.)"""
    station = Station(load_station("thesis_curvature"))
    task = make_task(station, 0, RobotCollisionChecker(station).collides)
    settings = dict(seed=3, routes=3, evaluations=8)  # candidates and refinement queries, both bounded
    bounded = make_planner("ompl-wear", station, **settings).plan(task)
    monkeypatch.setattr(LegCost, "_above", lambda self, traj, bound: None)
    unbounded = make_planner("ompl-wear", station, **settings).plan(task)
    assert np.array_equal(bounded.trajectory.waypoints, unbounded.trajectory.waypoints)
    assert bounded.info["objective"] == unbounded.info["objective"]
    assert bounded.info["cable_simulations_given_up"] > 0 == unbounded.info["cable_simulations_given_up"]
    scores = [[x for x in leg if x is not None] for leg in bounded.info["route_scores"]]
    assert [min(s) for s in scores] == [min(s) for s in unbounded.info["route_scores"]]


def test_a_negative_wear_term_ends_the_lower_bound():
    bound = _LowerBound(floor=1.0, wear_weight=1.0, peak_time=0.0, bound=1.5)

    class Cost:
        def __init__(self, total):
            self.total, self.tension = total, 0.0

    assert not bound(0.0, Cost(0.2)) and bound(1.0, Cost(0.9))  # 1 + (0.2 + 0.9)/2 > 1.5
    fresh = _LowerBound(floor=1.0, wear_weight=1.0, peak_time=0.0, bound=1.5)
    assert not fresh(0.0, Cost(-0.1)) and not fresh(1.0, Cost(5.0))  # C < 0: no lower bound from here on
