"""Train MaskablePPO on a dresspack environment from a YAML config: run folder, TensorBoard, checkpoints, resume.

    dresspack train stud_welding                        # or a YAML path: configs/training/stud_welding.yaml
    dresspack train --resume runs/train/stud_welding    # continue after Ctrl-C or a crash
    dresspack train goal_conditioned --physics-profile training   # on the rod engine (1.5-1.8x the steps/s)

Run folder: ``config.yaml`` (resolved), ``command.txt`` (every launch), ``versions.json``, ``tb/`` (TensorBoard),
``checkpoints/`` (periodic + on Ctrl-C), ``best/best_model.zip`` and ``best/best.json`` (evaluation callback, by
``best_by``), ``eval/evaluations.npz`` (every evaluation, kept across resumes), ``final_model.zip``,
``summary.json`` (wall time, steps/s, last evaluation).
"""

from __future__ import annotations

import functools
import json
import os
import platform
import re
import shlex
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import yaml

from dresspack_gym import __version__
from dresspack_gym.cli.args import number, seed, warn_deprecated
from dresspack_gym.errors import ConfigError, DresspackError
from dresspack_gym.io.loading import read_yaml
from dresspack_gym.physics.profiles import PROFILES
from dresspack_gym.shipped import find_shipped

from .config import MAX_ENVS, MAX_TIMESTEPS, TrainConfig, apply_overrides, check_env_kwargs, train_config_from_dict

CHECKPOINT_PREFIX = "ckpt"


def add_train_command(sub) -> None:
    """``dresspack train`` (a ``dresspack`` subcommand, registered by entry point)."""
    p = sub.add_parser("train", help="train a MaskablePPO planner from a training config, with checkpoints and resume",
                       description=__doc__.split("\n")[0] + " The run folder holds config.yaml, checkpoints/, "
                                   "best/, tb/ (TensorBoard), final_model.zip and summary.json.")
    p.add_argument("config", nargs="?", help="training YAML (path, or a name in configs/training/)")
    p.add_argument("--run-dir", help="run folder (default: runs/train/<config name>)")
    p.add_argument("--resume", metavar="RUN_DIR", help="continue the run in RUN_DIR from its newest checkpoint")
    p.add_argument("--total-timesteps", type=number(1, MAX_TIMESTEPS, integer=True),
                   help="environment steps to train for in all (default: the config's total_timesteps)")
    p.add_argument("--n-envs", type=number(1, MAX_ENVS, integer=True),
                   help="parallel environments (default: the config's n_envs)")
    p.add_argument("--seed", type=seed, help="seed of the model and the training envs (default: the config's seed)")
    p.add_argument("--physics-profile", choices=list(PROFILES),
                   help="the envs' physics profile, replacing the config's env_kwargs.physics_profile (training: "
                        "the rod engine; the shipped configs keep the profiles their shipped policies were "
                        "trained on)")
    p.add_argument("--force", action="store_true",
                   help="train into a run folder that holds a finished or begun run, deleting it first")
    p.add_argument("--no-progress", action="store_true", help="draw no progress bar (on stderr by default)")
    p.set_defaults(func=cmd_train)


def latest_checkpoint(run_dir: Path) -> Path | None:
    """The checkpoint with the most environment steps (periodic or saved on interrupt)."""
    found = []
    for path in (run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"):
        m = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", path.name)
        if m:
            found.append((int(m.group(1)), path))
    return max(found)[1] if found else None


def resume_point(run_dir: Path) -> Path | None:
    """The model to continue from: the newest checkpoint, or the final model of a finished session when it holds
    more steps (a run's last rollout need not fall on a checkpoint)."""
    ckpt = latest_checkpoint(run_dir)
    try:
        summary = json.loads((run_dir / "summary.json").read_text())
    except (OSError, ValueError):
        return ckpt
    finished = (run_dir / "final_model.zip").is_file() and isinstance(summary, dict) and \
        not summary.get("interrupted") and isinstance(summary.get("timesteps"), int)
    if finished:
        m = re.fullmatch(rf"{CHECKPOINT_PREFIX}_(\d+)_steps\.zip", ckpt.name) if ckpt else None
        if m is None or int(m.group(1)) < summary["timesteps"]:
            return run_dir / "final_model.zip"
    return ckpt


def git_state(folder: Path) -> tuple[str | None, bool | None]:
    """(commit, whether tracked files differ from it) of the checkout holding ``folder``, or Nones outside one.
    Read only: ``--no-optional-locks`` keeps ``git status`` from refreshing the index (it would otherwise take
    ``.git/index.lock`` and rewrite the index of a checkout someone else may be committing in)."""
    def git(*args):
        return subprocess.run(["git", "--no-optional-locks", *args], capture_output=True, text=True, timeout=10,
                              cwd=folder, env={**os.environ, "GIT_OPTIONAL_LOCKS": "0"})

    try:
        commit = git("rev-parse", "HEAD").stdout.strip() or None
        # edits to tracked files not yet committed: the commit alone would not reproduce the run
        status = git("status", "--porcelain", "--untracked-files=no")
        dirty = bool(status.stdout.strip()) if commit and status.returncode == 0 else None
    except (OSError, subprocess.TimeoutExpired):
        commit = dirty = None
    return commit, dirty


def _versions() -> dict:
    import sb3_contrib
    import stable_baselines3
    import torch

    commit, dirty = git_state(Path(__file__).parent)
    return {"dresspack_gym": __version__, "git_commit": commit, "git_dirty": dirty, "python": platform.python_version(),
            "torch": torch.__version__, "stable_baselines3": stable_baselines3.__version__,
            "sb3_contrib": sb3_contrib.__version__}


def make_vec_env(cfg: TrainConfig, seed: int, n_envs: int | None = None):
    """Monitor-wrapped envs; subprocesses (one per core) unless ``vec_env: dummy`` or a single env."""
    from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    n = cfg.n_envs if n_envs is None else n_envs
    subproc = cfg.vec_env == "subproc" and n > 1
    return sb3_make_vec_env(functools.partial(_make_env, cfg.env_id), n_envs=n, seed=seed, env_kwargs=cfg.env_kwargs,
                            vec_env_cls=SubprocVecEnv if subproc else DummyVecEnv,
                            vec_env_kwargs={"start_method": "forkserver"} if subproc else None)


def _make_env(env_id: str, **kwargs):
    """One env in a worker process: a forkserver worker has imported only what ``__main__`` imports, so the
    dresspack ids are registered here (training started from pytest or a notebook finds them too)."""
    import gymnasium as gym

    import dresspack_gym  # noqa: F401  (registers the env ids)

    return gym.make(env_id, **kwargs)


def _new_model(cfg: TrainConfig, env, tb_dir: Path):
    import torch
    from sb3_contrib import MaskablePPO

    act = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[cfg.activation]
    p = cfg.ppo
    return MaskablePPO("MlpPolicy", env, learning_rate=p.learning_rate, n_steps=p.n_steps, batch_size=p.batch_size,
                       n_epochs=p.n_epochs, gamma=p.gamma, gae_lambda=p.gae_lambda, clip_range=p.clip_range,
                       ent_coef=p.ent_coef, vf_coef=p.vf_coef, max_grad_norm=p.max_grad_norm,
                       policy_kwargs={"net_arch": list(cfg.net_arch), "activation_fn": act},
                       tensorboard_log=str(tb_dir), seed=cfg.seed, device="cpu", verbose=0)


def train(cfg: TrainConfig, run_dir: Path, *, resume: bool = False, progress: bool = True,
          command: str | None = None) -> dict:
    """Train (or continue) the run in ``run_dir``; returns the summary written to ``summary.json``."""
    import torch
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback

    from .callbacks import EpisodeMetricsCallback, ProgressBarCallback
    from .eval_callback import HeldOutEvalCallback

    torch.set_num_threads(1)  # the env subprocesses need the cores; a small MLP gains nothing from threads
    run_dir.mkdir(parents=True, exist_ok=True)
    ckpt_dir = run_dir / "checkpoints"
    ckpt = resume_point(run_dir) if resume else None
    if not resume and ckpt_dir.exists() and any(ckpt_dir.iterdir()):
        raise ConfigError("run_dir", f"{run_dir} already holds checkpoints: continue it with --resume {run_dir} "
                                     "or choose another --run-dir")
    (run_dir / "config.yaml").write_text(yaml.safe_dump(cfg.to_dict(), sort_keys=False))
    with open(run_dir / "command.txt", "a") as f:
        f.write((command or shlex.join(sys.argv)) + "\n")
    (run_dir / "versions.json").write_text(json.dumps(_versions(), indent=2) + "\n")

    env = make_vec_env(cfg, seed=cfg.seed)
    if ckpt is not None:
        model = MaskablePPO.load(ckpt, env=env, device="cpu", tensorboard_log=str(run_dir / "tb"))
        print(f"resuming from {ckpt} at {model.num_timesteps} steps", file=sys.stderr)
    else:
        model = _new_model(cfg, env, run_dir / "tb")
    start_steps = model.num_timesteps
    callbacks = [EpisodeMetricsCallback(),
                 CheckpointCallback(max(1, cfg.checkpoint_every // cfg.n_envs), str(ckpt_dir), CHECKPOINT_PREFIX)]
    eval_env = None
    warnings.filterwarnings("ignore", message="Training and eval env are not of the same type")
    if cfg.eval_every > 0:
        eval_env = make_vec_env(cfg, seed=cfg.eval_seed, n_envs=1)
        callbacks.append(HeldOutEvalCallback(eval_env, n_eval_episodes=cfg.eval_episodes,
                                             eval_freq=max(1, cfg.eval_every // cfg.n_envs),
                                             best_model_save_path=str(run_dir / "best"),
                                             log_path=str(run_dir / "eval"), deterministic=True, verbose=0,
                                             best_by=cfg.best_by, eval_seed=cfg.eval_seed))
    if progress:  # PPO collects whole rollouts, so the run ends on a rollout boundary
        per_rollout = cfg.ppo.n_steps * cfg.n_envs
        callbacks.append(ProgressBarCallback(-(-cfg.total_timesteps // per_rollout) * per_rollout))
    remaining = cfg.total_timesteps - start_steps
    # Ctrl-C and SIGTERM (a job scheduler's stop) both end in a checkpoint, even when the shell started us with
    # SIGINT ignored (background jobs)
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _interrupt)
    t0 = time.perf_counter()
    interrupted = False
    try:
        if remaining > 0:
            model.learn(remaining, callback=CallbackList(callbacks), reset_num_timesteps=ckpt is None,
                        tb_log_name="MaskablePPO")
    except KeyboardInterrupt:
        interrupted = True
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        wall = time.perf_counter() - t0
        if interrupted:
            path = ckpt_dir / f"{CHECKPOINT_PREFIX}_{model.num_timesteps}_steps.zip"
            ckpt_dir.mkdir(parents=True, exist_ok=True)
            model.save(path)
            print(f"\ninterrupted: saved {path}; continue with: dresspack train --resume {run_dir}", file=sys.stderr)
        for e in (env, eval_env):
            if e is not None:
                close_vec_env(e)
    if not interrupted:
        model.save(run_dir / "final_model.zip")
    steps = model.num_timesteps - start_steps
    summary = _summary(run_dir, cfg, model.num_timesteps, steps, wall, interrupted)
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if interrupted:
        raise KeyboardInterrupt
    return summary


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def _summary(run_dir: Path, cfg: TrainConfig, total_steps: int, steps: int, wall: float, interrupted: bool) -> dict:
    previous = {}
    if (run_dir / "summary.json").is_file():
        previous = json.loads((run_dir / "summary.json").read_text())
    s = {"name": cfg.name, "timesteps": total_steps, "interrupted": interrupted,
         "wall_time_s": round(previous.get("wall_time_s", 0.0) + wall, 1),
         "last_session": {"steps": steps, "wall_time_s": round(wall, 1),
                          "steps_per_s": round(steps / wall, 1) if wall > 0 else None}}
    evals = run_dir / "eval" / "evaluations.npz"
    if evals.is_file():
        import numpy as np

        data = np.load(evals)
        s["evaluations"] = {"timesteps": data["timesteps"].tolist(),
                            "mean_reward": data["results"].mean(axis=1).round(3).tolist()}
        if "successes" in data and len(data["successes"]):
            s["evaluations"]["success_rate"] = data["successes"].mean(axis=1).round(3).tolist()
    best = run_dir / "best" / "best.json"
    if best.is_file():
        s["best"] = json.loads(best.read_text())
    return s


CLOSE_TIMEOUT = 20.0  # [s] for the env subprocesses to finish their step and exit after an interrupt


def close_vec_env(env, timeout: float = CLOSE_TIMEOUT) -> None:
    """Close a vector env without ever hanging: an interrupt that lands while one worker answers and another
    settles can leave ``SubprocVecEnv.close()`` waiting on a pipe forever, so close in a thread and terminate the
    workers that have not exited by ``timeout``."""
    import threading

    def close():
        try:
            env.close()
        except (EOFError, BrokenPipeError, ConnectionError, OSError):
            pass  # workers already stopped by the same Ctrl-C

    t = threading.Thread(target=close, daemon=True)
    t.start()
    t.join(timeout)
    for proc in getattr(env, "processes", []):
        proc.join(timeout=0 if t.is_alive() else 1.0)
        if proc.is_alive():
            proc.terminate()
            proc.join(timeout=5.0)
            if proc.is_alive():
                proc.kill()


def _finished(run_dir: Path) -> bool:
    return (run_dir / "final_model.zip").is_file()


def resolve_run(args) -> tuple[TrainConfig, Path, bool]:
    """(config, run folder, resume) from the command line, every input checked before anything is written."""
    overrides = {"total_timesteps": args.total_timesteps, "n_envs": args.n_envs, "seed": args.seed}
    if args.resume:
        if getattr(args, "physics_profile", None) is not None:
            raise ConfigError("--physics-profile", "a resumed run keeps the profile in its config.yaml; give it to a "
                                                   "new run")
        run_dir = Path(args.resume)
        path = run_dir / "config.yaml"
        if not path.is_file():
            raise ConfigError("--resume", f"{run_dir} is not a run folder (no config.yaml)")
        try:
            cfg = train_config_from_dict(apply_overrides(read_yaml(path, "--resume"), **overrides))
        except ConfigError as exc:
            raise ConfigError("--resume", f"{path} is not a valid training config: {exc}") from None
        if _finished(run_dir) and args.total_timesteps is None:
            raise ConfigError("--resume", f"{run_dir} is a finished run (final_model.zip); give a larger "
                                          "--total-timesteps to continue it")
        return cfg, run_dir, True
    if not args.config:
        raise ConfigError("config", "give a training config (e.g. stud_welding) or --resume RUN_DIR")
    path = find_shipped(args.config, "training", "config")
    data = read_yaml(path, "config")
    data.setdefault("name", path.stem)
    if getattr(args, "physics_profile", None) is not None:
        data["env_kwargs"] = {**(data.get("env_kwargs") or {}), "physics_profile": args.physics_profile}
    cfg = train_config_from_dict(apply_overrides(data, **overrides), default_name=path.stem)
    run_dir = Path(args.run_dir) if args.run_dir else Path("runs") / "train" / cfg.name
    if run_dir.exists() and not run_dir.is_dir():
        raise ConfigError("--run-dir", f"{run_dir} is an existing file: give a folder")
    begun = run_dir.is_dir() and any((run_dir / k).exists() for k in ("final_model.zip", "checkpoints",
                                                                        "summary.json"))
    if begun and not args.force:
        what = "a finished run" if _finished(run_dir) else "a begun run"
        raise ConfigError("--run-dir", f"{run_dir} holds {what}: continue it with --resume {run_dir}, choose "
                                       "another --run-dir, or replace it with --force")
    return cfg, run_dir, False


def cmd_train(args) -> int:
    try:
        cfg, run_dir, resume = resolve_run(args)
        check_env_kwargs(cfg)
        if args.force and not resume and run_dir.is_dir():
            import shutil

            shutil.rmtree(run_dir)  # asked for: the old run is replaced, never mixed with the new one
        summary = train(cfg, run_dir, resume=resume, progress=not args.no_progress)
    except KeyboardInterrupt:
        return 130
    except DresspackError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(summary, indent=2))
    print(f"run folder: {run_dir}  (tensorboard --logdir {run_dir / 'tb'})")
    return 0


def main(argv: list[str] | None = None) -> int:
    """The ``dresspack-train`` executable, kept for one release: ``dresspack train`` with the same arguments."""
    from dresspack_gym.cli.main import main as dresspack_main

    warn_deprecated("dresspack-train is deprecated; use dresspack train")
    return dresspack_main(["train", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
