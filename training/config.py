"""Training-run configuration: a frozen dataclass read (strictly) from a YAML file in configs/training/."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym

from dresspack_gym import ENV_IDS
from dresspack_gym.cli.args import MAX_SEED
from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import Section
from dresspack_gym.io.loading import read_yaml
from dresspack_gym.shipped import find_shipped

ACTIVATIONS = ("tanh", "relu")
BEST_BY = ("reward", "success")  # the evaluation callback's rules for the best model (eval_callback.py)
MAX_ENVS = 64  # environment processes (one per core)
MAX_TIMESTEPS = 10**9  # ~100 days of env steps at today's speed on 2 cores: more is a typo


@dataclass(frozen=True)
class PPOConfig:
    """MaskablePPO hyperparameters (stable-baselines3 names)."""

    learning_rate: float = 3e-4
    n_steps: int = 512  # per environment, per update
    batch_size: int = 256
    n_epochs: int = 10
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 0.01
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5


@dataclass(frozen=True)
class TrainConfig:
    """Everything that defines a training run (saved, resolved, into the run folder)."""

    name: str
    env_id: str = "dresspack_gym/StudWelding-v0"
    env_kwargs: dict = field(default_factory=dict)
    n_envs: int = 2
    vec_env: str = "subproc"  # subproc: one process per env (both cores); dummy: in-process (tests)
    total_timesteps: int = 100_000
    seed: int = 0
    net_arch: tuple[int, ...] = (128, 128)
    activation: str = "tanh"
    ppo: PPOConfig = PPOConfig()
    checkpoint_every: int = 20_000  # env steps
    eval_every: int = 20_000  # env steps; 0 disables the evaluation callback (no best model)
    eval_episodes: int = 10
    eval_seed: int = 10_000  # evaluation episodes use their own seeds, never the training ones
    best_by: str = "reward"  # the best model: highest mean evaluation reward, or success rate (ties by reward)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["net_arch"] = list(self.net_arch)
        return d


def load_train_config(ref: str | Path) -> TrainConfig:
    """Read a training config by path or by name in configs/training/ (e.g. ``stud_welding``)."""
    path = find_shipped(ref, "training", "config")
    return train_config_from_dict(read_yaml(path, "config"), default_name=path.stem)


def train_config_from_dict(data: dict, default_name: str = "run") -> TrainConfig:
    s = Section(data, "")
    d = TrainConfig(name=default_name)
    env_id = s.string("env_id", d.env_id)
    if env_id not in gym.registry:
        raise ConfigError("env_id", f"{env_id!r} is not a registered environment; dresspack ids are {list(ENV_IDS)}")
    env_kwargs = s.raw("env_kwargs", {})
    if not isinstance(env_kwargs, dict):
        raise ConfigError("env_kwargs", f"expected a mapping of DresspackEnv arguments, got {env_kwargs!r}")
    net_arch = s.raw("net_arch", list(d.net_arch))
    if not (isinstance(net_arch, list) and net_arch and all(isinstance(n, int) and n > 0 for n in net_arch)):
        raise ConfigError("net_arch", f"expected a list of positive layer widths, got {net_arch!r}")
    p = s.section("ppo", {})
    dp = PPOConfig()
    ppo = PPOConfig(
        learning_rate=p.number("learning_rate", dp.learning_rate, lo=0.0, lo_open=True, hi=1.0),
        n_steps=p.integer("n_steps", dp.n_steps, lo=2),
        batch_size=p.integer("batch_size", dp.batch_size, lo=2),
        n_epochs=p.integer("n_epochs", dp.n_epochs, lo=1),
        gamma=p.number("gamma", dp.gamma, lo=0.0, hi=1.0),
        gae_lambda=p.number("gae_lambda", dp.gae_lambda, lo=0.0, hi=1.0),
        clip_range=p.number("clip_range", dp.clip_range, lo=0.0, lo_open=True, hi=1.0),
        ent_coef=p.number("ent_coef", dp.ent_coef, lo=0.0, hi=1.0),
        vf_coef=p.number("vf_coef", dp.vf_coef, lo=0.0, hi=10.0),
        max_grad_norm=p.number("max_grad_norm", dp.max_grad_norm, lo=0.0, lo_open=True, hi=100.0),
    )
    p.done()
    cfg = TrainConfig(
        name=s.string("name", d.name),
        env_id=env_id,
        env_kwargs=dict(env_kwargs),
        n_envs=s.integer("n_envs", d.n_envs, lo=1, hi=MAX_ENVS),
        vec_env=s.string("vec_env", d.vec_env, choices=("subproc", "dummy")),
        total_timesteps=s.integer("total_timesteps", d.total_timesteps, lo=1, hi=MAX_TIMESTEPS),
        seed=s.integer("seed", d.seed, lo=0, hi=MAX_SEED),
        net_arch=tuple(net_arch),
        activation=s.string("activation", d.activation, choices=ACTIVATIONS),
        ppo=ppo,
        checkpoint_every=s.integer("checkpoint_every", d.checkpoint_every, lo=1),
        eval_every=s.integer("eval_every", d.eval_every, lo=0),
        eval_episodes=s.integer("eval_episodes", d.eval_episodes, lo=1),
        eval_seed=s.integer("eval_seed", d.eval_seed, lo=0, hi=MAX_SEED),
        best_by=s.string("best_by", d.best_by, choices=BEST_BY),
    )
    s.done()
    rollout = cfg.ppo.n_steps * cfg.n_envs
    if cfg.ppo.batch_size > rollout:
        raise ConfigError("ppo.batch_size", f"{cfg.ppo.batch_size} is larger than one rollout (ppo.n_steps x n_envs = "
                                            f"{cfg.ppo.n_steps} x {cfg.n_envs} = {rollout}): must be at most {rollout}")
    return cfg


def apply_overrides(data: dict, **overrides) -> dict:
    """A config dict with command-line overrides set (None: not given), to be read by train_config_from_dict so
    that an override passes the same checks as the YAML value it replaces."""
    out = dict(data)
    out.update({k: v for k, v in overrides.items() if v is not None})
    return out


def check_env_kwargs(cfg: TrainConfig) -> None:
    """Build one environment so a wrong env argument fails now, naming the field, not in a subprocess."""
    try:
        env = gym.make(cfg.env_id, **cfg.env_kwargs)
    except TypeError as exc:
        raise ConfigError("env_kwargs", f"{exc}; see DresspackEnv's arguments") from None
    except ConfigError as exc:
        raise ConfigError(f"env_kwargs.{exc.field}", str(exc).split(": ", 1)[-1]) from None
    env.close()
