"""Segment-cost study configuration (counterfactual data, cost model): frozen dataclasses read strictly from YAML."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from dresspack_gym.cli.args import MAX_SEED
from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import Section
from dresspack_gym.io.loading import read_yaml
from dresspack_gym.shipped import find_shipped

# the visited states: the policy's most probable actions, its sampled ones, or ppo-search's ranked rule (the policy's
# proposals ranked by a cost-to-go model: labels on the states the ranked planner visits, a DAgger round)
ROLLOUTS = ("argmax", "sample", "ranked")
TARGETS = ("log", "linear")  # regress log(1 + cost) or the cost itself
LOSSES = ("huber", "mse")
LABELS = ("step", "to_go")  # the step's time + ∫C dt, or the cost to go of a continued proposal
MAX_EPISODES = 100_000
MAX_CONTINUED = 64  # ppo-search's most proposals a step
# The policy's env may differ only in how episodes are drawn and in the physics profile (the engine the labels are
# simulated on: the observation's layout does not depend on it, tests/env/test_env_fast_engine.py); the action set
# and the observation must stay the policy's (and the cost model's inputs with them).
ENV_OVERRIDES = ("start_noise_deg", "part_welds", "weld_tilt_deg", "max_steps", "physics_profile")


@dataclass(frozen=True)
class CounterfactualConfig:
    """Which states are visited (the policy's rollouts) and how many."""

    policy: str = "goal_conditioned"  # shipped policy name, run folder or model .zip (its config.yaml gives the env)
    episodes: int = 150
    seed: int = 0  # episode k resets the env (and torch, for sampled actions) from (seed, k) alone
    rollout: str = "sample"  # the visited states: the most probable action each step, actions sampled, or ranked
    cost_to_go: str | None = None  # rollout "ranked": its model (a model.pt, or a name shipped beside the policy)
    continued: int = 0  # the policy's most probable moves at each state continued to the end (cost-to-go labels)
    every_action: bool = True  # a row for every allowed action; false: for the continued ones only
    env_kwargs: dict = field(default_factory=dict)  # overrides of the policy's env, from ENV_OVERRIDES


@dataclass(frozen=True)
class CostModelConfig:
    """The MLP and its fit."""

    hidden: tuple[int, ...] = (256, 256)
    target: str = "log"
    loss: str = "huber"
    parts: bool = True  # also regress the time and the wear integral (extra heads; the ranking uses the total)
    label: str = "step"
    epochs: int = 150
    batch_size: int = 256
    learning_rate: float = 1e-3
    weight_decay: float = 1e-4
    held_out: float = 0.2  # fraction of the episodes (never of rows: a state's actions stay together)
    seed: int = 0


@dataclass(frozen=True)
class CostStudyConfig:
    name: str = "cost_model"
    counterfactuals: CounterfactualConfig = CounterfactualConfig()
    model: CostModelConfig = CostModelConfig()

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["model"]["hidden"] = list(self.model.hidden)
        return d


def load_cost_config(ref: str | Path) -> CostStudyConfig:
    """Read a cost-model config by path or by name in configs/training/ (e.g. ``cost_model``)."""
    path = find_shipped(ref, "training", "config")
    return cost_config_from_dict(read_yaml(path, "config"), default_name=path.stem)


def cost_config_from_dict(data: dict, default_name: str = "cost_model") -> CostStudyConfig:
    s = Section(data, "")
    dc, dm = CounterfactualConfig(), CostModelConfig()
    c = s.section("counterfactuals", {})
    env_kwargs = c.raw("env_kwargs", {})
    if not isinstance(env_kwargs, dict):
        raise ConfigError("counterfactuals.env_kwargs", f"expected a mapping, got {env_kwargs!r}")
    for key in env_kwargs:
        if key not in ENV_OVERRIDES:
            raise ConfigError(f"counterfactuals.env_kwargs.{key}", f"not a setting the labels may override; allowed: "
                                                                    f"{list(ENV_OVERRIDES)} (the action set and "
                                                                    "observation stay the policy's)")
    counterfactuals = CounterfactualConfig(
        policy=c.string("policy", dc.policy),
        episodes=c.integer("episodes", dc.episodes, lo=1, hi=MAX_EPISODES),
        seed=c.integer("seed", dc.seed, lo=0, hi=MAX_SEED),
        rollout=c.string("rollout", dc.rollout, choices=ROLLOUTS),
        cost_to_go=None if c.raw("cost_to_go", None) is None else c.string("cost_to_go"),
        continued=c.integer("continued", dc.continued, lo=0, hi=MAX_CONTINUED),
        every_action=c.boolean("every_action", dc.every_action),
        env_kwargs=dict(env_kwargs),
    )
    c.done()
    if not counterfactuals.every_action and not counterfactuals.continued:
        raise ConfigError("counterfactuals.every_action", "false keeps only the continued actions' rows: set "
                                                          "counterfactuals.continued to 1 or more, or every_action "
                                                          "to true")
    if (counterfactuals.rollout == "ranked") != (counterfactuals.cost_to_go is not None):
        raise ConfigError("counterfactuals.cost_to_go", "the ranked rollout needs its cost-to-go model (a model.pt "
                                                        "or a name shipped beside the policy, e.g. cost_to_go), "
                                                        "and only it takes one")
    m = s.section("model", {})
    hidden = m.raw("hidden", list(dm.hidden))
    if not (isinstance(hidden, list) and hidden and all(isinstance(n, int) and not isinstance(n, bool) and n > 0
                                                        for n in hidden)):
        raise ConfigError("model.hidden", f"expected a list of positive layer widths, got {hidden!r}")
    model = CostModelConfig(
        hidden=tuple(hidden),
        target=m.string("target", dm.target, choices=TARGETS),
        loss=m.string("loss", dm.loss, choices=LOSSES),
        parts=m.boolean("parts", dm.parts),
        label=m.string("label", dm.label, choices=LABELS),
        epochs=m.integer("epochs", dm.epochs, lo=1, hi=100_000),
        batch_size=m.integer("batch_size", dm.batch_size, lo=1),
        learning_rate=m.number("learning_rate", dm.learning_rate, lo=0.0, lo_open=True, hi=1.0),
        weight_decay=m.number("weight_decay", dm.weight_decay, lo=0.0, hi=1.0),
        held_out=m.number("held_out", dm.held_out, lo=0.0, lo_open=True, hi=0.9),
        seed=m.integer("seed", dm.seed, lo=0, hi=MAX_SEED),
    )
    m.done()
    if model.label == "to_go" and model.parts:
        raise ConfigError("model.parts", "the cost to go has no parts (time, wear) to regress: set it false")
    cfg = CostStudyConfig(name=s.string("name", default_name), counterfactuals=counterfactuals, model=model)
    s.done()
    return cfg
