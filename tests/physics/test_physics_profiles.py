"""The cheaper physics profiles (the training profile on the rod engine, coarse_step on MuJoCo) rank paths by wear as
the accurate profile does (issue: learned planner)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.env.dresspack_env import DresspackEnv
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import PROFILES, make_simulator, random_paths, spearman, with_profile
from dresspack_gym.physics.trajectory import replay
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.validity import MotionValidity


def test_spearman_by_hand():
    assert spearman([1, 2, 3, 4], [10, 20, 30, 40]) == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    assert spearman([1, 2, 3, 4, 5], [2, 1, 4, 3, 5]) == pytest.approx(1 - 6 * 4 / (5 * 24))


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_cheaper_profiles_rank_fixed_weld_cycles_like_the_accurate_one():
    config = load_station("default")
    accurate = Station(config)
    paths = random_paths(accurate, 0, MotionValidity(accurate, 0, 0.005), 12, seed=0)
    costs, settled = {}, np.ones(len(paths), dtype=bool)
    for name in ("accurate", "training", "coarse_step"):
        station = accurate if name == "accurate" else Station(with_profile(config, name))
        sim = make_simulator(station, PROFILES[name].engine)
        replays = [replay(sim, p, record_states=False) for p in paths]
        costs[name] = np.array([r.integrated_cost() for r in replays])
        settled &= np.array([r.unconverged_stops == 0 for r in replays])
    # ranked only where every settle of both replays reached the equilibrium residual (one path's two stops do not)
    assert settled.sum() >= len(paths) - 2
    acc = costs["accurate"][settled]
    assert np.ptp(acc) > 0.5 * np.mean(acc)  # the paths really differ in wear
    assert spearman(acc, costs["training"][settled]) >= 0.97  # 0.99 (the rod engine)
    assert spearman(acc, costs["coarse_step"][settled]) >= 0.97  # 1.0
    # the rod engine's integrals are the accurate ones' (within 6 %), not only in the same order
    np.testing.assert_allclose(costs["training"][settled], acc, rtol=0.1)


# A bent wrist met by a goal-conditioned policy in training: the forearm (link 4) reaches the tool-side clamp.
BENT_WRIST_DEG = [-54.243, 47.77, -26.703, 135.888, 81.244, 277.999]


def _segments(config, n: int):
    return replace(config, robots=tuple(replace(r, dresspack=replace(r.dresspack, segments=n)) for r in config.robots))


@pytest.mark.parametrize("profile, segments, crushed", [("coarse_step", 16, True), ("coarse_step", None, False),
                                                        ("accurate", None, False), ("training", None, False)])
def test_a_clamp_edge_as_long_as_the_accurate_one_is_not_crushed_by_the_forearm(profile, segments, crushed):
    """A 16-segment cable's clamps hold 1/16 of it rigidly: at this wrist MuJoCo's forearm cuts ~18 mm into the
    tool-side clamp's edge, a contact between two driven bodies whose force nothing bounds (MN read as tension).
    The profiles with the station's own 24 segments hold 1/24 and settle to the cable's real ~10 N (the training
    profile's rod engine too)."""
    config = with_profile(load_station("default"), profile)
    station = Station(config if segments is None else _segments(config, segments))
    sim = make_simulator(station, PROFILES[profile].engine)
    q = station.home.copy()
    q[0] = np.radians(BENT_WRIST_DEG)
    sim.reset(q)
    result = sim.settle()
    tension = sim.measures().max_tension
    if crushed:
        assert tension > 1e5
    else:
        assert result.converged and 5.0 < tension < 30.0


def test_profiles_are_applied_and_checked():
    env = DresspackEnv("default", physics_profile="coarse_step")
    assert env.station.model.opt.timestep == pytest.approx(0.008) and env.sim.engine == "dynamic"
    assert env.station.cables[0].n_vertices - 1 == 24
    env = DresspackEnv("default", physics_profile="coarse_step", sim_timestep=0.004)  # an explicit step wins
    assert env.station.model.opt.timestep == pytest.approx(0.004)
    env = DresspackEnv("default", physics_profile="training")
    assert env.sim.engine == "fast" and len(env.sim.cable_points(0)) == 25
    with pytest.raises(ConfigError, match="physics_profile: 'fast' is not one of the allowed values"):
        DresspackEnv("default", physics_profile="fast")


def test_collision_geometry_does_not_follow_the_physics_profile():
    """What a motion may do must not change with the physics profile (a coarser cable's clamp edges are longer):
    the env checks collisions on the station it was given, the one the planners and the evaluation judge with."""
    accurate = Station(load_station("default"))
    for profile in ("coarse_step", "training"):
        env = DresspackEnv(accurate, physics_profile=profile)
        assert env.checker.station is accurate
    judge = MotionValidity(accurate, 0, margin=env.checker.margin)
    qs = np.radians(np.random.default_rng(3).uniform(-120, 120, size=(200, 6)))
    assert [env.validity.valid(q) for q in qs] == [judge.valid(q) for q in qs]


def test_bench_env_reports_every_profile_in_one_run():
    from dresspack_gym.cli.bench import env_benchmark

    out = env_benchmark(repeats=1, env_steps=3)
    assert set(out["profiles_env_steps_per_s"]) == {"accurate", "training", "coarse_step"}
    for k in ("training_vs_accurate", "coarse_step_vs_accurate", "training_vs_coarse_step"):
        assert out[k] > 0 and np.isfinite(out[k])
    assert set(out["motion_s_per_s"]) == {"accurate", "training", "coarse_step", "training_primitives"}
    assert out["primitives_vs_accurate_motion"] > 0 and out["primitives_env_steps_per_s"] > 0
