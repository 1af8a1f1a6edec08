"""Leg costs on worker processes: the plan, its counters and every answer are those of one process."""

import json
import math

import numpy as np
import pytest
from dresspack.agents.planners.leg_cost import LegCost
from dresspack.agents.planners.leg_workers import check_jobs
from dresspack.agents.planners.registry import make_planner

from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.stations.collision import RobotCollisionChecker
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import make_task


@pytest.fixture(scope="module")
def tension():
    station = Station(load_station("thesis_tension"))
    return station, make_task(station, 0, RobotCollisionChecker(station).collides)


def _plan(station, planner: str, jobs: int):
    p = make_planner(planner, station, 0, seed=3, evaluations=10, routes=4, jobs=jobs)
    result = p.plan(make_task(station, 0, p.validity.checker.collides))
    p.leg_cost.reset()
    return result.trajectory.waypoints, json.dumps(result.info, sort_keys=True, default=str)


# ompl-wear's plan (its candidate routes in batches) takes about a minute: the slow tier; the bound arithmetic of a
# batch is the next test's
@pytest.mark.parametrize("planner", [pytest.param("ompl-wear", marks=pytest.mark.slow), "thesis-local"])
def test_a_plan_on_two_workers_is_the_plan_of_one_process(tension, planner):
    station, _ = tension
    one, two = _plan(station, planner, 1), _plan(station, planner, 2)
    assert np.array_equal(one[0], two[0])
    assert one[1] == two[1]  # route scores, cable evaluations and give-ups, collision checks, objective


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_a_prefetched_leg_answers_every_bound_as_its_own_simulation_would(tension):
    """A leg simulated ahead at one bound, then asked at a lower, the same or a higher one: the answer, the counters
    and the cache are those of simulating it at the asked bound."""
    station, task = tension
    a, b = task.goals[:2]
    leg = np.array([a, (a + b) / 2 + np.radians([0.0, -3.0, 3.0, 0.0, 0.0, 0.0]), b])
    alone = LegCost(station)
    state = alone.start_state(leg[0])
    j = alone.cost(state, leg)[0]
    ahead = LegCost(station, jobs=2)
    try:
        for prefetched, asked in [(math.inf, 0.9 * j), (math.inf, 1.1 * j), (0.8 * j, 0.5 * j), (0.8 * j, 1.2 * j),
                                  (1.2 * j, 0.9 * j)]:
            ahead.reset()
            ahead.prefetch(state, [leg], prefetched)
            got = ahead.cost(state, leg, asked)
            fresh = LegCost(station)
            want = fresh.cost(state, leg, asked)
            assert got[0] == want[0] and (got[1] is None) == (want[1] is None)
            assert (ahead.evaluations, ahead.given_up, ahead.queries) == (fresh.evaluations, fresh.given_up, 1)
            assert len(ahead._cache) == len(fresh._cache)
    finally:
        ahead._workers.close()


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2", 65])
def test_jobs_out_of_range_is_refused_naming_the_field(bad):
    with pytest.raises(ConfigError, match="jobs"):
        check_jobs(bad)
