"""A trained MaskablePPO policy behind the Planner interface: it drives the env through a task, and the
configurations it visits become a Trajectory that the evaluation replays exactly like a planner's."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import yaml

from dresspack_gym.env.dresspack_env import DresspackEnv
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.artefacts import reading
from dresspack_gym.physics.trajectory import Trajectory
from dresspack_gym.shipped import find_shipped, shipped_root
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import Task

from ..planners.base import Planner, PlanningError, out_of_time_error

SHIPPED_IN = "dresspack.agents"  # the package whose data holds the shipped policies: agents/policies/<name>/
POLICY_DIR = shipped_root(SHIPPED_IN) / "policies"
DEFAULT_POLICY = "goal_conditioned"  # any weld, any start; stud_welding: the default station's named welds
STILL = 1e-9  # [rad] a move whose target is no farther than this in every joint leaves the robot where it stands
ATTEMPTS = 3  # rollouts per task: the most probable action each step, then actions sampled (see PolicyPlanner)
# Only the episode-sampling arguments differ between training and acting on a given task.
_TRAINING_ONLY = ("tasks", "n_welds", "shuffle_welds", "welds", "start_noise_deg", "station", "render_mode")


def resolve_policy(ref: str | Path | None) -> tuple[Path, dict]:
    """A run folder, a shipped policy name (agents/policies/<name>) or a model .zip next to its config.yaml.
    Returns the model file and the training config (env id and env kwargs)."""
    ref = DEFAULT_POLICY if ref is None else ref
    path = Path(ref)
    if not path.exists():
        path = find_shipped(ref, "policies", "policy", package=SHIPPED_IN, suffix="")
    if path.is_dir():
        for name in ("model.zip", "best/best_model.zip", "final_model.zip"):
            if (path / name).is_file():
                model, folder = path / name, path
                break
        else:
            raise ConfigError("policy", f"{path} holds no model.zip, best/best_model.zip or final_model.zip")
    elif path.suffix == ".zip":  # beside its run's config.yaml, or one folder down (best/, checkpoints/)
        folder = next((f for f in (path.parent, path.parent.parent) if (f / "config.yaml").is_file()), None)
        if folder is None:
            raise ConfigError("policy", f"{path}: neither {path.parent} nor {path.parent.parent} holds the "
                                        "config.yaml of its training run (the config that defines the env)")
        model = path
    else:
        raise ConfigError("policy", f"{path} is neither a run folder nor a model .zip")
    if not (folder / "config.yaml").is_file():
        raise ConfigError("policy", f"{folder} has no config.yaml (the training config that defines the env)")
    with reading(folder / "config.yaml", "policy", "training config (YAML)"):
        config = yaml.safe_load((folder / "config.yaml").read_text())
    if not isinstance(config, dict):
        raise ConfigError("policy", f"{folder / 'config.yaml'} is not a training config (a YAML mapping)")
    return model, config


def policy_actions(policy_file: str | Path) -> int:
    """How many actions the policy in ``policy_file`` (a MaskablePPO .zip) chooses among."""
    from sb3_contrib import MaskablePPO

    from dresspack_gym.io.artefacts import reading

    with reading(policy_file, "policy", "MaskablePPO model (.zip)", "the labels' spec.json names it as policy_file"):
        return int(MaskablePPO.load(policy_file, device="cpu").action_space.n)


def moving_masks(env: DresspackEnv, masks: np.ndarray) -> np.ndarray:
    """``masks`` less the moves to where the robot already stands (a via to the travel posture it is at), unless
    nothing else is allowed. The env offers them (its observation shows them, as the policy saw them in training),
    but such a move is a wait that costs a step, and where one was the most probable action the policy stood on
    it until its steps ran out. The wait itself stays allowed."""
    q = env.q
    still = [a for a in np.flatnonzero(masks)
             if a != env.stay_action and np.abs(env.target(q, int(a)) - q).max() <= STILL]
    if not still or len(still) == int(masks.sum()):
        return masks
    moving = masks.copy()
    moving[still] = False
    return moving


class PolicyAgent:
    """The trained network with the SB3 ``predict`` signature, always masked."""

    def __init__(self, model_path: Path):
        from sb3_contrib import MaskablePPO

        with reading(model_path, "policy", "MaskablePPO model (.zip)"):
            self.model = MaskablePPO.load(model_path, device="cpu")
        self.n_actions = int(self.model.action_space.n)

    def reset(self, seed: int) -> None:
        """Deterministic actions need no randomness; sampling (``deterministic=False``) uses torch's."""
        import torch

        torch.manual_seed(seed)

    def predict(self, observation, action_masks, deterministic: bool = True) -> int:
        action, _ = self.model.predict(observation, action_masks=action_masks, deterministic=deterministic)
        return int(action)

    def probabilities(self, observation, action_masks) -> np.ndarray:
        """The masked policy's probability of every action (0 where masked)."""
        import torch

        policy = self.model.policy
        obs, _ = policy.obs_to_tensor(observation)
        with torch.no_grad():
            dist = policy.get_distribution(obs, action_masks=np.asarray(action_masks)[None])
            return dist.distribution.probs[0].cpu().numpy().astype(float)


class RandomMaskedAgent:
    """The floor: a uniformly random allowed action each step (same ``predict`` signature)."""

    def __init__(self, n_actions: int, seed: int = 0):
        self.n_actions = n_actions
        self.rng = np.random.default_rng(seed)

    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)

    def predict(self, observation, action_masks, deterministic: bool = True) -> int:
        return int(self.rng.choice(np.flatnonzero(action_masks)))


class PolicyPlanner(Planner):
    """``ppo``: roll the policy out in the training env (on this station, from the task's start, through the
    task's welds, with masks); its visited configurations are the trajectory.

    Actions: first a rollout with the most probable allowed action each step (a move to where the robot already
    stands is never taken, see :func:`moving_masks`); if it runs out of steps (argmax can cycle where the policy is
    undecided: the shipped policy never finishes floor_pan_inner that way), up to
    ``attempts - 1`` rollouts with actions sampled from the masked policy, seeded by the planner's seed (runs
    are reproducible). Sampling alone finishes every task but wanders (~20 % more wear on the held-out tasks).
    ``deterministic=True``: argmax only; ``sample=True``: sampling only.
    """

    name = "ppo"
    color = "#1b9e77"
    uses_policy = True

    def __init__(self, station: Station, robot: int = 0, *, policy: str | Path | None = None,
                 deterministic: bool = False, sample: bool = False, attempts: int = ATTEMPTS, **kwargs):
        super().__init__(station, robot, **kwargs)
        if deterministic and sample:
            raise ConfigError("deterministic", "choose deterministic=True or sample=True, not both")
        if not (isinstance(attempts, int) and attempts >= 1):
            raise ConfigError("attempts", f"must be an integer >= 1, got {attempts!r}")
        self.deterministic, self.sample, self.attempts = bool(deterministic), bool(sample), attempts
        model_path, config = resolve_policy(policy)
        self.policy_path = model_path
        env_kwargs = {k: v for k, v in (config.get("env_kwargs") or {}).items() if k not in _TRAINING_ONLY}
        margin = float(env_kwargs.pop("collision_margin", 0.0))
        # the planners' margin (at least): every step the masks allow then passes Planner.plan's validity check
        margin = max(margin, self.validity.checker.margin)
        self.env = DresspackEnv(station=station, robot=robot, collision_margin=margin, **env_kwargs)
        self.agent = self._make_agent(model_path)
        expected = self.agent.n_actions
        if self.env.action_space.n != expected:
            raise ConfigError("policy", f"the model has {expected} actions but its env config gives "
                                        f"{self.env.action_space.n}")

    def _make_agent(self, model_path: Path):
        return PolicyAgent(model_path)

    def _reseed(self) -> None:
        super()._reseed()
        self.agent.reset(self.seed)

    def _plan(self, task: Task) -> tuple[Trajectory, dict]:
        self._check_ends_at_home(task)
        failures = []
        for attempt, mode in enumerate(self._modes()):
            try:
                traj, info = self._rollout(task, mode)
            except EpisodeFailed as exc:
                failures.append(f"{mode}: {exc}")
                continue
            return traj, {**info, "mode": mode, "attempts": attempt + 1}
        raise PlanningError("the policy did not finish the task (" + "; ".join(failures) + ")")

    def _check_ends_at_home(self, task: Task) -> None:
        if not np.allclose(task.end, self.env.placement.home):
            raise PlanningError("the policy's episodes end at Home; this task ends elsewhere")

    def _modes(self) -> list[str]:
        """How each rollout chooses its actions, in the order they are tried."""
        if self.deterministic:
            return ["argmax"]
        if self.sample:
            return ["sample"] * self.attempts
        return ["argmax"] + ["sample"] * (self.attempts - 1)

    def _rollout(self, task: Task, mode: str) -> tuple[Trajectory, dict]:
        env = self.env
        # the task's own goal configurations: named welds and welds drawn for an evaluation alike
        obs, info = env.reset(seed=self.seed, options={"goals": dict(zip(task.weld_names, task.goals)),
                                                       "start": task.start})
        waypoints, stops, actions, masked_taken = [env.q], [], [], 0
        unconverged = []  # goals whose settle ended above the equilibrium residual: their wear reads a moving cable
        inference = 0.0  # the network alone; the rest of the planning time is the env (physics, masks)
        done = False
        while not done:
            if self.allowance.out_of_time():  # the work bound is the env's max_steps
                raise out_of_time_error(self, f"after {env.steps} policy steps")
            masks = env.action_masks()
            reached_before = info["goals_reached"]
            action, (obs, _, terminated, truncated, info), seconds = self._step(obs, masks, mode)
            inference += seconds
            actions.append(int(action))
            masked_taken += int(not masks[action])
            done = terminated or truncated
            for q in info["moved_through"]:  # a move that ends on the goal passes it twice: once is a waypoint
                if not np.allclose(q, waypoints[-1], atol=1e-12):
                    waypoints.append(q)
            if info["goals_reached"] > reached_before:
                stops.append(len(waypoints) - 1)
                if not info["settle_converged"]:
                    unconverged.append((*task.weld_names, "home")[reached_before])
        if not info["is_success"]:
            raise EpisodeFailed(f"{info['goals_reached']}/{info['n_goals']} goals in {env.max_steps} steps")
        traj = Trajectory(np.array(waypoints), tuple(stops))
        return traj, {"policy": str(self.policy_path), "policy_steps": env.steps, "actions": actions,
                      "masked_actions": masked_taken, "inference_s": round(inference, 5),
                      "unconverged_settles": unconverged}

    def _step(self, obs, masks, mode: str):
        """Choose an action and take it: the action, ``env.step``'s return and the network's seconds."""
        t0 = time.perf_counter()
        action = self.agent.predict(obs, self._moving(masks), deterministic=mode == "argmax")
        seconds = time.perf_counter() - t0
        return action, self.env.step(action), seconds

    def _moving(self, masks: np.ndarray) -> np.ndarray:
        return moving_masks(self.env, masks)


class EpisodeFailed(Exception):
    """One rollout ran out of steps (the planner may try again)."""


class RandomMaskedPlanner(PolicyPlanner):
    """``random``: the shipped policy's env and action set, but uniformly random allowed actions (a floor)."""

    name = "random"
    color = "#999999"

    def _make_agent(self, model_path: Path):
        return RandomMaskedAgent(self.env.action_space.n, self.seed)
