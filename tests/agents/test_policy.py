"""The shipped PPO policy behind the Planner interface: completes held-out tasks, never enters a masked state."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from dresspack.agents.learned.policy import POLICY_DIR, PolicyPlanner, resolve_policy  # noqa: E402
from dresspack.agents.planners.base import PlanningError  # noqa: E402
from dresspack.eval.runs import eval_start  # noqa: E402
from dresspack.training.config import load_train_config  # noqa: E402

from dresspack_gym.errors import ConfigError  # noqa: E402
from dresspack_gym.io.loading import load_station  # noqa: E402
from dresspack_gym.stations.station import Station  # noqa: E402
from dresspack_gym.stations.tasks import Task, make_task  # noqa: E402

HELD_OUT = [["sill_rear", "roof_rail_top"], ["b_pillar_outer", "sill_front"]]


@pytest.fixture(scope="module")
def station():
    return Station(load_station("default"))


@pytest.fixture(scope="module")
def planner(station):
    return PolicyPlanner(station, 0, policy="stud_welding", time_budget=60)


def test_default_policy_is_the_goal_conditioned_one():
    model, _ = resolve_policy(None)
    assert model == POLICY_DIR / "goal_conditioned" / "model.zip" and model.stat().st_size < 4_000_000


def test_shipped_policy_matches_its_training_config():
    model, config = resolve_policy("stud_welding")
    assert model == POLICY_DIR / "stud_welding" / "model.zip" and model.stat().st_size < 2_000_000
    cfg = load_train_config("stud_welding")
    assert config["env_kwargs"] == cfg.env_kwargs and config["total_timesteps"] == cfg.total_timesteps
    assert HELD_OUT[0] not in config["env_kwargs"]["tasks"] and HELD_OUT[1] not in config["env_kwargs"]["tasks"]


def test_shipped_goal_conditioned_policy_is_what_its_training_command_trains():
    """`dresspack train goal_conditioned` must train the shipped policy's env and hyperparameters."""
    _, config = resolve_policy("goal_conditioned")
    cfg = load_train_config("goal_conditioned")
    assert config["env_kwargs"] == cfg.env_kwargs and config["seed"] == cfg.seed
    assert config["ppo"] == cfg.to_dict()["ppo"] and config["net_arch"] == list(cfg.net_arch)


@pytest.mark.parametrize("welds", HELD_OUT)
def test_policy_completes_held_out_tasks_from_unseen_starts_with_valid_motion(station, planner, welds):
    base = make_task(station, 0, planner.validity.checker.collides, welds)
    task = Task(0, eval_start(station, 0, 3, 10.0), base.weld_names, base.goals, base.end)
    planner.seed = 3
    result = planner.plan(task)  # Planner.plan re-checks the whole path continuously (PlanningError if not)
    traj = result.trajectory
    assert result.info["masked_actions"] == 0
    assert 0.0 < result.info["inference_s"] < result.planning_time  # the network's share, not the env's physics
    assert np.allclose(traj.waypoints[0], task.start) and np.allclose(traj.waypoints[-1], task.end)
    assert len(traj.stops) == len(welds) + 1
    for stop, goal in zip(traj.stops, [*task.goals, task.end]):
        assert np.allclose(traj.waypoints[stop], goal)
    # brute force: every waypoint and 0.5 deg samples in between are inside limits/restrictions and clear
    v = planner.validity
    for a, b in zip(traj.waypoints[:-1], traj.waypoints[1:]):
        n = max(2, int(np.ceil(np.max(np.abs(b - a)) / np.radians(0.5))))
        qs = a + np.linspace(0, 1, n)[:, None] * (b - a)
        assert v.within_limits(qs).all() and v.restrictions.allowed(qs).all()
        assert min(v.checker.min_distance(q) for q in qs) > 0.0


def test_same_seed_same_trajectory(station, planner):
    base = make_task(station, 0, planner.validity.checker.collides, ["sill_front"])
    planner.seed = 5
    a = planner.plan(base).trajectory.waypoints
    b = planner.plan(base).trajectory.waypoints
    assert np.array_equal(a, b)


def test_policy_errors(station, tmp_path):
    with pytest.raises(ConfigError, match="policy"):
        PolicyPlanner(station, 0, policy=tmp_path / "nowhere")
    planner = PolicyPlanner(station, 0, policy="stud_welding", time_budget=60)
    base = make_task(station, 0, planner.validity.checker.collides, ["sill_front"])
    away = Task(0, base.start, base.weld_names, base.goals, base.goals[0])
    with pytest.raises(PlanningError, match="Home"):
        planner.plan(away)


def test_goal_conditioned_policy_backs_out_of_a_weld_no_midpoint_via_leaves(station):
    """drawn_0 of the held-out evaluation: every midpoint via toward Home is masked at the weld
    (tests/env/test_env_primitives.py), so the policy leaves it another way: to a travel posture or one of Home's
    approach configurations (the shipped policy has them, and then the fallback here-vias are not offered) or with
    a here-via (one joint moves)."""
    from helpers import STUCK_WELD

    planner = PolicyPlanner(station, 0, policy="goal_conditioned", time_budget=120)
    home = station.config.robots[0].home
    planner.seed = 0
    result = planner.plan(Task(0, home.copy(), ("drawn_0",), (STUCK_WELD,), home.copy()))
    waypoints, weld = result.trajectory.waypoints, result.trajectory.stops[0]
    assert np.allclose(waypoints[weld], STUCK_WELD) and result.info["masked_actions"] == 0
    out = waypoints[weld + 1]
    vias = np.concatenate([np.radians(planner.env._kwargs["via_postures_deg"]).reshape(-1, 6),
                           planner.env.approaches(home)])
    assert np.count_nonzero(np.abs(out - waypoints[weld]) > 1e-9) == 1 or np.abs(vias - out).max(axis=1).min() < 1e-9
    np.testing.assert_allclose(waypoints[-1], home, atol=1e-9)  # and back Home (a failed plan raises)


@pytest.mark.parametrize("settle_time, flagged", [(None, []), (0.05, ["sill_front", "home"])])
def test_plan_names_the_goals_whose_settle_missed_the_residual(settle_time, flagged):
    """A plan's info lists the goals whose settle ended above the equilibrium residual (their wear reads a cable
    still moving): none on the default station, every goal when the settle is cut to 50 ms."""
    from dataclasses import replace

    config = load_station("default")
    if settle_time is not None:
        config = replace(config, simulation=replace(config.simulation, settle_time=settle_time))
    station = Station(config)
    planner = PolicyPlanner(station, 0, policy="goal_conditioned", deterministic=True)
    task = make_task(station, 0, planner.validity.checker.collides, ["sill_front"])
    assert planner.plan(task).info["unconverged_settles"] == flagged
