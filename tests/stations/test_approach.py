"""Approach configurations of a goal (dresspack_gym.stations.approach) and the env's approach vias: free, into the goal,
within reach, the same for the same goal, clearest first; masked where a goal has fewer; errors."""

import math

import numpy as np
import pytest

from dresspack_gym import ConfigError
from dresspack_gym.env.dresspack_env import TO_GOAL, DresspackEnv
from dresspack_gym.io.loading import load_station
from dresspack_gym.stations.approach import approach_configurations
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.validity import PLANNER_MARGIN, MotionValidity

REACH = math.radians(45.0)


@pytest.fixture(scope="module")
def validity():
    return MotionValidity(Station(load_station("default")), 0, PLANNER_MARGIN)


@pytest.fixture(scope="module")
def env():
    e = DresspackEnv(station="default", action_set="primitives", approach_vias=3, physics_profile="training",
                     part_welds=1, wear_integral=True, settle_time=0.0, collision_margin=PLANNER_MARGIN, max_steps=8)
    yield e
    e.close()


def _drawn_goals(env, n):
    goals = []
    for seed in range(n):
        env.reset(seed=seed)
        goals.append(env.goal.copy())
    return goals


def test_approaches_are_free_ways_into_the_goal_within_reach(env, validity):
    """Every approach is a valid configuration within reach of the goal on each joint, and the straight segment from
    it into the goal passes the planners' own segment check (limits, restrictions, continuous collisions)."""
    found = 0
    for goal in _drawn_goals(env, 4):
        approaches = approach_configurations(validity, goal, 3, REACH)
        assert approaches.shape[1] == 6 and len(approaches) <= 3
        for a in approaches:
            assert np.max(np.abs(a - goal)) <= REACH + 1e-12
            assert validity.valid(a) and validity.segment_valid(a, goal)
        # clearest first: its clearance is the largest of those chosen
        if len(approaches) > 1:
            d = validity.checker.min_distances(approaches)
            assert d[0] >= d[1:].max() - 1e-12
        found += len(approaches)
    assert found >= 6  # the drawn welds are reachable: most have their three


def test_a_goals_approaches_do_not_depend_on_what_ran_before(validity):
    """Drawn from the goal itself: the same in a fresh checker, after other goals, and to the bit."""
    station = Station(load_station("default"))
    home = station.config.robots[0].home
    first = approach_configurations(validity, home, 3, REACH)
    approach_configurations(validity, home + 0.1, 3, REACH)  # something else in between
    again = approach_configurations(MotionValidity(station, 0, PLANNER_MARGIN), home, 3, REACH)
    np.testing.assert_array_equal(first, again)
    assert len(first) == 3  # Home is open: it has every approach asked for
    # the chosen approaches are spread: no two within a few degrees on every joint
    spread = [np.max(np.abs(a - b)) for i, a in enumerate(first) for b in first[i + 1:]]
    assert min(spread) > math.radians(10.0)


def test_a_goal_without_a_free_way_in_has_no_approaches(validity, monkeypatch):
    home = Station(load_station("default")).config.robots[0].home
    monkeypatch.setattr(validity, "segments_clear", lambda q0, q1s: np.zeros(len(q1s), dtype=bool))
    assert approach_configurations(validity, home, 3, REACH).shape == (0, 6)


def test_approach_vias_are_actions_before_the_wait(env):
    plain = DresspackEnv(station="default", action_set="primitives", physics_profile="training", part_welds=1)
    first = plain.stay_action
    assert env.n_actions == plain.n_actions + 3 and env.stay_action == env.n_actions - 1
    assert env.observation_structure["approaches"] == 18
    assert env.observation_structure["action_masks"] == env.n_actions
    assert env.observation_space.shape == (plain.observation_space.shape[0] + 18 + 3,)
    env.reset(seed=1)
    q, approaches = env.q, env.approaches()
    assert len(approaches) == 3
    masks = env.action_masks()
    for k, a in enumerate(approaches):
        assert env.describe_action(first + k) == f"via approach configuration {k} of the goal"
        np.testing.assert_array_equal(env.target(q, first + k), a)
        assert masks[first + k] == env.segment_valid(q, a)
    np.testing.assert_array_equal(masks[:first], plain.masks_at(q, env.goal)[:first])
    obs = env._get_obs(env.sim.measures())
    start = sum(n for k, n in env.observation_structure.items() if k in list(env.observation_structure)[:7])
    assert list(env.observation_structure)[7] == "approaches"
    np.testing.assert_allclose(obs[start:start + 18], np.clip((approaches - q).ravel() / np.pi, -5, 5), atol=1e-6)
    # taken: the robot stands at the approach, and from there the goal is one free segment away
    k = int(np.flatnonzero(masks[first:first + 3])[0])
    _, _, _, _, info = env.step(first + k)
    np.testing.assert_allclose(env.q, approaches[k], atol=1e-12)
    assert info["integral_cost"] > 0.0
    assert env.action_masks()[TO_GOAL]
    plain.close()


def test_a_goal_with_fewer_approaches_masks_the_rest(env, monkeypatch):
    env.reset(seed=2)
    one = env.approaches()[:1]
    monkeypatch.setitem(env.actions._approach_cache, env.goal.tobytes(), one)
    env.masks.forget()
    masks = env.action_masks()
    first = env.stay_action - 3
    assert not masks[first + 1] and not masks[first + 2]
    assert "1 approach configuration(s)" in env.why_masked(first + 2)
    obs = env._get_obs(env.sim.measures())
    start = sum(list(env.observation_structure.values())[:7])
    assert not obs[start + 6:start + 18].any()  # the missing approaches observe as zeros


@pytest.mark.parametrize("kwargs, field", [
    ({"approach_vias": 2}, "approach_vias"),  # joint steps have no vias
    ({"action_set": "primitives", "approach_vias": -1}, "approach_vias"),
    ({"action_set": "primitives", "approach_vias": 1.5}, "approach_vias"),
    ({"action_set": "primitives", "approach_vias": 2, "approach_range_deg": 0.0}, "approach_range_deg"),
    ({"action_set": "primitives", "approach_vias": 2, "approach_range_deg": float("nan")}, "approach_range_deg"),
])
def test_bad_approach_arguments_name_the_field(kwargs, field):
    with pytest.raises(ConfigError) as err:
        DresspackEnv(station="default", **kwargs)
    assert err.value.field == field
