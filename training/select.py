"""``dresspack select-model RUN``: every saved model of a training run rolled out on the same held-out episodes,
more of them than the evaluation callback affords, and the best picked by success, then by mean return."""

from __future__ import annotations

import contextlib
import json
import math
import multiprocessing
from pathlib import Path

from dresspack.agents.learned.policy import ATTEMPTS

from dresspack_gym.cli.args import number, seed
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import read_yaml

# Episode k of a selection resets the env with seed + k: these seeds are apart from the training envs' (seed,
# seed + 1, ...), the callback's (eval_seed, 10,000 by default) and the evaluation's weld draws (1,000,000).
SELECT_SEED = 20_000
SELECT_EPISODES = 90
MAX_EPISODES = 1000


def run_models(run_dir: Path) -> list[tuple[int, Path]]:
    """The run's checkpoints and its final model as (env steps, file), in order of steps."""
    models = []
    for path in sorted((run_dir / "checkpoints").glob("ckpt_*_steps.zip")):
        models.append((int(path.stem.split("_")[1]), path))
    final = run_dir / "final_model.zip"
    if final.is_file():
        summary = run_dir / "summary.json"
        steps = json.loads(summary.read_text())["timesteps"] if summary.is_file() else math.inf
        models.append((steps, final))
    return sorted(models, key=lambda m: m[0])


def validate(model_path: Path, run_dir: Path, episodes: int, first_seed: int, attempts: int = ATTEMPTS) -> dict:
    """Roll the model out on episodes first_seed .. + episodes - 1 as the evaluation's ``ppo`` does: the most
    probable allowed action each step, and where that does not finish, up to ``attempts - 1`` rollouts with sampled
    actions (torch seeded by the episode's seed). The finishing rollout's return, cycle time and ∫C dt count."""
    import gymnasium as gym
    import numpy as np
    import torch
    from sb3_contrib import MaskablePPO

    import dresspack_gym  # noqa: F401  (registers the env ids)

    from .config import train_config_from_dict
    from .rollouts import roll_out

    torch.set_num_threads(1)  # one process per core
    cfg = train_config_from_dict(read_yaml(run_dir / "config.yaml", "run"))
    env = gym.make(cfg.env_id, **cfg.env_kwargs).unwrapped
    model = MaskablePPO.load(model_path, device="cpu")

    returns, successes, first_tries, cycles, wears = [], [], [], [], []
    for k in range(episodes):
        torch.manual_seed(first_seed + k)
        for attempt in range(attempts):
            total, wear, info, _ = roll_out(env, model, first_seed + k, deterministic=attempt == 0)
            if info["is_success"]:
                break
        returns.append(total)
        successes.append(bool(info["is_success"]))
        first_tries.append(bool(info["is_success"]) and attempt == 0)
        if info["is_success"]:
            cycles.append(info["cycle_time"])
            wears.append(wear)
    env.close()
    return {"model": model_path.name, "success_rate": float(np.mean(successes)), "mean_return": float(np.mean(returns)),
            "argmax_success_rate": float(np.mean(first_tries)),
            "mean_cycle_time": float(np.mean(cycles)) if cycles else None,
            "mean_integral_cost": float(np.mean(wears)) if wears else None}


def _validate_job(job) -> dict:
    steps, path, run_dir, episodes, first_seed, attempts = job
    return {"steps": steps, **validate(path, run_dir, episodes, first_seed, attempts)}


def select_model(run_dir: str | Path, *, episodes: int = SELECT_EPISODES, first_seed: int = SELECT_SEED,
                 from_steps: int = 0, attempts: int = ATTEMPTS, jobs: int = 1, progress=print) -> dict:
    """Validate every model of the run from ``from_steps`` on (results kept in ``select_<seed>_<episodes>.jsonl``
    of the run folder: an interrupted selection resumes); returns the table and the pick (success first, ties by
    mean return, then the earlier model), also written to ``select_<seed>_<episodes>.json``."""
    run_dir = Path(run_dir)
    if not (run_dir / "config.yaml").is_file():
        raise ConfigError("run", f"{run_dir} is not a training run folder (no config.yaml)")
    models = [(s, p) for s, p in run_models(run_dir) if s >= from_steps]
    if not models:
        raise ConfigError("from_steps", f"{run_dir} has no checkpoint or final model from {from_steps} steps on")
    name = f"select_{first_seed}_{episodes}" + ("" if attempts == ATTEMPTS else f"_{attempts}")
    log = run_dir / f"{name}.jsonl"
    done = {}
    if log.is_file():
        for line in log.read_text().splitlines():
            row = json.loads(line)
            done[row["model"]] = row
    todo = [(s, p, run_dir, episodes, first_seed, attempts) for s, p in models if p.name not in done]
    if todo:
        progress(f"validating {len(todo)} models on {episodes} episodes (seeds {first_seed}..{first_seed + episodes - 1})"
                 f", {jobs} at a time")
    pool = multiprocessing.get_context("forkserver").Pool(min(jobs, len(todo))) if jobs > 1 and len(todo) > 1 else None
    with pool or contextlib.nullcontext():
        for row in (pool.imap if pool else map)(_validate_job, todo):
            done[row["model"]] = row
            with log.open("a") as f:
                f.write(json.dumps(row, default=float) + "\n")
            progress(_line(row))
    rows = sorted((done[p.name] for _, p in models), key=lambda r: r["steps"])
    best = max(rows, key=lambda r: (r["success_rate"], r["mean_return"]))
    result = {"run": str(run_dir), "episodes": episodes, "first_seed": first_seed, "attempts": attempts,
              "rule": "success, then mean return", "models": rows, "best": best}
    (run_dir / f"{name}.json").write_text(json.dumps(result, indent=2, default=float) + "\n")
    return result


def _line(row: dict) -> str:
    def num(v, f):
        return "-" if v is None else format(v, f)

    return (f"{row['model']:>24s}  success {100 * row['success_rate']:5.1f} % (first try "
            f"{100 * row['argmax_success_rate']:5.1f} %)  return {row['mean_return']:7.2f}  "
            f"cycle {num(row['mean_cycle_time'], '.2f')} s  ∫C {num(row['mean_integral_cost'], '.1f')}")


def add_select_command(sub) -> None:
    p = sub.add_parser("select-model", help="pick a training run's best model on more held-out episodes",
                       description="Rolls every checkpoint and the final model of RUN out on the same held-out "
                                   "episodes (their own seeds) and picks the best: success first, ties by mean "
                                   "return. Resumable; writes select_<seed>_<episodes>.json into the run folder.")
    p.add_argument("run", help="training run folder (runs/train/<name>)")
    p.add_argument("--episodes", type=number(1, MAX_EPISODES, integer=True), default=SELECT_EPISODES,
                   help=f"held-out episodes each model is rolled out on (default {SELECT_EPISODES})")
    p.add_argument("--seed", type=seed, default=SELECT_SEED, help=f"first episode's seed (default {SELECT_SEED})")
    p.add_argument("--from-steps", type=number(0, None, integer=True), default=0,
                   help="only models saved at this many env steps or later (default 0: every model)")
    p.add_argument("--attempts", type=number(1, 10, integer=True), default=ATTEMPTS,
                   help=f"rollouts per episode: the most probable actions, then sampled ones, as the evaluation's "
                        f"ppo (default {ATTEMPTS}; 1: the most probable only, as the training callback)")
    p.add_argument("--jobs", type=number(1, 64, integer=True), default=1,
                   help="processes (one per core; default 1)")
    p.set_defaults(func=cmd_select)


def cmd_select(args) -> int:
    result = select_model(args.run, episodes=args.episodes, first_seed=args.seed, from_steps=args.from_steps,
                          attempts=args.attempts, jobs=args.jobs)
    print(f"best: {_line(result['best'])}  ({result['rule']})")
    return 0
