"""The env's weld-cycle task: which welds an episode visits, its goals, reward terms and termination.

The physics (the station's cable simulator, on either engine) answers physical questions; this task turns
its answers into goals and rewards; :class:`~dresspack_gym.env.dresspack_env.DresspackEnv` adapts both to Gymnasium.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError
from ..physics.wear_cost import cost_function
from ..stations.station import Station
from ..stations.tasks import closest_branch, select_weld_goals
from ..stations.weld_sampling import SampledWeld, WeldSampler, WeldSampling

if TYPE_CHECKING:
    from .config import EnvConfig

# The reward's named terms, in the order they are reported (``info["reward_<term>"]``); their sum is the reward.
REWARD_TERMS = ("time", "wear", "progress", "goal", "invalid")


class WeldCycleTask:
    """Start somewhere near Home, visit weld configurations in order, return Home.

    Reward per step (every term in ``info``; their sum is the reward)::

        time     = -time_weight * step_time
        wear     = -wear_weight * C(gamma)              (with wear_integral: -wear_weight * the integral of C over
                                                        the step, sampled along the motion; the return sums it)
        progress = progress_weight * (phi(q_before) - phi(q_after)),  phi(q) = max_j |q_j - goal_j| / step_size
        goal     = goal_reward when a weld (or the final Home) is reached
        invalid  = -invalid_penalty for a masked action

    With ``wear_reward_cap`` the wear term of a step is at most that large: the cost grows with the square of the
    tension, and one step dragging the cable at kilonewtons would otherwise swamp every other reward a learner
    sees (the evaluation always reports the uncapped integral).
    """

    def __init__(self, station: Station, robot: int, collides, step_size: float, *, welds=None, n_welds=None,
                 shuffle_welds: bool = False, tasks=None, time_weight: float = 1.0, wear_weight: float = 1.0,
                 goal_reward: float = 10.0, progress_weight: float = 1.0, invalid_penalty: float = 1.0,
                 wear_integral: bool = False, cost_variant: str = "thesis", part_welds: int = 0,
                 weld_sampling: WeldSampling | None = None, wear_reward_cap: float | None = None):
        self.home = station.config.robots[robot].home
        self.wear_config = station.config.wear_cost
        self.cost_fn = cost_function(cost_variant)
        self.step_size = float(step_size)
        self.weights = dict(time=time_weight, wear=wear_weight, progress=progress_weight, goal=goal_reward,
                            invalid=invalid_penalty)
        self.wear_integral = bool(wear_integral)
        self.wear_reward_cap = None if wear_reward_cap is None else float(wear_reward_cap)
        # part_welds > 0: every episode draws that many new weld points on the station's parts (goal-conditioned)
        self.part_welds = int(part_welds)
        self.sampler = WeldSampler(station, robot, collides, weld_sampling or WeldSampling()) \
            if self.part_welds else None
        if self.part_welds and (n_welds is not None or tasks is not None or shuffle_welds):
            raise ConfigError("part_welds", "draws each episode's welds on the parts: leave n_welds, tasks and "
                                            "shuffle_welds out")
        self.sampled: dict[str, SampledWeld] = {}  # this episode's drawn welds
        self.episode_goals: dict[str, np.ndarray] = {}
        named = [w for w in station.config.weld_points if w.robot == station.config.robots[robot].name]
        self.weld_goals = select_weld_goals(station, robot, collides, welds) \
            if named or not self.part_welds else {}
        if n_welds is not None and not 1 <= n_welds <= len(self.weld_goals):
            raise ConfigError("n_welds", f"must be in [1, {len(self.weld_goals)}], got {n_welds}")
        self.n_welds = n_welds
        self.shuffle_welds = bool(shuffle_welds)
        self.tasks = self._check_tasks(tasks)
        self.begin(list(self.weld_goals))

    @classmethod
    def from_config(cls, station: Station, collides, step_size: float, config: EnvConfig) -> WeldCycleTask:
        """The task an env's settings describe (``collides(q)``: the robot-station collision query)."""
        c = config
        return cls(station, c.robot, collides, step_size, welds=c.welds, n_welds=c.n_welds,
                   shuffle_welds=c.shuffle_welds, tasks=c.tasks, time_weight=c.time_weight, wear_weight=c.wear_weight,
                   goal_reward=c.goal_reward, progress_weight=c.progress_weight, invalid_penalty=c.invalid_penalty,
                   wear_integral=c.wear_integral, cost_variant=c.cost_variant, part_welds=c.part_welds,
                   weld_sampling=WeldSampling(tilt_max=math.radians(c.weld_tilt_deg)),
                   wear_reward_cap=c.wear_reward_cap)

    def _check_tasks(self, tasks) -> list[list[str]] | None:
        if tasks is None:
            return None
        if not isinstance(tasks, (list, tuple)) or not tasks or not all(isinstance(t, (list, tuple)) and t
                                                                       for t in tasks):
            raise ConfigError("tasks", f"must be a non-empty list of non-empty weld-name lists, got {tasks!r}")
        for t in tasks:
            self._check_welds(t, "tasks")
        return [list(t) for t in tasks]

    def _check_welds(self, welds, field: str) -> None:
        unknown = [w for w in welds if w not in self.weld_goals]
        if unknown:
            raise ConfigError(field, f"unknown weld(s) {unknown}; choose from {list(self.weld_goals)}")

    # ------------------------------------------------------------------------------ episode
    def sample_welds(self, rng: np.random.Generator, options: dict) -> list[str]:
        """This episode's welds: ``options["welds"]`` (names), else ``options["goals"]`` (name -> configuration,
        in order), else ``part_welds`` drawn on the parts, else one of ``tasks``, else all (a random ``n_welds``
        subset, optionally shuffled), drawn from ``rng``."""
        order = list(self.weld_goals)
        self.sampled, self.episode_goals = {}, {}
        if "welds" in options:
            order = list(options["welds"])
            self._check_welds(order, "options.welds")
        elif "goals" in options:  # explicit goal configurations (any weld, e.g. one drawn for an evaluation)
            self.episode_goals = {str(k): np.asarray(v, dtype=float).copy() for k, v in options["goals"].items()}
            order = list(self.episode_goals)
        elif self.sampler is not None:
            for k in range(self.part_welds):
                drawn = self.sampler.sample(rng, f"part_{k}")
                self.sampled[drawn.weld.name] = drawn
                self.episode_goals[drawn.weld.name] = closest_branch(drawn.configurations, self.home)
            order = list(self.sampled)
        elif self.tasks is not None:
            order = list(self.tasks[rng.integers(len(self.tasks))])
        else:
            if self.n_welds is not None:
                order = list(rng.choice(order, size=self.n_welds, replace=False))
            if self.shuffle_welds:
                order = list(rng.permutation(order))
        return [str(w) for w in order]

    def begin(self, order: list[str], goal_index: int = 0) -> None:
        self.goal_names = list(order) + ["home"]
        goals = {**self.weld_goals, **self.episode_goals}
        self.goals = [goals[n] for n in order] + [self.home.copy()]
        self.goal_index = goal_index

    @property
    def goal(self) -> np.ndarray:
        return self.goals[min(self.goal_index, len(self.goals) - 1)]

    @property
    def goal_name(self) -> str:
        return self.goal_names[min(self.goal_index, len(self.goal_names) - 1)]

    @property
    def n_goals(self) -> int:
        return len(self.goals)

    @property
    def progress(self) -> float:
        return self.goal_index / len(self.goals)

    def terminated(self) -> bool:
        """The episode ends when Home is reached after the last weld."""
        return self.goal_index >= len(self.goals)

    def near_goal(self, q: np.ndarray) -> bool:
        """Within half a step of the goal in every joint: the robot finishes the move onto it."""
        return bool(np.max(np.abs(q - self.goal)) <= 0.5 * self.step_size + 1e-9)

    def potential(self, q: np.ndarray) -> float:
        return float(np.max(np.abs(q - self.goal)) / self.step_size)

    # ------------------------------------------------------------------------------ reward
    def cost(self, measures):
        """The wear cost C(gamma) of the chosen variant, with its terms."""
        return self.cost_fn(measures, self.wear_config)

    def reward(self, q_before: np.ndarray, q_after: np.ndarray, step_time: float, cost, cost_integral: float,
               reached: bool, invalid: bool) -> tuple[float, dict[str, float]]:
        """The step's reward and its named terms (computed before the goal index advances)."""
        w = self.weights
        terms = dict.fromkeys(REWARD_TERMS, 0.0)
        terms["time"] = -w["time"] * step_time
        terms["wear"] = -w["wear"] * (cost_integral if self.wear_integral else cost.total)
        if self.wear_reward_cap is not None:  # a step that nearly tears the cable is bad, not a billion times bad
            terms["wear"] = max(terms["wear"], -self.wear_reward_cap)
        terms["progress"] = w["progress"] * (self.potential(q_before) - self.potential(q_after))
        terms["goal"] = w["goal"] if reached else 0.0
        terms["invalid"] = -w["invalid"] if invalid else 0.0
        return float(sum(terms.values())), terms
