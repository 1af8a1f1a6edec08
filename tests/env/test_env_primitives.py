"""The env's planner-like action set: straight to the goal, via configurations, a wait; the wear integral sampled
along each motion; the wear reward cap; errors."""

import math
import pickle

import numpy as np
import pytest
from helpers import STUCK_WELD

from dresspack_gym import ConfigError
from dresspack_gym.env.dresspack_env import TO_GOAL, DresspackEnv, InvalidActionError
from dresspack_gym.env.episode_wear import cost_row

FREE_WAY = {"welds": ["roof_rail_top"]}  # the straight way from Home to this weld is free


@pytest.fixture(scope="module")
def env():
    e = DresspackEnv(station="default", action_set="primitives", via_offsets_deg=[30.0, 60.0], wear_integral=True,
                     settle_time=0.0, collision_margin=0.005, physics_profile="training", max_steps=12)
    yield e
    e.close()


def test_action_layout_and_targets(env):
    assert env.n_actions == 2 + 12 * 2 and env.stay_action == env.n_actions - 1
    env.reset(seed=0)
    q, goal = env.q, env.goal
    np.testing.assert_array_equal(env.target(q, TO_GOAL), goal)
    np.testing.assert_array_equal(env.target(q, env.stay_action), q)
    # action 1 + 12 i + 2 j (+1): the midpoint with joint j offset by +(-) via_offsets_deg[i]
    for i, off in enumerate((30.0, 60.0)):
        for j in range(6):
            for sign, k in ((1.0, 0), (-1.0, 1)):
                a = 1 + 12 * i + 2 * j + k
                expected = q + 0.5 * (goal - q)
                expected[j] += sign * math.radians(off)
                np.testing.assert_allclose(env.target(q, a), expected, atol=1e-12)
                assert f"j{j + 1} {sign * off:+g} deg" in env.describe_action(a)
    assert env.describe_action(TO_GOAL) == "straight to the goal" and env.describe_action(env.stay_action) == "stay"


def test_here_anchored_vias_offset_the_current_configuration():
    e = DresspackEnv(station="default", action_set="primitives", via_offsets_deg=[30.0, 60.0],
                     via_anchors=["midpoint", "here"], physics_profile="training")
    assert e.n_actions == 2 + 12 * 2 * 2 and e.observation_structure["action_masks"] == e.n_actions
    assert e.observation_space.shape == (sum(e.observation_structure.values()),)
    e.reset(seed=0)
    q, goal = e.q, e.goal
    for i, off in enumerate((30.0, 60.0)):
        for j in range(6):
            for sign, k in ((1.0, 0), (-1.0, 1)):
                mid, here = 1 + 12 * i + 2 * j + k, 1 + 24 + 12 * i + 2 * j + k
                expected = q + 0.5 * (goal - q)
                expected[j] += sign * math.radians(off)
                np.testing.assert_allclose(e.target(q, mid), expected, atol=1e-12)
                expected = q.copy()
                expected[j] += sign * math.radians(off)
                np.testing.assert_allclose(e.target(q, here), expected, atol=1e-12)
                assert e.describe_action(here) == f"via here with j{j + 1} {sign * off:+g} deg"
    other = goal + 0.3  # any leg's end: what the reachability study (scripts/studies/primitive_reach.py) asks
    for a in (TO_GOAL, 1, 30):
        expected = e.target(q, a)
        np.testing.assert_allclose(e.target(q, a, other), expected + (other - goal) * (0.0 if a == 30 else
                                                                                        1.0 if a == TO_GOAL else 0.5))
    # a here-anchored via leaves the other joints where they are: the segment moves one joint only
    a = int(next(a for a in range(25, e.n_actions - 1) if e.action_masks()[a]))
    _, _, _, _, info = e.step(a)
    moved = np.abs(info["moved_through"][0] - q) > 1e-12
    assert moved.sum() == 1
    e.close()


TUCK_DEG = [-93.2, -46.3, -107.9, 51.7, 14.1, 223.0]  # a travel posture of the wear-aware planner's routes


def test_travel_postures_are_actions_after_the_vias():
    """Each of ``via_postures_deg`` is one action, after the vias and before the wait: it goes to that posture
    from anywhere, masked as any segment, and the observation's mask grows with it."""
    postures = [TUCK_DEG, [0.0, -20.0, 10.0, 180.0, -60.0, 180.0]]
    e = DresspackEnv(station="default", action_set="primitives", via_anchors=["midpoint", "here"],
                     fallback_anchors=["here"], via_postures_deg=postures, physics_profile="training",
                     wear_integral=True, settle_time=0.0, collision_margin=0.005, part_welds=1)
    plain = DresspackEnv(station="default", action_set="primitives", via_anchors=["midpoint", "here"],
                         fallback_anchors=["here"], physics_profile="training", part_welds=1)
    assert e.n_actions == plain.n_actions + 2 and e.stay_action == e.n_actions - 1
    assert e.observation_structure["action_masks"] == e.n_actions
    assert e.observation_space.shape == (plain.observation_space.shape[0] + 2,)
    first = 1 + 12 * 2 * 2
    e.reset(seed=0)
    q = e.q
    for k, posture in enumerate(postures):
        assert e.describe_action(first + k) == f"via travel posture {k}"
        np.testing.assert_allclose(e.target(q, first + k), np.radians(posture), atol=1e-12)
        np.testing.assert_allclose(e.target(q + 0.2, first + k, q), np.radians(posture), atol=1e-12)
    assert not e.actions.fallback[first:first + 2].any()  # offered like any other move
    masks = e.action_masks()
    np.testing.assert_array_equal(masks[:first], plain.masks_at(q, e.goal)[:first])
    assert masks[first] == e.segment_valid(q, np.radians(postures[0]))
    # taken: the robot stands at the posture, and the motion's wear is integrated as for any segment
    _, _, _, _, info = e.step(first)
    np.testing.assert_allclose(e.q, np.radians(TUCK_DEG), atol=1e-12)
    np.testing.assert_allclose(info["moved_through"], np.radians([TUCK_DEG]), atol=1e-12)
    assert info["integral_cost"] > 0.0 and info["step_time"] > 1.0
    e.close()
    plain.close()


def test_fallback_vias_are_offered_only_where_nothing_else_moves():
    kw = {"station": "default", "action_set": "primitives", "via_anchors": ["midpoint", "here"],
          "collision_margin": 0.005, "physics_profile": "training"}
    always, fallback = DresspackEnv(**kw), DresspackEnv(**kw, fallback_anchors=["here"])
    here = np.arange(25, 49)
    home = always.task.home.copy()
    # at the stuck weld heading Home nothing but here-vias moves: the fallback env offers the same ones
    stuck = always.masks_at(STUCK_WELD, home)
    assert not stuck[:25].any() and stuck[here].any()
    np.testing.assert_array_equal(fallback.masks_at(STUCK_WELD, home), stuck)
    # from Home toward that weld midpoint vias are free: the fallback env masks every here-via, the rest equal
    free = always.masks_at(home, STUCK_WELD)
    assert free[1:25].any() and free[here].any()
    masks = fallback.masks_at(home, STUCK_WELD)
    assert not masks[here].any()
    np.testing.assert_array_equal(np.delete(masks, here), np.delete(free, here))
    # taking a masked fallback via says why
    strict = DresspackEnv(**kw, fallback_anchors=["here"], invalid_action="raise")
    strict.reset(seed=0, options={"goals": {"stuck": STUCK_WELD}})
    with pytest.raises(InvalidActionError, match="fallback via"):
        strict.step(int(here[np.flatnonzero(free[here])[0]]))
    # where the fallback vias are offered, one still masked is masked for what it hits
    strict.reset(seed=0, options={"start": STUCK_WELD, "goals": {"home": home}})
    np.testing.assert_array_equal(strict.action_masks(), stuck)
    with pytest.raises(InvalidActionError) as err:
        strict.step(int(here[np.flatnonzero(~stuck[here])[0]]))
    assert "fallback" not in str(err.value)
    for e in (always, fallback, strict):
        e.close()


def test_straight_to_the_goal_reaches_it_in_one_step_and_integrates_the_wear(env):
    env.reset(seed=1, options=FREE_WAY)
    assert env.action_masks()[TO_GOAL]
    goal = env.goal.copy()
    _, r, _, _, info = env.step(TO_GOAL)
    np.testing.assert_array_equal(info["q"], goal)
    assert info["goals_reached"] == 1 and info["reward_goal"] > 0
    np.testing.assert_array_equal(info["moved_through"][-1], goal)
    # the wear term is the integral of C along the motion, not C at its end times its duration: a second run of
    # the same motion, sampled ten times more densely by the simulator itself, gives the same integral
    clone = DresspackEnv(**{**env._kwargs})
    clone.reset(seed=1, options=FREE_WAY)
    q_all = clone.sim.q.copy()
    q_all[0] = goal
    t0, c0 = clone.sim.motion_time, clone.task.cost(clone.sim.measures()).total
    trace = clone.sim.move_to(q_all, settle=False, record_every=0.005)
    t = np.r_[t0, trace.time]
    c = np.r_[c0, [clone.task.cost(m).total for m in trace.measures]]
    dense = float(np.sum(0.5 * (c[1:] + c[:-1]) * np.diff(t)))
    assert -info["reward_wear"] == pytest.approx(dense, rel=0.05)
    assert info["reward_time"] == pytest.approx(-info["step_time"])
    assert r == pytest.approx(sum(info[f"reward_{k}"] for k in ("time", "wear", "progress", "goal", "invalid")))


def test_a_wait_at_rest_integrates_a_constant_cost():
    e = DresspackEnv(station="default", action_set="primitives", wear_integral=True, physics_profile="training")
    e.reset(seed=0)
    e.sim.settle()  # at equilibrium: C stays what it is over the wait
    e.wear.cost_now = cost_row(e.task.cost(e.sim.measures()))
    _, _, _, _, info = e.step(e.stay_action)
    assert -info["reward_wear"] == pytest.approx(info["cost"] * info["step_time"], rel=1e-3)


def test_the_wear_reward_cap_bounds_each_step():
    e = DresspackEnv(station="default", action_set="primitives", wear_integral=True, physics_profile="training",
                     wear_reward_cap=1e-3)
    e.reset(seed=2, options=FREE_WAY)
    _, _, _, _, info = e.step(TO_GOAL)
    assert info["cost"] > 0 and info["reward_wear"] == pytest.approx(-1e-3)


def test_random_masked_primitives_keep_every_segment_valid(env):
    """Every segment an allowed action drives passes the planners' continuous check (independent code path)."""
    rng = np.random.default_rng(3)
    env.reset(seed=3)
    segments = 0
    for _ in range(10):
        q0 = env.q
        a = int(rng.choice(np.flatnonzero(env.action_masks())))
        _, _, term, trunc, info = env.step(a)
        for q1 in info["moved_through"]:
            assert env.validity.segment_valid(q0, q1), (env.describe_action(a), q0, q1)
            q0, segments = q1, segments + 1
        if term or trunc:
            env.reset(seed=int(rng.integers(1000)))
    assert segments >= 5


def test_primitive_env_pickles_mid_episode(env):
    env.reset(seed=4)
    a = int(np.flatnonzero(env.action_masks())[1])
    env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    a = int(np.flatnonzero(env.action_masks())[0])
    o1, r1, *_ = env.step(a)
    o2, r2, *_ = clone.step(a)
    np.testing.assert_array_equal(o1, o2)
    assert r1 == r2


def test_snapshot_and_restore_continue_an_episode_exactly(env):
    """Searching over action sequences: after a detour and a restore, the same actions give the same steps, to
    the bit, as a fresh episode does (observation, reward, cost integral, settle report, the final fatigue life)."""
    def run(e):
        """Straight on where that is free, else the first free action, to the episode's end."""
        out, done = [], False
        while not done:
            masks = e.action_masks()
            obs, reward, term, trunc, info = e.step(0 if masks[0] else int(np.flatnonzero(masks)[0]))
            done = term or trunc
            out.append((obs, reward, term, trunc, info["integral_cost"], info["settle_converged"], info["cycle_time"],
                        info.get("life_cycles")))
        return out

    env.reset(seed=4, options={"welds": ["sill_front"]})
    first = int(np.flatnonzero(env.action_masks())[1])
    env.step(first)
    snap = env.snapshot()
    detour = int(np.flatnonzero(env.action_masks())[-2])
    env.step(detour)
    env.restore(snap)
    restored = run(env)  # to the weld (settling there), off the panel by a via, Home
    env.restore(snap)
    again = run(env)
    env.reset(seed=4, options={"welds": ["sill_front"]})
    env.step(first)
    fresh = run(env)
    assert len(restored) == len(again) == len(fresh) == 3
    for a, b, c in zip(restored, again, fresh):
        for x, y, z in zip(a, b, c):
            np.testing.assert_array_equal(x, y)
            np.testing.assert_array_equal(x, z)
    assert restored[-1][2] and restored[-1][7] is not None  # finished: the episode's fatigue life compared too
    with pytest.raises(ConfigError, match="snapshot"):
        env.restore({"sim": None})


@pytest.mark.parametrize("kwargs, field", [
    ({"action_set": "segments"}, "action_set"),
    ({"action_set": "primitives", "via_offsets_deg": []}, "via_offsets_deg"),
    ({"action_set": "primitives", "via_offsets_deg": "30"}, "via_offsets_deg"),
    ({"action_set": "primitives", "via_offsets_deg": [30.0, 0.0]}, "via_offsets_deg[1]"),
    ({"action_set": "primitives", "goal_action": True}, "goal_action"),
    ({"action_set": "primitives", "via_anchors": "here"}, "via_anchors"),
    ({"action_set": "primitives", "via_anchors": []}, "via_anchors"),
    ({"action_set": "primitives", "via_anchors": ["midpoint", "start"]}, "via_anchors[1]"),
    ({"action_set": "primitives", "via_anchors": ["here", "here"]}, "via_anchors"),
    ({"action_set": "primitives", "via_anchors": ["midpoint", "here"], "fallback_anchors": "here"},
     "fallback_anchors"),
    ({"action_set": "primitives", "via_anchors": ["midpoint", "here"], "fallback_anchors": ["corner"]},
     "fallback_anchors[0]"),
    ({"action_set": "primitives", "fallback_anchors": ["here"]}, "fallback_anchors[0]"),  # not a via anchor
    ({"action_set": "primitives", "via_anchors": ["midpoint", "here"], "fallback_anchors": ["here", "midpoint"]},
     "fallback_anchors"),  # nothing left to fall back from
    ({"action_set": "primitives", "via_anchors": ["midpoint", "here"], "fallback_anchors": ["here", "here"]},
     "fallback_anchors"),
    ({"fallback_anchors": ["here"]}, "fallback_anchors"),  # joint steps have no vias
    ({"action_set": "primitives", "via_postures_deg": "tuck"}, "via_postures_deg"),
    ({"action_set": "primitives", "via_postures_deg": [[0, -20, 10, 180, -60]]}, "via_postures_deg[0]"),
    ({"action_set": "primitives", "via_postures_deg": [[0, -20, 10, 180, -60, 180], [0, 0, 0, 0, 200, 0]]},
     "via_postures_deg[1][4]"),  # beyond joint 5's limits
    ({"action_set": "primitives", "via_postures_deg": [[0, -20, 10, 180, float("nan"), 180]]},
     "via_postures_deg[0][4]"),
    ({"via_postures_deg": [[0, -20, 10, 180, -60, 180]]}, "via_postures_deg"),  # joint steps have no vias
    ({"wear_reward_cap": -1.0}, "wear_reward_cap"),
    ({"wear_reward_cap": float("nan")}, "wear_reward_cap"),
])
def test_bad_action_set_arguments_name_the_field(kwargs, field):
    with pytest.raises(ConfigError) as err:
        DresspackEnv(station="default", **kwargs)
    assert err.value.field == field


def test_the_observation_carries_the_action_mask(env):
    obs, _ = env.reset(seed=5)
    start = sum(n for k, n in env.observation_structure.items() if k != "action_masks")
    assert list(env.observation_structure)[-1] == "action_masks"
    np.testing.assert_array_equal(obs[start:] > 0, env.action_masks())
    obs, *_ = env.step(int(np.flatnonzero(env.action_masks())[0]))
    np.testing.assert_array_equal(obs[start:] > 0, env.action_masks())
