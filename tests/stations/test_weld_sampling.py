"""Weld points drawn on the parts: on a face, approached within the tilt cone, reachable and passing the filters."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import Section
from dresspack_gym.io.loading import load_station
from dresspack_gym.robots.kinematics import rpy_matrix
from dresspack_gym.stations.collision import RobotCollisionChecker
from dresspack_gym.stations.config import Obstacle, obstacle_from_section
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.weld_sampling import WeldSampler, WeldSampling, part_faces, tilted


@pytest.fixture(scope="module")
def station():
    return Station(load_station("default"))


@pytest.fixture(scope="module")
def draws(station):
    checker = RobotCollisionChecker(station, 0)
    sampler = WeldSampler(station, 0, checker.collides)
    rng = np.random.default_rng(0)
    return sampler, checker, [sampler.sample(rng, f"w{i}") for i in range(30)]


def test_faces_of_a_rotated_box_part():
    box = Obstacle("b", "box", (1.0, 2.0, 3.0), (0.0, 0.0, math.radians(90)), (0.1, 0.2, 0.3), part=True)
    faces = part_faces((box, replace(box, name="not_a_part", part=False)))
    assert len(faces) == 6 and {f.part for f in faces} == {"b"}
    for f in faces:  # every face centre lies half a size from the centre along its outward normal
        local = rpy_matrix(box.rpy).T @ (f.centre - np.array(box.pos))
        assert np.count_nonzero(np.isclose(np.abs(local), box.size)) == 1
        assert np.dot(f.centre - np.array(box.pos), f.normal) > 0
    assert sum(f.area for f in faces) == pytest.approx(8 * (0.1 * 0.2 + 0.1 * 0.3 + 0.2 * 0.3))
    assert len(part_faces((box,), min_face=0.25)) == 2  # only the 0.4 x 0.6 faces are wide enough


def test_tilt_stays_in_the_cone_and_fills_it():
    rng = np.random.default_rng(1)
    d = np.array([0.0, 0.0, -1.0])
    angles = np.array([math.acos(np.clip(np.dot(tilted(d, math.radians(20), rng), d), -1, 1)) for _ in range(2000)])
    assert angles.max() <= math.radians(20) + 1e-12 and angles.max() > math.radians(19)
    # uniform over the cap: P(angle < a) = (1 - cos a) / (1 - cos 20 deg)
    expected = (1 - math.cos(math.radians(10))) / (1 - math.cos(math.radians(20)))
    assert np.mean(angles < math.radians(10)) == pytest.approx(expected, abs=0.04)


def test_drawn_welds_lie_on_part_faces_and_pass_the_planners_filters(station, draws):
    sampler, checker, samples = draws
    placement = station.config.robots[0]
    kin = station.robots[0].kinematics
    for s in samples:
        pos, approach, face = np.array(s.weld.pos), np.array(s.weld.approach), s.face
        assert abs(np.dot(pos - face.centre, face.normal)) < 1e-12  # on the face's plane ...
        for axis in (face.u, face.v):  # ... and within it
            assert abs(np.dot(pos - face.centre, axis)) <= np.dot(axis, axis) + 1e-12
        assert np.dot(approach, -face.normal) >= math.cos(sampler.settings.tilt_max) - 1e-12
        assert len(s.configurations) >= 1
        assert placement.restrictions.allowed(s.configurations).all()
        for q in s.configurations:
            assert not checker.collides(q)
            tcp = kin.tcp_pose(q)
            assert np.linalg.norm(tcp[:3, 3] - pos) < 1e-6  # the branch really puts the tool tip there
            assert np.dot(tcp[:3, 2], approach / np.linalg.norm(approach)) > 1 - 1e-9
    assert len({s.face.part for s in samples}) >= 3  # draws spread over the body, not one panel


def test_draws_are_reproducible_and_depend_on_the_seed(station, draws):
    sampler, _, samples = draws
    again = [sampler.sample(np.random.default_rng(0), "w0")]
    assert again[0].weld == samples[0].weld
    np.testing.assert_array_equal(again[0].configurations, samples[0].configurations)
    other = sampler.sample(np.random.default_rng(7), "w0")
    assert other.weld.pos != samples[0].weld.pos


def test_bad_input_is_named(station):
    checker = RobotCollisionChecker(station, 0)
    no_parts = Station(replace(station.config, obstacles=tuple(replace(o, part=False)
                                                               for o in station.config.obstacles)))
    with pytest.raises(ConfigError, match="no box obstacle tagged 'part: true'"):
        WeldSampler(no_parts, 0, RobotCollisionChecker(no_parts, 0).collides)
    with pytest.raises(ConfigError, match="weld_sampling.tilt_max"):
        WeldSampling(tilt_max=math.radians(95))
    far = replace(station.config, obstacles=tuple(replace(o, part=False) for o in station.config.obstacles) + (
        Obstacle("far_panel", "box", (9.0, 0.0, 1.0), (0.0, 0.0, 0.0), (0.05, 0.5, 0.5), part=True),))
    far_station = Station(far)
    with pytest.raises(ConfigError, match=r"weld_sampling.tries: no weld point .* in 20 draws"):
        WeldSampler(far_station, 0, RobotCollisionChecker(far_station, 0).collides,
                    WeldSampling(tries=20)).sample(np.random.default_rng(0))
    with pytest.raises(ConfigError, match=r"obstacles\[0\].part: weld points are drawn on the faces of box parts"):
        obstacle_from_section(Section({"name": "ball", "type": "sphere", "radius": 0.2, "part": True},
                                      "obstacles[0]"))
    assert not checker.collides(station.home[0])


# ------------------------------------------------------------------------------ goal-conditioned episodes
def test_env_draws_new_welds_on_the_parts_each_episode():
    import pickle

    from dresspack_gym.env.dresspack_env import DresspackEnv
    from dresspack_gym.stations.tasks import closest_branch

    env = DresspackEnv("default", part_welds=2, max_steps=5, settle_time=0.0)
    assert env.observation_structure["goal_pose"] == 6
    obs, info = env.reset(seed=3)
    assert obs.shape == env.observation_space.shape == (sum(env.observation_structure.values()),)
    names = env.task.goal_names
    assert names[:2] == ["part_0", "part_1"] and names[-1] == "home" and info["n_goals"] == 3
    for name in names[:2]:
        drawn = env.task.sampled[name]
        goal = env.task.episode_goals[name]
        np.testing.assert_array_equal(goal, closest_branch(drawn.configurations, env.placement.home))
        assert env.validity.valid(goal)
    # the observed goal pose is the drawn weld's: tool tip position and approach
    pose = obs[-6:]
    weld = env.task.sampled["part_0"].weld
    np.testing.assert_allclose(pose[:3] * 3.0 + np.array(env.placement.base_pos), weld.pos, atol=1e-5)
    np.testing.assert_allclose(pose[3:], np.array(weld.approach) / np.linalg.norm(weld.approach), atol=1e-5)
    first = [env.task.sampled[n].weld.pos for n in names[:2]]
    env.reset(seed=3)
    assert [env.task.sampled[n].weld.pos for n in names[:2]] == first  # seeded
    env.reset(seed=4)
    assert [env.task.sampled[n].weld.pos for n in names[:2]] != first
    env.step(int(np.flatnonzero(env.action_masks())[0]))
    clone = pickle.loads(pickle.dumps(env))  # a drawn episode survives pickling (vectorised envs, checkpoints)
    np.testing.assert_array_equal(clone.goal, env.goal)
    assert clone.task.goal_names == env.task.goal_names
    with pytest.raises(ConfigError, match="part_welds"):
        DresspackEnv("default", part_welds=1, n_welds=2)


def test_env_takes_explicit_goal_configurations(station):
    from dresspack_gym.env.dresspack_env import DresspackEnv

    env = DresspackEnv("default", max_steps=3)
    goal = env.weld_goals["sill_front"].copy()
    env.reset(seed=0, options={"goals": {"my_weld": goal}})
    assert env.task.goal_names == ["my_weld", "home"]
    np.testing.assert_array_equal(env.goal, goal)
    bad = goal.copy()
    bad[4] = np.radians(500)
    with pytest.raises(ConfigError, match=r"options.goals.my_weld: must be 6 joint angles"):
        env.reset(options={"goals": {"my_weld": bad}})
    with pytest.raises(ConfigError, match="either welds"):
        env.reset(options={"goals": {"my_weld": goal}, "welds": ["sill_front"]})


@pytest.mark.slow  # one of the fast tier's longest: the slow tier runs it
def test_evaluation_on_welds_drawn_from_their_own_seeds(tmp_path):
    pytest.importorskip("ompl.base")
    from dresspack.eval.runs import EvalSpec, build_tasks, run_evaluation

    spec = EvalSpec(methods=("ompl", "ppo"), seeds=(0,), drawn_tasks=2, iterations=500)
    assert spec.tasks == (("drawn_0",), ("drawn_1",))
    station = Station(load_station(spec.station))
    tasks = build_tasks(station, spec)
    again = build_tasks(station, spec)
    for key, task in tasks.items():
        np.testing.assert_array_equal(task.goals, again[key].goals)  # drawn from (drawn_seed, k): reproducible
    assert not np.allclose(tasks[(("drawn_0",), 0)].goals, tasks[(("drawn_1",), 0)].goals)
    rows, _ = run_evaluation(spec, tmp_path / "e", progress=False)
    assert [r["task"] for r in rows] == ["drawn_0"] * 2 + ["drawn_1"] * 2
    ompl = [r for r in rows if r["method"] == "ompl"]
    assert all(r["success"] for r in ompl) and all(r["reversals_per_s"] is not None for r in ompl)
    assert all(isinstance(r["unconverged_stops"], int) for r in ompl)  # every settle's outcome is in the row
    with pytest.raises(ConfigError, match="drawn_tasks"):
        EvalSpec(drawn_tasks=-1)
