"""The env's steps/s on the rod engine against MuJoCo, turn-about in one process on the same random masked steps.

    PYTHONPATH=. .venv/bin/python scripts/studies/env_engine_speed.py --setup joint --steps 120 --rounds 6
    PYTHONPATH=. .venv/bin/python scripts/studies/env_engine_speed.py --setup primitives --steps 12 --rounds 4

Each round runs the same episodes (reset seed 0, actions drawn from seed 0 among the allowed ones) on every profile
in turn, so the rounds differ only in what else the machine did; the ratios are medians over the rounds. ``joint``
is the joint-step env with default arguments, ``primitives`` the goal-conditioned setup of its shipped training
config. Profiles: ``training`` (the rod engine), ``coarse_step`` (MuJoCo, the same cable at 8 ms) and
``mujoco_16`` (MuJoCo with 16 segments at 8 ms, registered here only: the profile training used before the rod
engine).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def main() -> None:
    from dresspack_gym.cli.bench import _training_env_kwargs
    from dresspack_gym.env.dresspack_env import DresspackEnv
    from dresspack_gym.physics.profiles import PROFILES, PhysicsProfile

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--setup", choices=["joint", "primitives"], default="joint")
    ap.add_argument("--steps", type=int, default=120, help="env steps per profile and round")
    ap.add_argument("--rounds", type=int, default=6)
    args = ap.parse_args()

    PROFILES["mujoco_16"] = PhysicsProfile("mujoco_16", segments=16, timestep=0.008)
    kwargs = {} if args.setup == "joint" else _training_env_kwargs("goal_conditioned")
    names = ("training", "coarse_step", "mujoco_16")
    envs = {n: DresspackEnv("default", **{**kwargs, "physics_profile": n}) for n in names}

    def rate(env) -> float:
        rng = np.random.default_rng(0)
        env.reset(seed=0)
        t0 = time.perf_counter()
        for _ in range(args.steps):
            *_, terminated, truncated, _ = env.step(int(rng.choice(np.flatnonzero(env.action_masks()))))
            if terminated or truncated:
                env.reset()
        return args.steps / (time.perf_counter() - t0)

    for env in envs.values():  # compiled code loaded and caches filled before anything is timed
        env.reset(seed=0)
        env.step(int(np.flatnonzero(env.action_masks())[0]))
    rates = {n: [] for n in names}
    for _ in range(args.rounds):
        for n in names:
            rates[n].append(rate(envs[n]))
    fast = np.array(rates["training"])
    print(json.dumps({"setup": args.setup, "steps": args.steps, "rounds": args.rounds,
                      "steps_per_s_median": {n: round(float(np.median(r)), 2) for n, r in rates.items()},
                      "training_vs_coarse_step": round(float(np.median(fast / np.array(rates["coarse_step"]))), 2),
                      "training_vs_mujoco_16": round(float(np.median(fast / np.array(rates["mujoco_16"]))), 2)},
                     indent=2))


if __name__ == "__main__":
    main()
