"""The Gymnasium environment: API checks, determinism, reward decomposition, exact masking, errors."""

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest

import dresspack_gym
from dresspack_gym import ConfigError
from dresspack_gym.env.dresspack_env import STAY, DresspackEnv, InvalidActionError
from dresspack_gym.errors import EnvUsageError


@pytest.fixture(scope="module")
def env():
    e = DresspackEnv(station="default", max_steps=60)
    yield e
    e.close()


def masked_rollout(env, seed, n):
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    out = [(obs, 0.0, info["q"])]
    for _ in range(n):
        a = int(rng.choice(np.flatnonzero(env.action_masks())))
        obs, r, term, trunc, info = env.step(a)
        out.append((obs, r, info["q"]))
        if term or trunc:
            break
    return out, info


def test_gymnasium_env_checker_passes_without_warnings():
    e = gym.make("dresspack_gym/StudWelding-v0", max_steps=20).unwrapped  # carries its spec
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from gymnasium.utils.env_checker import check_env

        check_env(e, skip_render_check=False)
    ours = [w for w in caught if "gymnasium" in str(w.filename) or "dresspack" in str(w.filename)]
    assert not ours, [str(w.message) for w in ours]


def test_stable_baselines3_env_checker_passes():
    sb3_check = pytest.importorskip("stable_baselines3.common.env_checker").check_env
    e = DresspackEnv(station="default", max_steps=20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sb3_check(e, warn=True)
    assert not [w for w in caught if "env_checker" in str(w.filename)], [str(w.message) for w in caught]


def test_registered_ids_make_envs():
    for env_id in dresspack_gym.ENV_IDS:
        e = gym.make(env_id)
        obs, _ = e.reset(seed=0)
        assert e.observation_space.contains(obs)
        e.close()


def test_same_seed_same_trajectory(env):
    a, _ = masked_rollout(env, seed=3, n=8)
    b, _ = masked_rollout(env, seed=3, n=8)
    assert len(a) == len(b)
    for (oa, ra, qa), (ob, rb, qb) in zip(a, b):
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(qa, qb)
        assert ra == rb


def test_reward_is_the_sum_of_its_documented_terms(env):
    env.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(6):
        a = int(rng.choice(np.flatnonzero(env.action_masks())))
        _, r, _, _, info = env.step(a)
        terms = sum(info[f"reward_{k}"] for k in ("time", "wear", "progress", "goal", "invalid"))
        assert r == pytest.approx(terms, abs=1e-12)
        assert info["reward_wear"] == pytest.approx(-info["cost"])
        assert info["cost"] == pytest.approx(info["cost_curvature"] + info["cost_tension"] + info["cost_distance"]
                                             + info["cost_twist"])
        assert info["reward_time"] == pytest.approx(-info["step_time"])
        for key in ("max_curvature", "max_tension", "min_clearance", "max_twist_rate", "cycle_time", "progress"):
            assert np.isfinite(info[key])


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_long_random_masked_rollout_never_violates_anything():
    """Checked from info['q'] with independent code: limits, restriction rules, exact min distance."""
    e = DresspackEnv(station="default", max_steps=400)
    limits = e.placement.robot.joint_limits
    rules = e.placement.restrictions.rules
    visited = []
    rng = np.random.default_rng(7)
    e.reset(seed=7)
    for _ in range(250):
        a = int(rng.choice(np.flatnonzero(e.action_masks())))
        _, _, term, trunc, info = e.step(a)
        visited.append(info["q"])
        if term or trunc:
            e.reset()
    q = np.array(visited)
    assert np.all(q >= limits[:, 0] - 1e-9) and np.all(q <= limits[:, 1] + 1e-9)
    for rule in rules:
        assert rule.allowed(q).all(), rule.describe()
    assert min(e.checker.min_distance(qi) for qi in q) >= 0.0
    assert len(np.unique(np.round(q, 6), axis=0)) > 20  # it really moved around


def test_masked_action_is_penalised_and_robot_stays():
    e = DresspackEnv(station="default")
    e.reset(seed=0)
    # push joint 2 to its upper limit so that "+" becomes masked
    for _ in range(20):
        masks = e.action_masks()
        if not masks[2]:
            break
        e.step(2)
    masks = e.action_masks()
    assert not masks[2] and masks[STAY]
    q = e.q
    _, r, _, _, info = e.step(2)
    assert info["invalid_action"] and info["reward_invalid"] == -1.0
    np.testing.assert_array_equal(info["q"], q)
    strict = DresspackEnv(station="default", invalid_action="raise")
    strict.reset(seed=0)
    strict.sim.set_state(e.sim.get_state())
    with pytest.raises(InvalidActionError, match="masked"):
        strict.step(2)


@pytest.mark.parametrize("action", [13, -1, 2.5, "a", None])
def test_malformed_actions_raise_clear_errors(env, action):
    env.reset(seed=0)
    with pytest.raises(InvalidActionError, match="integer in"):
        env.step(action)


def test_bad_env_configuration_names_the_field():
    with pytest.raises(ConfigError) as e:
        DresspackEnv(station="default", welds=["nope"])
    assert e.value.field == "welds"
    with pytest.raises(ConfigError) as e:
        DresspackEnv(station="default", cost_variant="fancy")
    assert e.value.field == "cost_variant"
    with pytest.raises(ConfigError) as e:
        DresspackEnv(station="no_such_station")
    assert e.value.field == "station"


def test_env_pickles_mid_episode(env):
    env.reset(seed=5)
    for a in (0, 0, 3):
        if env.action_masks()[a]:
            env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    np.testing.assert_array_equal(clone.q, env.q)
    for a in (2, 5):
        if env.action_masks()[a]:
            o1, r1, *_ = env.step(a)
            o2, r2, *_ = clone.step(a)
            np.testing.assert_array_equal(o1, o2)
            assert r1 == r2


def test_render_returns_an_rgb_frame():
    e = DresspackEnv(station="default", render_mode="rgb_array", render_size=(160, 120))
    e.reset(seed=0)
    frame = e.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8 and frame.std() > 5
    e.close()


def test_goal_seeking_policy_reaches_goals():
    """A greedy masked policy (largest potential decrease) reaches the first weld: the task is feasible."""
    e = DresspackEnv(station="thesis_distance", max_steps=80)
    e.reset(seed=0)
    reached = 0
    for _ in range(80):
        masks = e.action_masks()
        best, best_phi = STAY, np.inf
        for a in np.flatnonzero(masks[:12]):
            phi = np.max(np.abs(e.target(e.q, a) - e.goal))
            if phi < best_phi:
                best, best_phi = int(a), phi
        _, _, term, trunc, info = e.step(best)
        reached = info["goals_reached"]
        if term or trunc or reached >= 1:
            break
    assert reached >= 1


def test_maskable_ppo_runs_on_the_env():
    """sb3-contrib picks up action_masks() (the full training pipeline is a separate command)."""
    contrib = pytest.importorskip("sb3_contrib")
    e = DresspackEnv(station="thesis_distance", max_steps=16)
    from stable_baselines3.common.logger import Logger

    model = contrib.MaskablePPO("MlpPolicy", e, n_steps=16, batch_size=16, n_epochs=1, seed=0, verbose=0)
    model.set_logger(Logger(folder=None, output_formats=[]))  # SB3's default logger leaves a /tmp/SB3-* folder
    model.learn(total_timesteps=32)
    obs, _ = e.reset(seed=0)
    action, _ = model.predict(obs, action_masks=e.action_masks(), deterministic=True)
    assert e.action_masks()[int(action)]


def test_sim_timestep_builds_a_station_from_the_changed_config():
    """The timestep is a physics setting: the env's station is compiled at it, exactly as a station built at
    that timestep; a caller's station keeps its own. (Since physics v2 no constraint parameter depends on the
    timestep: the edge and clamp stiffness are set in force units.)"""
    from dataclasses import replace

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station

    config = load_station("default")
    station = Station(config)
    e = DresspackEnv(station=station, sim_timestep=0.004)
    at_4ms = Station(replace(config, simulation=replace(config.simulation, timestep=0.004)))
    assert e.station.model.opt.timestep == 0.004 and e.station.config.simulation.timestep == 0.004
    np.testing.assert_array_equal(e.station.model.eq_solref, at_4ms.model.eq_solref)
    np.testing.assert_array_equal(e.station.model.flexedge_invweight0, at_4ms.model.flexedge_invweight0)
    np.testing.assert_array_equal(e.station.model.eq_solref, station.model.eq_solref)  # timestep-independent
    assert e.station is not station and station.model.opt.timestep == config.simulation.timestep


def test_observation_size_comes_from_its_structure():
    e = DresspackEnv(station="thesis_distance", cable_samples=5)
    obs, _ = e.reset(seed=0)
    assert list(e.observation_structure) == ["joints", "goal", "goal_error", "progress", "cable_points", "measures"]
    assert e.observation_structure["cable_points"] == 15
    assert obs.shape == e.observation_space.shape == (sum(e.observation_structure.values()),)


def test_a_step_reports_the_residual_of_its_own_settle():
    e = DresspackEnv(station="default", settle_time=0.0)
    e.reset(seed=0)
    _, _, _, _, info = e.step(STAY)  # waiting lets the cable settle (bounded by the wait)
    assert np.isfinite(info["equilibrium_residual"]) and isinstance(info["settle_converged"], bool)
    assert info["equilibrium_residual"] == pytest.approx(e.sim.last_settle.equilibrium.force_residual)
    moves = [a for a in np.flatnonzero(e.action_masks()) if a != STAY]
    _, _, _, _, info = e.step(int(moves[0]))  # settle_time=0: an ordinary step does not settle
    assert np.isnan(info["equilibrium_residual"]) and not info["settle_converged"]


def test_action_masks_before_reset_is_refused():
    fresh = DresspackEnv(station="default", max_steps=5)
    with pytest.raises(EnvUsageError, match=r"action_masks\(\) before reset"):
        fresh.action_masks()
    fresh.reset(seed=0)
    assert fresh.action_masks().shape == (fresh.n_actions,)
    fresh.close()


def test_step_after_close_is_refused_until_reset():
    e = DresspackEnv(station="default", max_steps=5, settle_time=0.0)
    e.reset(seed=0)
    e.close()
    with pytest.raises(EnvUsageError, match=r"step\(\) after close"):
        e.step(STAY)
    with pytest.raises(EnvUsageError, match=r"action_masks\(\) after close"):
        e.action_masks()
    e.reset(seed=0)  # a new episode reopens it
    assert np.isfinite(e.step(STAY)[1])
    e.close()


@pytest.mark.parametrize("options, field", [
    ({"start": "home"}, "options.start"),
    ({"start": [0.0, 0.1]}, "options.start"),
    ({"start": None}, "options.start"),
    ({"welds": "sill_front"}, "options.welds"),
    ({"welds": ["sill_front", 3]}, "options.welds"),
    ({"goals": {"g": "home"}}, "options.goals.g"),
])
def test_bad_reset_options_name_the_option(env, options, field):
    with pytest.raises(ConfigError) as err:
        env.reset(seed=0, options=options)
    assert err.value.field == field
    assert "'s'" not in str(err.value)  # a weld name is not split into letters


def test_a_weld_name_where_a_list_belongs_is_refused_whole():
    for kwargs, field in (({"welds": "sill_front"}, "welds"), ({"tasks": ["sill_front"]}, "tasks[0]"),
                          ({"tasks": [["sill_front", None]]}, "tasks[0]")):
        with pytest.raises(ConfigError) as err:
            DresspackEnv(station="default", **kwargs)
        assert err.value.field == field and "sill_front" in str(err.value) and "'s'," not in str(err.value)
