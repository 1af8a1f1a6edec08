"""Gymnasium environment: joint-space motion of a robot carrying a simulated dresspack, masked actions.

Episode: starting at Home, visit the task's weld configurations in order, then return Home. Each weld
configuration is the restriction-passing, collision-free IK branch closest to Home (max joint change).

Actions (``Discrete(13)``, or ``Discrete(14)`` with ``goal_action=True``): action ``2 j`` moves joint ``j`` by
``+joint_step``, ``2 j + 1`` by ``-joint_step`` (j = 0..5), action 12 holds still for ``joint_step`` worth of
time, action 13 (optional) moves all joints together straight toward the current goal, the largest joint
change being ``joint_step`` (a straight joint-space move is what a planner's segment is, so a policy can match
a planner's cycle time where the straight way is free). When every joint is within half a step of the
current goal the robot finishes the move onto the goal exactly (that motion is simulated and timed too) and
the goal is reached; the cable then settles (the robot dwells while welding, as in trajectory replay).
With ``action_set="primitives"`` the actions are planner-like segments instead (``Discrete(2 + 12 k a)`` for k
``via_offsets_deg`` and a ``via_anchors``): action 0 goes straight to the goal; action ``1 + 12 (k b + i) + 2 j (+1)``
goes to anchor ``b``'s configuration with joint ``j`` offset by ``+(-)via_offsets_deg[i]`` (a via configuration:
around an obstacle with j1-j3, re-orienting the wrist with j4-j6). Anchors: ``"midpoint"``
(halfway toward the goal) and ``"here"`` (the current configuration: backing out of a tight spot, e.g. away
from the panel just welded, before heading anywhere); the last action waits. An anchor in ``fallback_anchors``
offers its vias only where no other move is free (so a policy keeps to the others and uses these to get out of a
spot they cannot leave). ``via_postures_deg`` adds one action per given configuration, after the vias: go to that
posture (a cell's travel positions, where the cable hangs easy; a wear-aware planner's routes pass through such
postures, see ``scripts/travel_postures.py``). ``approach_vias`` adds that many more: via an approach configuration
of the current goal (:mod:`approach`: free configurations within ``approach_range_deg`` of the goal from which the
straight segment into it is free, drawn from the goal itself, so they are the same in any run); a weld in a pocket of
the body admits only a narrow cone of straight entries, which no offset of the midpoint finds. A replayed episode
is then a via path whose segments the time law times rest-to-rest, exactly like a planner's, and an episode takes
a few decisions per leg.

Tasks: ``welds`` (all of them, in order), or each episode ``n_welds`` of them (optionally shuffled), or one
of the weld lists in ``tasks``; ``reset(options={"welds": [...], "start": q})`` sets both explicitly. With
``sim_timestep`` the env compiles its own station from the config with that physics step (e.g. 4 ms to train
faster; everything derived from the step follows it; evaluation replays the resulting trajectory at the
station's own step). With ``start_noise_deg`` the episode starts at a random valid configuration within that many degrees of Home
(drawn from ``np_random``, the cable settled there); it always ends at Home.

Masks (``action_masks()``, sb3-contrib convention): an action is masked when the joint limits or an active
joint restriction (thesis §4.1) are violated along the move (checked every ``mask_resolution_deg``), or when
the robot comes closer to an obstacle than ``collision_margin`` (at least 2 mm) anywhere along it: collisions
are checked continuously with the planners' :class:`~dresspack_gym.stations.validity.MotionValidity`, so every
trajectory a masked policy drives is valid for the planners' checker too. Taking a
masked action anyway: with ``invalid_action="penalize"`` (default, so generic checkers can sample actions)
the robot stays where it is, the step costs ``invalid_penalty`` and ``info["invalid_action"]`` is True;
with ``invalid_action="raise"`` an :class:`InvalidActionError` is raised. The robot never enters a
forbidden configuration either way.

Reward per step: the task's (:class:`~dresspack_gym.env.weld_cycle.WeldCycleTask`, which owns goals, reward terms
and termination; ``_get_rew`` returns the reward and its named terms, all in ``info`` as ``reward_<term>``)::

    reward = reward_time + reward_wear + reward_progress + reward_goal + reward_invalid

``reward_progress`` is potential-based shaping (it does not change which policies are optimal);
``reward_goal`` makes completion learnable. ``settle_time`` bounds the cable settling after each ordinary
step (0: the cable keeps its motion into the next step, as in a continuous trajectory). The episode terminates when Home is reached after the last
weld and is truncated after ``max_steps``.

Observation (float32, all roughly in [-1, 1]), laid out by ``observation_structure`` (part name -> size, in
order; the space's size is their sum): joints scaled by their limits (6), goal scaled likewise (6), joint error to
the goal / pi (6), task progress (1), ``cable_samples`` cable points in the TCP frame divided by the cable length
(3 each), and the measures κ/κ0, F/``tension_scale``, d/c (3); with ``part_welds`` (each episode draws that many
weld points on the station's parts, :mod:`weld_sampling`) also the goal's tool position from the base /
``POSE_SCALE`` and its approach direction (6); with ``approach_vias`` each approach configuration's joint change
from where the robot is / pi (6 each, zeros for an approach the goal does not have); with
``action_set="primitives"`` also the action mask (+1 allowed, -1 masked, one per action): whether each candidate
segment is free is what the policy sees of the geometry around its way, so a changed station changes what it
observes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import ConfigError, DresspackError, EnvUsageError
from ..fields import check_choice, check_integer, check_number, check_vector
from ..io.loading import load_station
from ..physics.damage import damage_rate
from ..physics.fatigue import fatigue_life
from ..physics.profiles import PROFILES, with_profile
from ..physics.segment_state import SegmentState
from ..physics.simulation import CableSimulator
from ..physics.trajectory import Trajectory, smoothness
from ..physics.wear_cost import COST_VARIANTS
from ..robots.joint_limits import check_within_limits
from ..robots.time_law import segment_durations
from ..stations.approach import approach_configurations
from ..stations.collision import RobotCollisionChecker
from ..stations.rendering import check_frame_size
from ..stations.station import Station
from ..stations.tasks import random_start
from ..stations.validity import MotionValidity
from ..stations.weld_sampling import WeldSampling
from .weld_cycle import REWARD_TERMS, WeldCycleTask

# Observations are clipped to +-OBS_BOUND (all parts are scaled to about [-1, 1]); clearance is observed as d/c up
# to CLEARANCE_OBS_CAP: farther than a few clearance thresholds from everything carries no information.
OBS_BOUND = 10.0
CLEARANCE_OBS_CAP = 5.0
# [m] the goal tool position is observed relative to the robot's base in these units (the shipped robots reach
# 2.55-2.7 m), so it stays within about [-1, 1]
POSE_SCALE = 3.0
N_JOINT_ACTIONS = 12
STAY = 12
TOWARD_GOAL = 13
# The "primitives" action set: action 0 goes straight to the goal (a planner's segment), then per via anchor, via
# offset, joint and sign a via configuration (the anchor, the midpoint toward the goal or where the robot is, with
# that joint offset: a detour around an obstacle with j1-j3, a wrist re-orientation with j4-j6), and last a wait.
# Every action is one straight, rest-to-rest segment timed by the time law, so a replayed episode is as smooth as a
# planner's via path.
ACTION_SETS = ("joint_steps", "primitives")
# where a via configuration is taken from, as the fraction of the way toward the goal
VIA_ANCHORS = {"midpoint": 0.5, "here": 0.0}
TO_GOAL = 0
# [s] with wear_integral the cost is sampled this often along a motion and integrated (trapezoid): a primitive
# segment lasts seconds, its end state alone would miss what the cable went through on the way
WEAR_SAMPLE_TIME = 0.05
APPROACH_CACHE = 16  # goals whose approach configurations are kept (a search revisits an episode's few goals)


COST_TERMS = ("total", "curvature", "tension", "distance", "twist", "damage")


def _cost_row(cost) -> np.ndarray:
    """A WearCost as numbers in COST_TERMS order."""
    return np.array([cost.total, cost.curvature, cost.tension, cost.distance, cost.twist, cost.damage])


def _trapezoid(times: list[float], rows: list[np.ndarray]) -> np.ndarray:
    """Per term of COST_TERMS, the integral over a step from its samples (start, on the way, end)."""
    t, c = np.asarray(times, dtype=float), np.asarray(rows, dtype=float)
    return np.sum(0.5 * (c[1:] + c[:-1]) * np.diff(t)[:, None], axis=0)


@dataclass(frozen=True)
class EnvSnapshot:
    """Everything an episode's continuation depends on, from :meth:`DresspackEnv.snapshot`: restored into the same
    env (or a pickled copy), the next steps give the same observations, rewards and infos as without the detour."""

    sim: np.ndarray  # CableSimulator.get_state(): MuJoCo state with the DER frames, commanded q, motion time
    last_settle: Any  # the simulator's last settle, so a restored step reports only a settle it made itself
    goal_names: tuple[str, ...]  # the episode's welds in order (Home follows)
    episode_goals: dict  # drawn or given weld configurations of this episode
    goal_index: int
    steps: int
    cycle_time: float
    needs_reset: bool
    episode_path: tuple[np.ndarray, ...]
    cost_now: np.ndarray  # cost terms at the current state: where the next step's wear integral starts
    damage: tuple  # (per-segment damage so far, its current rate, the episode's segment states)
    rng: dict | None  # the env's random generator state


class InvalidActionError(DresspackError, ValueError):
    """A masked or malformed action was taken with ``invalid_action="raise"``."""


RESET_OPTIONS = ("welds", "goals", "start")
# Ranges of the numeric keyword arguments: (low, high, integer). Everything a trainer passes through from its
# YAML is checked here, once, so a bad value fails at construction naming the argument, not as NaN logits later.
_NUMBER_ARGS = {
    "robot": (0, 64, True),
    "n_welds": (1, 10_000, True),
    "joint_step_deg": (0.1, 90.0, False),
    "max_steps": (1, 1_000_000, True),
    "time_weight": (0.0, 1e6, False),
    "wear_weight": (0.0, 1e6, False),
    "goal_reward": (0.0, 1e6, False),
    "progress_weight": (0.0, 1e6, False),
    "invalid_penalty": (0.0, 1e6, False),
    "settle_time": (0.0, 10.0, False),
    "cable_samples": (2, 1000, True),
    "collision_margin": (0.0, 1.0, False),
    "mask_resolution_deg": (0.01, 90.0, False),
    "start_noise_deg": (0.0, 180.0, False),
    "sim_timestep": (1e-4, 0.01, False),
    "part_welds": (0, 100, True),
    "weld_tilt_deg": (0.0, 80.0, False),
    "wear_reward_cap": (1e-6, 1e12, False),
    "approach_vias": (0, 16, True),
    "approach_range_deg": (1.0, 180.0, False),
}
VIA_OFFSET_RANGE_DEG = (1.0, 180.0)
_BOOL_ARGS = ("shuffle_welds", "goal_action", "wear_integral")


def _primitives_list(kw: dict[str, Any], name: str, expected: str) -> list | tuple:
    """Argument ``name``: a list (``expected`` says of what), and empty unless the action set is primitives."""
    value = kw[name]
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
        raise ConfigError(name, f"expected {expected}, got {value!r}")
    if value and kw["action_set"] != "primitives":
        raise ConfigError(name, "applies to action_set primitives only (joint steps have no vias)")
    return value


def _check_arguments(kw: dict[str, Any]) -> None:
    """Every keyword argument typed, finite and in range, or a ConfigError naming it and what it allows."""
    if not isinstance(kw["station"], (str, Station)):
        raise ConfigError("station", f"expected a station name, YAML path or Station, got {kw['station']!r}")
    for name, (lo, hi, integer) in _NUMBER_ARGS.items():
        value = kw[name]
        if value is None and name in ("n_welds", "sim_timestep", "wear_reward_cap"):
            continue
        if integer:
            check_integer(value, name, lo=lo, hi=hi)
        else:
            check_number(value, name, lo=lo, hi=hi, unit="deg" if name.endswith("_deg") else "")
    if kw["mask_resolution_deg"] > kw["joint_step_deg"]:
        raise ConfigError("mask_resolution_deg", f"{kw['mask_resolution_deg']} must not exceed joint_step_deg "
                                                 f"({kw['joint_step_deg']}): a step is checked at this resolution")
    for name in _BOOL_ARGS:
        if not isinstance(kw[name], (bool, np.bool_)):
            raise ConfigError(name, f"expected true or false, got {kw[name]!r}")
    if kw["welds"] is not None and (isinstance(kw["welds"], str) or not isinstance(kw["welds"], (list, tuple))
                                    or not all(isinstance(w, str) for w in kw["welds"])):
        raise ConfigError("welds", f"expected a list of weld-point names, got {kw['welds']!r}")
    check_choice("cost_variant", kw["cost_variant"], COST_VARIANTS)
    check_choice("physics_profile", kw["physics_profile"], list(PROFILES))
    check_choice("invalid_action", kw["invalid_action"], ("penalize", "raise"))
    check_choice("action_set", kw["action_set"], ACTION_SETS)
    offsets = kw["via_offsets_deg"]
    if isinstance(offsets, (str, bytes)) or not isinstance(offsets, (list, tuple)) or not offsets:
        raise ConfigError("via_offsets_deg", f"expected a non-empty list of angles [deg], got {offsets!r}")
    for i, v in enumerate(offsets):
        check_number(v, f"via_offsets_deg[{i}]", lo=VIA_OFFSET_RANGE_DEG[0], hi=VIA_OFFSET_RANGE_DEG[1], unit="deg")
    anchors = kw["via_anchors"]
    if isinstance(anchors, (str, bytes)) or not isinstance(anchors, (list, tuple)) or not anchors:
        raise ConfigError("via_anchors", f"expected a non-empty list from {list(VIA_ANCHORS)}, got {anchors!r}")
    for i, anchor in enumerate(anchors):
        check_choice(f"via_anchors[{i}]", anchor, list(VIA_ANCHORS))
    if len(set(anchors)) != len(anchors):
        raise ConfigError("via_anchors", f"each anchor at most once, got {list(anchors)}")
    fallback = _primitives_list(kw, "fallback_anchors", f"a list of anchors from via_anchors {list(anchors)}")
    for i, anchor in enumerate(fallback):
        check_choice(f"fallback_anchors[{i}]", anchor, list(anchors))
    if len(set(fallback)) != len(fallback) or len(set(fallback)) == len(anchors):
        raise ConfigError("fallback_anchors", f"each anchor at most once, and at least one of via_anchors "
                                              f"{list(anchors)} not a fallback, got {list(fallback)}")
    postures = _primitives_list(kw, "via_postures_deg", "a list of joint configurations (6 angles each) [deg]")
    for i, posture in enumerate(postures):
        check_vector(posture, f"via_postures_deg[{i}]", 6, unit="deg")
    if kw["approach_vias"] and kw["action_set"] != "primitives":
        raise ConfigError("approach_vias", "applies to action_set primitives only (joint steps have no vias)")
    if kw["goal_action"] and kw["action_set"] == "primitives":
        raise ConfigError("goal_action", "applies to action_set joint_steps only (primitives always go to the goal "
                                         "with action 0)")
    check_choice("render_mode", kw["render_mode"], (None, "rgb_array"))
    size = kw["render_size"]
    if not isinstance(size, (list, tuple)) or len(size) != 2:
        raise ConfigError("render_size", f"expected (width, height) in pixels, got {size!r}")
    check_frame_size(size[0], size[1])


class DresspackEnv(gym.Env):
    """Visit weld configurations and return Home; reward = -(time + wear cost) + completion terms."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, station: str = "default", robot: int = 0, welds: list[str] | None = None,
                 n_welds: int | None = None, shuffle_welds: bool = False, joint_step_deg: float = 10.0,
                 max_steps: int = 200, time_weight: float = 1.0, wear_weight: float = 1.0,
                 cost_variant: str = "thesis", goal_reward: float = 10.0, progress_weight: float = 1.0,
                 invalid_action: str = "penalize", invalid_penalty: float = 1.0, settle_time: float = 0.3,
                 cable_samples: int = 8, collision_margin: float = 0.0, mask_resolution_deg: float = 2.0,
                 goal_action: bool = False, wear_integral: bool = False, tasks: list[list[str]] | None = None,
                 start_noise_deg: float = 0.0, sim_timestep: float | None = None,
                 physics_profile: str = "accurate", part_welds: int = 0,
                 weld_tilt_deg: float = 20.0, action_set: str = "joint_steps",
                 via_offsets_deg: tuple[float, ...] = (30.0, 60.0), via_anchors: tuple[str, ...] = ("midpoint",),
                 fallback_anchors: tuple[str, ...] = (), via_postures_deg: tuple[tuple[float, ...], ...] = (),
                 approach_vias: int = 0, approach_range_deg: float = 45.0, wear_reward_cap: float | None = None,
                 render_mode: str | None = None, render_size: tuple[int, int] = (480, 360)):
        self._kwargs = dict(locals())
        for k in ("self", "__class__"):
            self._kwargs.pop(k, None)
        _check_arguments(self._kwargs)
        geometry = station if isinstance(station, Station) else None
        if sim_timestep is not None or physics_profile != "accurate":
            # a station compiled from the changed config: everything derived from the timestep (the cable's
            # constraint impedances) follows it, and a caller's Station keeps its own
            config = station.config if isinstance(station, Station) else load_station(station)
            if physics_profile != "accurate" and geometry is None:
                geometry = Station(config)
            config = with_profile(config, physics_profile)
            if sim_timestep is not None:
                config = replace(config, simulation=replace(config.simulation, timestep=float(sim_timestep)))
            station = Station(config)
        self.station = station if isinstance(station, Station) else Station(load_station(station))
        if not 0 <= robot < self.station.n_robots:
            raise ConfigError("robot", f"robot index {robot} out of range for {self.station.n_robots} robot(s)")
        self.robot_index = robot
        self.robot = self.station.robots[robot]
        self.placement = self.station.config.robots[robot]
        self.sim = CableSimulator(self.station)
        self.home_state = self.sim.get_state()
        # Collision geometry is the given station's whatever the physics profile: what a motion may do must not
        # depend on how finely its cable is simulated (a coarser profile's longer rigid clamp edges, robot hardware
        # in the checks, would otherwise reject goals and moves the planners accept).
        self.validity = MotionValidity(geometry or self.station, robot, collision_margin, mask_resolution_deg)
        self.checker: RobotCollisionChecker = self.validity.checker
        self.restrictions = self.placement.restrictions
        self.limits = self.placement.robot.joint_limits
        self.step_size = math.radians(joint_step_deg)
        self.substeps = max(1, int(math.ceil(joint_step_deg / mask_resolution_deg)))
        self.max_steps = int(max_steps)
        self.invalid_action = invalid_action
        self.settle_time = float(settle_time)
        # the limits a replayed program runs at (the robot's, at the station's speed fraction), as in the evaluation
        self._program_limits = self.placement.robot.joint_motion_limits.at_speed(self.station.config.simulation.speed_fraction)
        self._stay_time = self._step_time()  # the limits never change: timed once, not on every "stay"
        self.cable_samples = int(cable_samples)
        self.render_mode = render_mode
        self.render_size = render_size
        self._renderer = None
        self.task = WeldCycleTask(self.station, robot, self.checker.collides, self.step_size, welds=welds,
                                  n_welds=n_welds, shuffle_welds=shuffle_welds, tasks=tasks, time_weight=time_weight,
                                  wear_weight=wear_weight, goal_reward=goal_reward, progress_weight=progress_weight,
                                  invalid_penalty=invalid_penalty, wear_integral=wear_integral,
                                  cost_variant=cost_variant, part_welds=part_welds,
                                  weld_sampling=WeldSampling(tilt_max=math.radians(weld_tilt_deg)),
                                  wear_reward_cap=wear_reward_cap)
        self.goal_action = bool(goal_action)
        self.start_noise = math.radians(start_noise_deg)
        self.observation_structure = {"joints": 6, "goal": 6, "goal_error": 6, "progress": 1,
                                      "cable_points": 3 * self.cable_samples, "measures": 3}
        if part_welds:  # goals change every episode: the goal's tool pose too (position, approach)
            self.observation_structure["goal_pose"] = 6
        if approach_vias:  # where the goal's approach configurations are, from here
            self.observation_structure["approaches"] = 6 * approach_vias
        if action_set == "primitives":  # which segments are free: probes of the geometry along each candidate
            self.observation_structure["action_masks"] = 2 + 12 * len(via_offsets_deg) * len(via_anchors) + \
                len(via_postures_deg) + approach_vias
        n_obs = sum(self.observation_structure.values())
        self.observation_space = gym.spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(n_obs,), dtype=np.float32)
        self.action_set = action_set
        if action_set == "primitives":
            # (fraction toward the goal, joint, signed offset) per via action, in action order 1..n; the wait is
            # the last action
            self._vias = [(VIA_ANCHORS[anchor], j, sign * math.radians(off)) for anchor in via_anchors
                          for off in via_offsets_deg for j in range(6) for sign in (1.0, -1.0)]
            # the travel postures' actions follow the vias: action 1 + len(vias) + k goes to posture k
            self._postures = np.radians(np.array(via_postures_deg, dtype=float).reshape(-1, 6))
            for k, posture in enumerate(self._postures):
                check_within_limits(posture, self.placement.robot.joint_limits, f"via_postures_deg[{k}]")
            # the approach vias follow the postures: action 1 + len(vias) + len(postures) + k goes to the current
            # goal's approach configuration k
            self._approach_count, self._approach_reach = int(approach_vias), math.radians(approach_range_deg)
            self._first_approach = 1 + len(self._vias) + len(self._postures)
            self.n_actions = 2 + len(self._vias) + len(self._postures) + self._approach_count
            self.stay_action = self.n_actions - 1
            # the fallback anchors' vias, offered only where nothing else moves (see masks_at)
            self._fallback = np.array([False] + [anchor in fallback_anchors for anchor in via_anchors
                                                 for _ in range(12 * len(via_offsets_deg))]
                                      + [False] * (len(self._postures) + self._approach_count) + [False])
        else:
            self._vias = []
            self._postures = np.zeros((0, 6))
            self._approach_count, self._approach_reach, self._first_approach = 0, 0.0, 0
            self.n_actions = N_JOINT_ACTIONS + (2 if self.goal_action else 1)
            self.stay_action = STAY
            self._fallback = np.zeros(self.n_actions, dtype=bool)
        # the moves (every action but the wait), split once: masks_at runs on every step
        moves = np.array([a for a in range(self.n_actions) if a != self.stay_action])
        self._first_moves, self._fallback_moves = moves[~self._fallback[moves]], moves[self._fallback[moves]]
        self.action_space = gym.spaces.Discrete(self.n_actions)
        self._mask_cache: tuple[bytes, np.ndarray] | None = None
        self._approach_cache: dict[bytes, np.ndarray] = {}  # goal -> its approach configurations
        self._setup_episode(list(self.task.weld_goals))
        self._needs_reset = True  # Gymnasium's order: reset() before the first step()
        self._begin_damage(self.sim.segment_states()[self.robot_index])
        self._cost_now = _cost_row(self.task.cost(self.sim.measures()))

    # ----------------------------------------------------------------------------- task
    def _setup_episode(self, order: list[str], goal_index: int = 0) -> None:
        self.task.begin(order, goal_index)
        self.steps = 0
        self.cycle_time = 0.0
        self._mask_cache = None
        self._episode_path = [self.q]  # the configurations the episode moved through (its smoothness at the end)

    @property
    def weld_goals(self) -> dict[str, np.ndarray]:
        return self.task.weld_goals

    @property
    def goal(self) -> np.ndarray:
        return self.task.goal

    @property
    def goal_index(self) -> int:
        return self.task.goal_index

    @property
    def q(self) -> np.ndarray:
        return self.sim.q[self.robot_index].copy()

    # ----------------------------------------------------------------------------- gym API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if options is not None and not isinstance(options, dict):
            raise ConfigError("options", f"expected a dict with keys from {list(RESET_OPTIONS)} or None, "
                                         f"got {options!r}")
        options = options or {}
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ConfigError(f"options.{unknown[0]}", f"unknown reset option; allowed: {list(RESET_OPTIONS)}")
        super().reset(seed=seed)
        if "goals" in options:
            self._check_goals(options)
        order = self.task.sample_welds(self.np_random, options)
        if "start" in options:
            start = np.asarray(options["start"], dtype=float)
            if start.shape != (6,) or not self.validity.valid(start):
                raise ConfigError("options.start", "must be 6 joint angles [rad] of a valid configuration: "
                                                   f"{self.validity.why_invalid(start) if start.shape == (6,) else start.shape}")
        else:
            start = (random_start(self.placement.home, self.start_noise, self.np_random, self.validity.valid)
                     if self.start_noise > 0 else None)
        if start is None or np.allclose(start, self.placement.home):
            self.sim.set_state(self.home_state)
        else:
            q_all = self.station.home.copy()
            q_all[self.robot_index] = start
            self.sim.reset(q_all)
        self._setup_episode(order)
        self._needs_reset = False
        measures, states = self.sim.measures_and_states()
        self._begin_damage(states[self.robot_index])
        cost = self.task.cost(measures)
        self._cost_now = _cost_row(cost)  # where the first step's wear integral starts
        info = self._info(measures, cost, dict.fromkeys(REWARD_TERMS, 0.0), 0.0, False)
        return self._observation(measures), info

    def step(self, action):
        if self._needs_reset:
            raise EnvUsageError("step() before reset(): call reset() first" if self.steps == 0 else
                                "step() after the episode ended (terminated or truncated): call reset() first")
        a = self._check_action(action)
        masks = self.action_masks()
        q_before = self.q
        invalid = not masks[a]
        if invalid and self.invalid_action == "raise":
            raise InvalidActionError(f"action {a} ({self.describe_action(a)}) is masked at q = "
                                     f"{np.round(np.degrees(q_before), 2).tolist()} deg: {self._why_masked(a)}")
        t0 = self.sim.motion_time
        settle_before = self.sim.last_settle  # the step reports only a settle it made itself
        reached = False
        moved_through: list[np.ndarray] = []
        times, rows = [t0], [self._cost_now]  # motion times and cost terms along the step
        if invalid:
            pass  # the robot stays where it is
        elif a == self.stay_action:  # waiting costs the time of one joint step, while the cable swings/settles
            wait = self._stay_time
            self.sim.settle(wait)
            self.sim.motion_time += wait
        else:
            target = self._target(q_before, a)
            self._move(target, times, rows)
            moved_through.append(target)
            if self.task.near_goal(target) and self._segment_valid(target, self.goal):
                self._move(self.goal, times, rows)
                moved_through.append(self.goal.copy())
                reached = True
        if reached:
            self.sim.settle()
        elif not invalid and a != self.stay_action and self.settle_time > 0:
            self.sim.settle(self.settle_time)
        step_time = self.sim.motion_time - t0
        self.cycle_time += step_time
        measures, states = self.sim.measures_and_states()
        cost = self.task.cost(measures)
        times.append(self.sim.motion_time)
        rows.append(_cost_row(cost))
        self._cost_now = rows[-1]
        integral = _trapezoid(times, rows)
        reward, terms = self._get_rew(q_before, step_time, cost, float(integral[0]), reached, invalid)
        if reached:
            self.task.goal_index += 1
        self.steps += 1
        self._mask_cache = None
        terminated = self.task.terminated()
        truncated = not terminated and self.steps >= self.max_steps
        self._needs_reset = terminated or truncated
        self._add_damage(step_time, states[self.robot_index])
        info = self._info(measures, cost, terms, step_time, invalid)
        for k, v in zip(COST_TERMS, integral):  # sampled along the motion with wear_integral, else end points only
            info["integral_cost" if k == "total" else f"integral_cost_{k}"] = float(v)
        self._episode_path += moved_through
        if terminated or truncated:  # how smoothly the episode's path runs, measured as for every method
            if len(self._episode_path) > 1:
                info.update(smoothness(Trajectory(np.array(self._episode_path), ()), self._program_limits))  # the episode as one station cycle: its fatigue life (states at step ends)
            dp = self.placement.dresspack
            info["life_cycles"] = fatigue_life(self._episode_states, dp.fatigue,
                                               np.arange(dp.segments + 1) * dp.segment_length,
                                               dp.tensile_stiffness).summary()["life_cycles"]
        info["moved_through"] = np.array(moved_through).reshape(-1, 6)  # the straight segments' end points
        # The step's settle (at a weld: to equilibrium; after an ordinary step: bounded by settle_time) and the
        # residual it ended with; NaN when the step did not settle.
        settle = self.sim.last_settle if self.sim.last_settle is not settle_before else None
        info["settle_converged"] = bool(settle is not None and settle.converged)
        info["equilibrium_residual"] = settle.equilibrium.force_residual if settle is not None else float("nan")
        return self._observation(measures), reward, terminated, truncated, info

    def _get_rew(self, q_before: np.ndarray, step_time: float, cost, cost_integral: float, reached: bool,
                 invalid: bool) -> tuple[float, dict[str, float]]:
        """The reward and its named terms (the task's, see :class:`~dresspack_gym.env.weld_cycle.WeldCycleTask`)."""
        return self.task.reward(q_before, self.q, step_time, cost, cost_integral, reached, invalid)

    def action_masks(self) -> np.ndarray:
        """Boolean mask over the actions: True where the action is allowed (see module docstring)."""
        q = self.q
        key = q.tobytes() + bytes([self.goal_index])
        if self._mask_cache is not None and self._mask_cache[0] == key:
            return self._mask_cache[1].copy()
        masks = self.masks_at(q, self.goal)
        self._mask_cache = (key, masks)
        return masks.copy()

    def masks_at(self, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """The action mask at configuration ``q`` heading for ``goal`` (what ``action_masks`` returns there).
        The fallback anchors' vias are allowed only where every other move is masked: a policy then keeps to
        the other actions and uses these to get out of a spot nothing else leaves (e.g. the panel just welded)."""
        masks = np.ones(self.n_actions, dtype=bool)
        first, rest = self._first_moves, self._fallback_moves
        masks[first] = self._moves_free(q, goal, first)
        masks[rest] = False if masks[first].any() else self._moves_free(q, goal, rest)
        return masks

    def _moves_free(self, q: np.ndarray, goal: np.ndarray, moves: np.ndarray) -> np.ndarray:
        """Which of ``moves`` from ``q`` pass the limits, restrictions and the continuous collision check."""
        if not len(moves):
            return np.zeros(0, dtype=bool)
        targets = np.array([self._target(q, a, goal) for a in moves])
        free = np.array([self._segment_valid(q, target, check_collision=False) for target in targets])
        if self._approach_count:  # a goal with fewer approach configurations than slots: the rest are masked
            free &= moves < self._first_approach + len(self.approaches(goal))  # (the wait is not a move)
        # Moves whose largest possible robot displacement stays below the clearance beyond the margin cannot
        # come closer than the margin anywhere: they skip the collision queries (a continuous guarantee that
        # implies MotionValidity.segment_valid, so planners accept every step a masked policy takes).
        clearance = self.checker.min_distance(q) - self.checker.margin
        reach = self.checker.chain_reach()
        # the moves that pass limits and restrictions and could come near an obstacle: their collision checks
        # advance together, each round's distance queries in one batch
        near = np.flatnonzero(free & np.array([reach @ np.abs(t - q) >= clearance for t in targets]))
        if len(near):
            free[near] = self.validity.segments_clear(q, targets[near])
        return free

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            from ..stations.rendering import StationRenderer

            self._renderer = StationRenderer(self.station.model, width=self.render_size[0], height=self.render_size[1])
        return self._renderer.render(self.sim.data)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def _begin_damage(self, state: SegmentState) -> None:
        self._episode_states = [state]
        self._damage_rate = damage_rate(state, self.placement.dresspack)
        self._damage = np.zeros_like(self._damage_rate)

    def _add_damage(self, step_time: float, state: SegmentState) -> None:
        """Per segment, the damage of the step (value terms, trapezoid over its end states; see physics/damage.py)."""
        self._episode_states.append(state)
        rate = damage_rate(state, self.placement.dresspack)
        self._damage += 0.5 * (self._damage_rate + rate) * step_time
        self._damage_rate = rate

    # ----------------------------------------------------------------------------- snapshots and pickling
    def snapshot(self) -> EnvSnapshot:
        """The episode's state now (for search over action sequences: ``restore`` it and try another action)."""
        damage = (self._damage.copy(), self._damage_rate.copy(), list(self._episode_states))
        return EnvSnapshot(
            sim=self.sim.get_state(), last_settle=self.sim.last_settle, goal_names=tuple(self.task.goal_names[:-1]),
            episode_goals={k: v.copy() for k, v in self.task.episode_goals.items()}, goal_index=self.goal_index,
            steps=self.steps, cycle_time=self.cycle_time, needs_reset=self._needs_reset,
            episode_path=tuple(q.copy() for q in self._episode_path), cost_now=self._cost_now.copy(), damage=damage,
            rng=self._np_random.bit_generator.state if self._np_random is not None else None)

    def restore(self, snap: EnvSnapshot) -> None:
        """Return to a state from :meth:`snapshot` (of this env or one built with the same arguments)."""
        if not isinstance(snap, EnvSnapshot):
            raise ConfigError("snapshot", f"expected an EnvSnapshot from DresspackEnv.snapshot(), got {type(snap).__name__}")
        self.sim.set_state(snap.sim)
        self.sim.last_settle = snap.last_settle
        self.task.episode_goals = {k: v.copy() for k, v in snap.episode_goals.items()}
        self._setup_episode(list(snap.goal_names), snap.goal_index)
        self.steps, self.cycle_time, self._needs_reset = snap.steps, snap.cycle_time, snap.needs_reset
        self._episode_path = [q.copy() for q in snap.episode_path]
        self._cost_now = snap.cost_now.copy()
        damage, rate, states = snap.damage
        self._damage, self._damage_rate, self._episode_states = damage.copy(), rate.copy(), list(states)
        if snap.rng is not None:
            self._np_random = np.random.Generator(np.random.PCG64())
            self._np_random.bit_generator.state = snap.rng

    def __getstate__(self) -> dict[str, Any]:
        return {"kwargs": self._kwargs, "snapshot": self.snapshot()}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(**state["kwargs"])
        self.restore(state["snapshot"])

    def _check_goals(self, options: dict) -> None:
        goals = options["goals"]
        if "welds" in options:
            raise ConfigError("options.goals", "give either welds (names) or goals (configurations), not both")
        if not isinstance(goals, dict) or not goals:
            raise ConfigError("options.goals", f"expected a non-empty mapping of weld name -> 6 joint angles [rad], "
                                               f"got {goals!r}")
        for name, q in goals.items():
            q = np.asarray(q, dtype=float)
            if q.shape != (6,) or not self.validity.valid(q):
                why = self.validity.why_invalid(q) if q.shape == (6,) else f"shape {q.shape}"
                raise ConfigError(f"options.goals.{name}", f"must be 6 joint angles [rad] of a valid configuration: "
                                                           f"{why}")

    # ----------------------------------------------------------------------------- helpers
    def describe_action(self, a: int) -> str:
        if a == self.stay_action:
            return "stay"
        if self.action_set == "primitives":
            if a == TO_GOAL:
                return "straight to the goal"
            if a >= self._first_approach:
                return f"via approach configuration {a - self._first_approach} of the goal"
            if a > len(self._vias):
                return f"via travel posture {a - 1 - len(self._vias)}"
            fraction, j, offset = self._vias[a - 1]
            anchor = "the midpoint" if fraction else "here"
            return f"via {anchor} with j{j + 1} {math.degrees(offset):+g} deg"
        if a == TOWARD_GOAL:
            return f"toward goal (<= {math.degrees(self.step_size):g} deg)"
        return f"j{a // 2 + 1} {'+' if a % 2 == 0 else '-'}{math.degrees(self.step_size):g} deg"

    def _check_action(self, action) -> int:
        """An action of the action space: an integer (Python, numpy, or a one-element integer array) in range;
        bools and floats are refused, as ``Discrete.contains`` does."""
        value = action
        if isinstance(action, np.ndarray) and action.size == 1 and action.ndim <= 1:
            value = action.reshape(()).item() if np.issubdtype(action.dtype, np.integer) else action
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
                or not 0 <= value < self.n_actions:
            raise InvalidActionError(f"action must be an integer in [0, {self.n_actions - 1}], got {action!r}")
        return int(value)

    def _target(self, q: np.ndarray, a: int, goal: np.ndarray | None = None) -> np.ndarray:
        """Where action ``a`` moves from ``q`` (toward ``goal``, default the current goal)."""
        goal = self.goal if goal is None else goal
        target = q.copy()
        if a == self.stay_action:
            return target
        if self.action_set == "primitives":
            if a == TO_GOAL:
                return goal.copy()
            if a >= self._first_approach:  # an approach configuration of the goal (none: no move, and masked)
                found = self.approaches(goal)
                k = a - self._first_approach
                return found[k].copy() if k < len(found) else target
            if a > len(self._vias):  # a travel posture: where it is, wherever the robot and the goal are
                return self._postures[a - 1 - len(self._vias)].copy()
            fraction, j, offset = self._vias[a - 1]
            target = q + fraction * (goal - q)
            target[j] += offset
            return target
        if a == TOWARD_GOAL:
            err = goal - q
            return q + err * min(1.0, self.step_size / max(float(np.max(np.abs(err))), 1e-12))
        if a != STAY:
            target[a // 2] += self.step_size if a % 2 == 0 else -self.step_size
        return target

    def approaches(self, goal: np.ndarray | None = None) -> np.ndarray:
        """The approach configurations of ``goal`` (default the current goal), (k, 6) with k <= approach_vias."""
        goal = self.goal if goal is None else np.asarray(goal, dtype=float)
        key = goal.tobytes()
        found = self._approach_cache.pop(key, None)  # reinserted below: the least recently used goes first
        if found is None:
            if len(self._approach_cache) >= APPROACH_CACHE:  # goals change every episode (Home stays)
                self._approach_cache.pop(next(iter(self._approach_cache)))
            found = approach_configurations(self.validity, goal, self._approach_count, self._approach_reach)
        self._approach_cache[key] = found
        return found

    def _segment_configs(self, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
        n = max(self.substeps, int(math.ceil(np.max(np.abs(q1 - q0)) / (self.step_size / self.substeps))))
        s = np.linspace(0.0, 1.0, n + 1)[1:, None]
        return q0[None, :] + s * (q1 - q0)[None, :]

    def _segment_valid(self, q0: np.ndarray, q1: np.ndarray, check_collision: bool = True) -> bool:
        qs = self._segment_configs(q0, q1)
        if not (self.validity.within_limits(qs).all() and self.restrictions.allowed(qs).all()):
            return False
        return not check_collision or self.validity.segment_clear(q0, q1)

    def _why_masked(self, a: int) -> str:
        if self._fallback[a] and self.masks_at(self.q, self.goal)[self._first_moves].any():  # another move is free
            return "a fallback via: offered only where no other move is free"
        if self._approach_count and a >= self._first_approach and a != self.stay_action \
                and a - self._first_approach >= len(self.approaches()):
            return f"the goal has {len(self.approaches())} approach configuration(s) within approach_range_deg"
        qs = self._segment_configs(self.q, self._target(self.q, a))
        if not self.validity.within_limits(qs).all():
            return "joint limit"
        bad = ~self.restrictions.allowed(qs)
        if bad.any():
            return "joint restriction: " + "; ".join(self.restrictions.violated_by(qs[np.argmax(bad)]))
        return "robot-obstacle collision"

    def _step_time(self) -> float:
        """Seconds of one joint step of the fastest joint under the simulator's time law."""
        limits = self.sim.motion_limits()
        dq = np.zeros(limits.velocity.shape)
        dq[self.robot_index, int(np.argmax(limits.velocity[self.robot_index]))] = self.step_size
        return float(segment_durations(dq, limits))

    def _move(self, target: np.ndarray, times: list[float], rows: list[np.ndarray]) -> None:
        """Move there (not settling); with wear_integral the cost terms sampled on the way join times/rows."""
        q_all = self.sim.q.copy()
        q_all[self.robot_index] = target
        every = WEAR_SAMPLE_TIME if self.task.wear_integral else None
        trace = self.sim.move_to(q_all, settle=False, record_every=every)
        times += trace.time
        rows += [_cost_row(self.task.cost(m)) for m in trace.measures]

    def _observation(self, measures) -> np.ndarray:
        """The parts of ``observation_structure``, in its order, each roughly in [-1, 1]."""
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        scale = lambda v: 2.0 * (v - lo) / (hi - lo) - 1.0  # noqa: E731
        q = self.q
        pts = self.sim.cable_points(self.robot_index)
        idx = np.linspace(0, len(pts) - 1, self.cable_samples).round().astype(int)
        tcp = self.robot.kinematics.tcp_pose(q)
        cfg = self.station.config.wear_cost
        parts = {
            "joints": scale(q),
            "goal": scale(self.goal),
            "goal_error": (q - self.goal) / np.pi,
            "progress": [self.task.progress],
            "cable_points": ((pts[idx] - tcp[:3, 3]) @ tcp[:3, :3] / self.placement.dresspack.length).ravel(),
            "measures": [measures.max_curvature / max(cfg.curvature_threshold, 1e-6),
                         measures.max_tension / cfg.tension_scale,
                         min(measures.min_clearance / max(cfg.clearance, 1e-6), CLEARANCE_OBS_CAP)],
        }
        if "goal_pose" in self.observation_structure:
            goal_tcp = self.robot.kinematics.tcp_pose(self.goal)
            base = np.asarray(self.placement.base_pos)
            parts["goal_pose"] = np.concatenate([(goal_tcp[:3, 3] - base) / POSE_SCALE, goal_tcp[:3, 2]])
        if "approaches" in self.observation_structure:
            rows = np.zeros((self._approach_count, 6))
            found = self.approaches(self.goal)
            rows[:len(found)] = (found - q) / np.pi
            parts["approaches"] = rows.ravel()
        if "action_masks" in self.observation_structure:
            parts["action_masks"] = np.where(self.action_masks(), 1.0, -1.0)
        obs = np.concatenate([parts[k] for k in self.observation_structure])
        return np.clip(obs, -OBS_BOUND, OBS_BOUND).astype(np.float32)

    def _info(self, measures, cost, terms: dict, step_time: float, invalid: bool) -> dict[str, Any]:
        info = {
            "q": self.q,
            "goal": self.goal.copy(),
            "goal_name": self.task.goal_name,
            "max_curvature": measures.max_curvature,
            "max_tension": measures.max_tension,
            "min_clearance": measures.min_clearance,
            "max_twist_rate": measures.max_twist_rate,
            "total_twist": measures.total_twist,
            "max_compression": measures.max_compression,
            "max_node_force": measures.max_node_force,
            "max_node_torque": measures.max_node_torque,
            "cost": cost.total,
            "cost_curvature": cost.curvature,
            "cost_tension": cost.tension,
            "cost_distance": cost.distance,
            "cost_twist": cost.twist,
            "cost_damage": cost.damage,
            "damage_rate": measures.max_damage_rate,
            "damage": float(self._damage.max()),
            "step_time": step_time,
            "cycle_time": self.cycle_time,
            "goals_reached": self.goal_index,
            "n_goals": self.task.n_goals,
            "progress": self.task.progress,
            "is_success": self.task.terminated(),
            "invalid_action": invalid,
        }
        for k in REWARD_TERMS:
            info[f"reward_{k}"] = float(terms[k])
        return info

