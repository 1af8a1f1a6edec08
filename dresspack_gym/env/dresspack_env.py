"""Gymnasium environment: a robot carrying a simulated dresspack through a weld cycle, with masked actions.

The env composes one owner per concern, as dm_control splits physics, task and environment:

- settings: :class:`~dresspack_gym.env.config.EnvConfig` (frozen, validated in one place; the env's keyword
  arguments are its fields);
- physics: the station's cable simulator on the physics profile's engine (``physics.profiles.make_simulator``:
  MuJoCo's :class:`~dresspack_gym.physics.simulation.CableSimulator` for the accurate profile, the rod engine's
  :class:`~dresspack_gym.rod.simulator.RodSimulator` for the training profile);
- task: :class:`~dresspack_gym.env.weld_cycle.WeldCycleTask` (goals, reward terms, termination);
- actions: an :class:`~dresspack_gym.env.action_sets.ActionSet` (``action_set``: joint steps, or planner-like
  primitives), masked by :class:`~dresspack_gym.env.masks.ActionMasks`;
- observation: :class:`~dresspack_gym.env.observation.Observation` (its layout is ``observation_structure``);
- wear bookkeeping: :class:`~dresspack_gym.env.episode_wear.EpisodeWear` (wear integral, damage, fatigue life);
- input checks: :mod:`~dresspack_gym.env.inputs` (actions, reset options, configurations, before anything changes).

Episode: starting at Home, visit the task's weld configurations in order, then return Home. Each weld configuration
is the restriction-passing, collision-free IK branch closest to Home (max joint change). A step moves straight to
its action's target (simulated and timed by the time law); when every joint is then within half a step of the
current goal the robot finishes the move onto the goal exactly (simulated and timed too) and the goal is reached;
the cable then settles (the robot dwells while welding, as in trajectory replay). ``settle_time`` bounds the cable
settling after each ordinary step (0: the cable keeps its motion into the next step, as in a continuous
trajectory). The episode terminates when Home is reached after the last weld and is truncated after ``max_steps``.

Tasks: ``welds`` (all of them, in order), or each episode ``n_welds`` of them (optionally shuffled), or one of the
weld lists in ``tasks``, or ``part_welds`` weld points drawn on the station's parts (:mod:`weld_sampling`);
``reset(options={"welds": [...], "start": q})`` sets both explicitly (or ``"goals"``: weld name -> configuration).
With ``sim_timestep`` the env compiles its own station from the config with that physics step (e.g. 4 ms to train
faster; everything derived from the step follows it; evaluation replays the resulting trajectory at the station's
own step). With ``start_noise_deg`` the episode starts at a random valid configuration within that many degrees of
Home (drawn from ``np_random``, the cable settled there); it always ends at Home.

Taking a masked action anyway: with ``invalid_action="penalize"`` (default, so generic checkers can sample actions)
the robot stays where it is, the step costs ``invalid_penalty`` and ``info["invalid_action"]`` is True; with
``invalid_action="raise"`` an :class:`InvalidActionError` is raised. The robot never enters a forbidden
configuration either way.

Reward per step: the task's (``_get_rew`` returns the reward and its named terms, all in ``info`` as
``reward_<term>``)::

    reward = reward_time + reward_wear + reward_progress + reward_goal + reward_invalid

``reward_progress`` is potential-based shaping (it does not change which policies are optimal); ``reward_goal``
makes completion learnable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import ConfigError, EnvUsageError
from ..fields import check_choice
from ..io.loading import load_station
from ..physics.profiles import PROFILES, make_simulator, with_profile
from ..physics.trajectory import Trajectory, smoothness
from ..robots.time_law import segment_durations
from ..stations.collision import RobotCollisionChecker
from ..stations.station import Station
from ..stations.tasks import random_start
from ..stations.validity import MotionValidity
from .action_sets import ACTION_SET_CLASSES
from .action_sets.joint_steps import STAY, TOWARD_GOAL
from .action_sets.primitives import TO_GOAL
from .config import EnvConfig
from .episode_wear import COST_TERMS, EpisodeWear, cost_row
from .inputs import InvalidActionError, checked_action, checked_reset_options
from .masks import ActionMasks
from .observation import Observation
from .weld_cycle import REWARD_TERMS, WeldCycleTask

__all__ = ["STAY", "TOWARD_GOAL", "TO_GOAL", "DresspackEnv", "EnvSnapshot", "InvalidActionError"]

# [s] with wear_integral the cost is sampled this often along a motion and integrated (trapezoid): a primitive
# segment lasts seconds, its end state alone would miss what the cable went through on the way
WEAR_SAMPLE_TIME = 0.05


@dataclass(frozen=True)
class EnvSnapshot:
    """Everything an episode's continuation depends on, from :meth:`DresspackEnv.snapshot`: restored into the same
    env (or a pickled copy), the next steps give the same observations, rewards and infos as without the detour."""

    sim: np.ndarray  # the simulator's get_state(): the cables' state (MuJoCo's or the rod's), joints, motion time
    last_settle: Any  # the simulator's last settle, so a restored step reports only a settle it made itself
    goal_names: tuple[str, ...]  # the episode's welds in order (Home follows)
    episode_goals: dict  # drawn or given weld configurations of this episode
    goal_index: int
    steps: int
    cycle_time: float
    needs_reset: bool
    episode_path: tuple[np.ndarray, ...]
    wear: tuple  # EpisodeWear.state(): cost terms now, per-segment damage and its rate, the segment states
    rng: dict | None  # the env's random generator state
    masks: tuple | None = None  # ActionMasks.kept(): the mask where the robot stands, if computed


def _build_station(station: str | Station, config: EnvConfig) -> tuple[Station, Station | None]:
    """The station the env simulates, and the one whose geometry its checks use when that differs (None: the same).
    A changed timestep, or a physics profile that changes the cable's segments or step, compiles a station from the
    changed config: everything derived from the timestep (the cable's constraint impedances) follows it, and a
    caller's Station keeps its own."""
    geometry = station if isinstance(station, Station) else None
    profile = PROFILES[config.physics_profile]
    changes_station = profile.segments is not None or profile.timestep is not None
    if config.sim_timestep is None and not changes_station:
        return (station if isinstance(station, Station) else Station(load_station(station))), geometry
    base = station.config if isinstance(station, Station) else load_station(station)
    if changes_station and geometry is None:
        geometry = Station(base)
    changed = with_profile(base, config.physics_profile)
    if config.sim_timestep is not None:
        changed = replace(changed, simulation=replace(changed.simulation, timestep=float(config.sim_timestep)))
    return Station(changed), geometry


class DresspackEnv(gym.Env):
    """Visit weld configurations and return Home; reward = -(time + wear cost) + completion terms.

    ``DresspackEnv(station, config=EnvConfig(...))`` or ``DresspackEnv(station, **settings)`` (the settings are
    :class:`EnvConfig`'s fields; given both, the settings replace the config's)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, station: str | Station = "default", config: EnvConfig | None = None,
                 render_mode: str | None = None, **settings):
        if not isinstance(station, (str, Station)):
            raise ConfigError("station", f"expected a station name, YAML path or Station, got {station!r}")
        if config is not None and not isinstance(config, EnvConfig):
            raise ConfigError("config", f"expected an EnvConfig, got {type(config).__name__}")
        config = EnvConfig.from_dict({**(config.as_dict() if config is not None else {}), **settings})
        check_choice("render_mode", render_mode, (None, "rgb_array"))
        self.config = config
        self._kwargs = {"station": station, **config.as_dict(), "render_mode": render_mode}  # rebuilds it (pickling)
        self.station, geometry = _build_station(station, config)
        robot = config.robot
        if not 0 <= robot < self.station.n_robots:
            raise ConfigError("robot", f"robot index {robot} out of range for {self.station.n_robots} robot(s)")
        self.robot_index = robot
        self.robot = self.station.robots[robot]
        self.placement = self.station.config.robots[robot]
        self.sim = make_simulator(self.station, PROFILES[config.physics_profile].engine)
        self.home_state = self.sim.get_state()
        # Collision geometry is the given station's whatever the physics profile: what a motion may do must not
        # depend on how finely its cable is simulated (a coarser profile's longer rigid clamp edges, robot hardware
        # in the checks, would otherwise reject goals and moves the planners accept).
        self.validity = MotionValidity(geometry or self.station, robot, config.collision_margin,
                                       config.mask_resolution_deg)
        self.checker: RobotCollisionChecker = self.validity.checker
        self.restrictions = self.placement.restrictions
        self.limits = self.placement.robot.joint_limits
        self.step_size = math.radians(config.joint_step_deg)
        self.max_steps = int(config.max_steps)
        self.invalid_action = config.invalid_action
        self.settle_time = float(config.settle_time)
        self.start_noise = math.radians(config.start_noise_deg)
        # the limits a replayed program runs at (the robot's, at the station's speed fraction), as in the evaluation
        self._program_limits = self.placement.robot.joint_motion_limits.at_speed(
            self.station.config.simulation.speed_fraction)
        self._stay_time = self._step_time()  # the limits never change: timed once, not on every "stay"
        self.render_mode = render_mode
        self.render_size = config.render_size
        self._renderer = None
        self._frame_data = None  # MuJoCo data the rod engine's frames are posed on (made at the first frame)
        self.task = WeldCycleTask.from_config(self.station, self.checker.collides, self.step_size, config)
        self.actions = ACTION_SET_CLASSES[config.action_set].from_config(config, self.validity, self.limits)
        self.n_actions, self.stay_action = self.actions.n_actions, self.actions.stay_action
        self.action_space = gym.spaces.Discrete(self.n_actions)
        substeps = max(1, int(math.ceil(config.joint_step_deg / config.mask_resolution_deg)))
        self.masks = ActionMasks(self.actions, self.validity, self.restrictions, self.step_size, substeps)
        self.observation = Observation(self.sim, robot, self.actions, config.cable_samples,
                                       goal_pose=bool(config.part_welds))
        self.observation_structure = self.observation.structure
        self.observation_space = self.observation.space
        self.wear = EpisodeWear(self.placement.dresspack)
        self._setup_episode(list(self.task.weld_goals))
        self._needs_reset = True  # Gymnasium's order: reset() before the first step()
        self._closed = False
        self.wear.begin(self.sim.segment_states()[robot], self.task.cost(self.sim.measures()))

    # ----------------------------------------------------------------------------- task
    def _setup_episode(self, order: list[str], goal_index: int = 0) -> None:
        self.task.begin(order, goal_index)
        self.steps = 0
        self.cycle_time = 0.0
        self.masks.forget()
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
        options = checked_reset_options(options, self.validity)
        super().reset(seed=seed)
        order = self.task.sample_welds(self.np_random, options)
        if "start" in options:
            start = options["start"]
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
        self._needs_reset = self._closed = False
        measures, states = self.sim.measures_and_states()
        cost = self.task.cost(measures)
        self.wear.begin(states[self.robot_index], cost)  # where the first step's wear integral starts
        info = self._info(measures, cost, dict.fromkeys(REWARD_TERMS, 0.0), 0.0, False)
        return self._get_obs(measures), info

    def step(self, action):
        measures, reward, terminated, truncated, info = self._step(action, summary=True)
        return self._get_obs(measures), reward, terminated, truncated, info

    def step_outcome(self, action) -> tuple[float, bool, bool, dict[str, Any]]:
        """``step(action)`` without the observation where it lands and the episode's summary (smoothness, fatigue
        life): (reward, terminated, truncated, info). For a search that tries actions from a :meth:`snapshot` and
        restores it: the observation's action masks there (primitives) cost collision checks that nothing reads.
        The env continues as after ``step``."""
        return self._step(action, summary=False)[1:]

    def _step(self, action, summary: bool):
        self._check_in_episode("step()")
        a = checked_action(action, self.n_actions)
        q_before = self.q
        invalid = not self.action_masks()[a]
        if invalid and self.invalid_action == "raise":
            raise InvalidActionError(f"action {a} ({self.describe_action(a)}) is masked at q = "
                                     f"{np.round(np.degrees(q_before), 2).tolist()} deg: {self.why_masked(a)}")
        t0 = self.sim.motion_time
        settle_before = self.sim.last_settle  # the step reports only a settle it made itself
        times, rows = [t0], [self.wear.cost_now]  # motion times and cost terms along the step
        moved_through, reached = self._act(a, invalid, q_before, times, rows)
        step_time = self.sim.motion_time - t0
        self.cycle_time += step_time
        measures, states = self.sim.measures_and_states()
        cost = self.task.cost(measures)
        times.append(self.sim.motion_time)
        integral = self.wear.end_step(step_time, states[self.robot_index], times, rows, cost)
        reward, terms = self._get_rew(q_before, step_time, cost, float(integral[0]), reached, invalid)
        if reached:
            self.task.goal_index += 1
        self.steps += 1
        self.masks.forget()
        terminated = self.task.terminated()
        truncated = not terminated and self.steps >= self.max_steps
        self._needs_reset = terminated or truncated
        self._episode_path += moved_through
        info = self._info(measures, cost, terms, step_time, invalid)
        for k, v in zip(COST_TERMS, integral):  # sampled along the motion with wear_integral, else end points only
            info["integral_cost" if k == "total" else f"integral_cost_{k}"] = float(v)
        if summary and (terminated or truncated):
            info.update(self._episode_summary())
        info["moved_through"] = np.array(moved_through).reshape(-1, 6)  # the straight segments' end points
        # The step's settle (at a weld: to equilibrium; after an ordinary step: bounded by settle_time) and the
        # residual it ended with; NaN when the step did not settle.
        settle = self.sim.last_settle if self.sim.last_settle is not settle_before else None
        info["settle_converged"] = bool(settle is not None and settle.converged)
        info["equilibrium_residual"] = settle.equilibrium.force_residual if settle is not None else float("nan")
        return measures, reward, terminated, truncated, info

    def _act(self, a: int, invalid: bool, q: np.ndarray, times: list[float], rows: list[np.ndarray]):
        """Carry out action ``a`` from ``q`` in the simulation: the configurations moved through, and whether the
        goal was reached. A masked action leaves the robot where it is; the wait lasts one joint step's time while
        the cable swings/settles; a move goes to its target, then onto the goal when that is within half a step."""
        moved_through: list[np.ndarray] = []
        reached = False
        if invalid:
            return moved_through, reached
        if a == self.stay_action:
            self._settle(self._stay_time)
            self.sim.motion_time += self._stay_time
            return moved_through, reached
        target = self.target(q, a)
        self._move(target, times, rows)
        moved_through.append(target)
        if self.task.near_goal(target) and self.masks.segment_valid(target, self.goal):
            self._move(self.goal, times, rows)
            moved_through.append(self.goal.copy())
            reached = True
        if reached:
            self.sim.settle()
        elif self.settle_time > 0:
            self._settle(self.settle_time)
        return moved_through, reached

    def _settle(self, max_time: float) -> None:
        """Let the cable come to rest with the robot still: MuJoCo relaxes for at most ``max_time``; the rod engine,
        quasi-static, solves for its rest (as the robustness maps settle it)."""
        if self.sim.engine == "fast":
            self.sim.settle()
        else:
            self.sim.settle(max_time)

    def _move(self, target: np.ndarray, times: list[float], rows: list[np.ndarray]) -> None:
        """Move there (not settling); with wear_integral the cost terms sampled on the way join times/rows."""
        q_all = self.sim.q.copy()
        q_all[self.robot_index] = target
        every = WEAR_SAMPLE_TIME if self.task.wear_integral else None
        trace = self.sim.move_to(q_all, settle=False, record_every=every)
        times += trace.time
        rows += [cost_row(self.task.cost(m)) for m in trace.measures]

    def _get_rew(self, q_before: np.ndarray, step_time: float, cost, cost_integral: float, reached: bool,
                 invalid: bool) -> tuple[float, dict[str, float]]:
        """The reward and its named terms (the task's, see :class:`~dresspack_gym.env.weld_cycle.WeldCycleTask`)."""
        return self.task.reward(q_before, self.q, step_time, cost, cost_integral, reached, invalid)

    def _get_obs(self, measures) -> np.ndarray:
        return self.observation.build(self.goal, self.task.progress, measures, self.action_masks)

    def _episode_summary(self) -> dict[str, Any]:
        """At the episode's end: how smoothly its path runs (measured as for every method) and its fatigue life as
        one station cycle (states at step ends)."""
        out: dict[str, Any] = {}
        if len(self._episode_path) > 1:
            out.update(smoothness(Trajectory(np.array(self._episode_path), ()), self._program_limits))
        out["life_cycles"] = self.wear.life_cycles()
        return out

    def action_masks(self) -> np.ndarray:
        """Boolean mask over the actions: True where the action is allowed (see :class:`ActionMasks`)."""
        if self._closed or (self._needs_reset and self.steps == 0):
            self._check_in_episode("action_masks()")
        return self.masks.current(self.q, self.goal, self.goal_index)

    def masks_at(self, q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """The action mask at configuration ``q`` heading for ``goal`` (what ``action_masks`` returns there)."""
        return self.masks.masks_at(q, goal)

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        from ..stations.rendering import StationRenderer, live_frame

        if self._renderer is None:
            self._renderer = StationRenderer(self.station.model, width=self.render_size[0], height=self.render_size[1])
        # the rod engine's robots are posed on a MuJoCo data of the env's own, its cables drawn from their points
        data, cables = live_frame(self.sim, self._frame_data)
        if cables is not None:
            self._frame_data = data
        return self._renderer.render(data, cables=cables)

    def close(self):
        """Release the renderer and end the episode: ``step()`` and ``action_masks()`` need a ``reset()`` again."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self._closed = True

    # ----------------------------------------------------------------------------- snapshots and pickling
    def snapshot(self) -> EnvSnapshot:
        """The episode's state now (for search over action sequences: ``restore`` it and try another action)."""
        return EnvSnapshot(
            sim=self.sim.get_state(), last_settle=self.sim.last_settle, goal_names=tuple(self.task.goal_names[:-1]),
            episode_goals={k: v.copy() for k, v in self.task.episode_goals.items()}, goal_index=self.goal_index,
            steps=self.steps, cycle_time=self.cycle_time, needs_reset=self._needs_reset,
            episode_path=tuple(q.copy() for q in self._episode_path), wear=self.wear.state(),
            rng=self._np_random.bit_generator.state if self._np_random is not None else None,
            masks=self.masks.kept())

    def restore(self, snap: EnvSnapshot) -> None:
        """Return to a state from :meth:`snapshot` (of this env or one built with the same arguments)."""
        if not isinstance(snap, EnvSnapshot):
            raise ConfigError("snapshot", f"expected an EnvSnapshot from DresspackEnv.snapshot(), "
                                          f"got {type(snap).__name__}")
        self.sim.set_state(snap.sim)
        self.sim.last_settle = snap.last_settle
        self.task.episode_goals = {k: v.copy() for k, v in snap.episode_goals.items()}
        self._setup_episode(list(snap.goal_names), snap.goal_index)
        self.masks.keep(snap.masks)
        self.steps, self.cycle_time, self._needs_reset = snap.steps, snap.cycle_time, snap.needs_reset
        self._closed = False
        self._episode_path = [q.copy() for q in snap.episode_path]
        self.wear.set_state(snap.wear)
        if snap.rng is not None:
            self._np_random = np.random.Generator(np.random.PCG64())
            self._np_random.bit_generator.state = snap.rng

    def __getstate__(self) -> dict[str, Any]:
        return {"kwargs": self._kwargs, "snapshot": self.snapshot()}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(**state["kwargs"])
        self.restore(state["snapshot"])

    # ----------------------------------------------------------------------------- actions
    def describe_action(self, a: int) -> str:
        return self.actions.describe(a)

    def target(self, q: np.ndarray, a: int, goal: np.ndarray | None = None) -> np.ndarray:
        """Where action ``a`` moves from ``q`` (toward ``goal``, default the current goal)."""
        return self.actions.target(q, a, self.goal if goal is None else goal)

    def approaches(self, goal: np.ndarray | None = None) -> np.ndarray:
        """The approach configurations the action set offers toward ``goal`` (default the current goal), (k, 6)."""
        return self.actions.approaches(self.goal if goal is None else np.asarray(goal, dtype=float))

    def segment_valid(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        """The straight segment q0 -> q1 passes the limits, restrictions and the continuous collision check."""
        return self.masks.segment_valid(q0, q1)

    def why_masked(self, a: int) -> str:
        """Why action ``a`` is masked where the robot stands."""
        return self.masks.why_masked(self.q, self.goal, a)

    # ----------------------------------------------------------------------------- checks
    def _check_in_episode(self, call: str) -> None:
        """``call`` needs a running episode: not before the first reset(), after close() or after the episode."""
        if self._closed:
            raise EnvUsageError(f"{call} after close(): call reset() first")
        if self._needs_reset:
            raise EnvUsageError(f"{call} before reset(): call reset() first" if self.steps == 0 else
                                f"{call} after the episode ended (terminated or truncated): call reset() first")

    def _step_time(self) -> float:
        """Seconds of one joint step of the fastest joint under the simulator's time law."""
        limits = self.sim.motion_limits()
        dq = np.zeros(limits.velocity.shape)
        dq[self.robot_index, int(np.argmax(limits.velocity[self.robot_index]))] = self.step_size
        return float(segment_durations(dq, limits))

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
            "damage": self.wear.max_damage,
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
