"""Record seeded env rollouts (joint steps and planner-like primitives) to compare two versions bit for bit.

    PYTHONPATH=. .venv/bin/python scripts/studies/env_rollout_record.py before.npz      # on one commit
    PYTHONPATH=. .venv/bin/python scripts/studies/env_rollout_record.py after.npz --compare before.npz   # on another

A refactor that must not change behaviour keeps every array equal (NaN equal to NaN); the env ids stay v0 only then.
"""

from __future__ import annotations

import argparse
import sys

import gymnasium as gym
import numpy as np
import yaml

import dresspack_gym  # noqa: F401  (registers the env ids)
from dresspack_gym.shipped import find_shipped


def _numbers(info: dict) -> np.ndarray:
    """The info's scalar entries in key order (what a step reports besides the observation and reward)."""
    return np.array([float(v) for _, v in sorted(info.items()) if isinstance(v, (int, float, np.floating, bool))])


def record(joint_steps: int = 30, primitive_steps: int = 8) -> dict[str, np.ndarray]:
    """Seeded random masked actions on the default station: joint steps with the goal action, and the shipped
    goal-conditioned training config's primitives."""
    config = find_shipped("goal_conditioned", "training", "training config")
    primitives = yaml.safe_load(config.read_text())["env_kwargs"]
    out = {}
    for name, kwargs, steps in (("steps", {"goal_action": True}, joint_steps), ("prims", primitives, primitive_steps)):
        env = gym.make("dresspack_gym/StudWelding-v0", **kwargs).unwrapped
        obs, info = env.reset(seed=7)
        rng = np.random.default_rng(3)
        observations, rewards, infos = [obs], [], []
        for _ in range(steps):
            action = int(rng.choice(np.flatnonzero(env.action_masks())))
            obs, reward, terminated, truncated, info = env.step(action)
            observations.append(obs)
            rewards.append(reward)
            infos.append(_numbers(info))
            if terminated or truncated:
                obs, info = env.reset(seed=8)
        out[f"{name}_obs"], out[f"{name}_rew"] = np.array(observations), np.array(rewards)
        out[f"{name}_info"], out[f"{name}_q"] = np.concatenate(infos), env.sim.q.copy()
        env.close()
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="where to write the recorded arrays (.npz)")
    parser.add_argument("--compare", help="a recording of another version: exit 1 unless every array is equal")
    args = parser.parse_args()
    arrays = record()
    np.savez(args.out, **arrays)
    if args.compare:
        with np.load(args.compare) as other:
            differ = [k for k in arrays if k not in other or not np.array_equal(arrays[k], other[k], equal_nan=True)]
        print("bit-identical" if not differ else f"differ: {differ}")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
