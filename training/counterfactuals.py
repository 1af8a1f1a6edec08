"""``dresspack counterfactuals``: every unmasked action simulated from each state a policy visits, as cost labels.

    dresspack counterfactuals --config configs/training/cost_model.yaml --out runs/cost/data --jobs 2
    dresspack counterfactuals --out runs/cost/data --backend ray --ray-address auto --jobs 64   # on a Ray cluster

The policy rolls out on drawn episodes; at each state it visits, every allowed action is stepped from a snapshot
(restored after each) and one row per action records the observation, the action, its target configuration, the
step's time [s] and wear integral ∫C dt (unscaled, uncapped), whether it reached the goal and the policy's
probability of it. With ``continued: K`` the policy's K most probable moves (ppo-search's proposals) are also
continued by its most probable actions to the episode's end: their rows hold the cost to go (the step's and the
continuation's time + ∫C dt, a cost-to-go label) and whether the continuation finished; ``every_action: false``
keeps only those rows. Episode k is seeded
from (seed, k) alone, so the labels do not depend on the number of processes. Output folder: ``spec.json`` (the
settings the shards were made with), ``episodes/ep_<k>.npz`` (one shard per finished episode: a resumed run skips
them) and ``summary.json`` (rows, and each session's labels per minute).
"""

from __future__ import annotations

import contextlib
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from dresspack_gym.cli.args import ALL_CORES, MAX_JOBS, number, output_dir
from dresspack_gym.errors import ConfigError
from dresspack_gym.fields import check_choice
from dresspack_gym.io.artefacts import read_json, read_npz
from dresspack_gym.io.outputs import output_folder, replacing, write_text
from dresspack_gym.io.provenance import code_fingerprint, file_digest, library_versions
from dresspack_gym.process_pool import spawn_pool

from .cost_config import MAX_EPISODES, CostStudyConfig, CounterfactualConfig, load_cost_config
from .rollouts import ROLLOUT_CODE

# the settings that decide the labels: a resumed run must match them (episodes may grow, jobs may change)
SPEC_FIELDS = ("policy", "seed", "rollout", "cost_to_go", "continued", "every_action", "env_kwargs")
WEAR_PARTS = ("curvature", "tension", "distance", "twist", "damage")
BACKENDS = ("process", "ray")  # where the episodes run: processes on this machine, or Ray actors

# the libraries whose arithmetic the labels depend on: the cable physics, the policy's and the cost-to-go model's
# networks, the time law (either MuJoCo distribution; one is not installed)
LIBRARIES = ("mujoco-core", "mujoco", "numpy", "torch", "stable-baselines3", "sb3-contrib", "ruckig", "gymnasium")

_worker: dict = {}  # the process's env, policy and ranked rule, built once by _init_worker


def episode_seed(seed: int, index: int) -> int:
    """The reset (and torch) seed of episode ``index``: a function of (seed, index) only."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


def policy_env(cfg: CounterfactualConfig) -> tuple[Path, str, dict]:
    """(model file, env id, env kwargs): the policy's training env with the config's episode overrides."""
    from dresspack.agents.learned.policy import resolve_policy

    model_path, train_cfg = resolve_policy(cfg.policy)
    env_kwargs = {**(train_cfg.get("env_kwargs") or {}), **cfg.env_kwargs}
    return model_path, train_cfg.get("env_id", "dresspack_gym/StudWelding-v0"), env_kwargs


def _init_worker(model_path: str, env_id: str, env_kwargs: dict, cost_to_go: str | None = None) -> None:
    import gymnasium as gym
    import torch
    from dresspack.agents.learned.policy import PolicyAgent
    from dresspack.agents.learned.search import PROPOSALS, RankedChooser, load_cost_to_go

    import dresspack_gym  # noqa: F401  (registers the env ids in a spawned process)

    torch.set_num_threads(1)  # one process per core
    _worker["env"] = gym.make(env_id, **env_kwargs).unwrapped
    _worker["agent"] = PolicyAgent(Path(model_path))
    _worker["chooser"] = None if cost_to_go is None else RankedChooser(
        load_cost_to_go(cost_to_go, _worker["agent"].n_actions), PROPOSALS)


def counterfactual_rows(env, state_obs: np.ndarray, masks: np.ndarray, keep: int | None = None,
                        probs: np.ndarray | None = None, continued=(), agent=None,
                        every_action: bool = True) -> tuple[list[dict], tuple | None]:
    """Step every allowed action (or, without ``every_action``, those ``continued``) from where ``env`` stands,
    restoring it after each; returns one row per action and, for action ``keep``, the snapshot and step result
    after it (the episode continues from there without stepping that action again). ``probs``: the policy's
    probability of each action; ``continued``: actions whose rows also get a cost to go, continued by ``agent``
    to the episode's end."""
    snap, q = env.snapshot(), env.q
    reached_before = env.goal_index
    continued = set(continued)
    rows, kept = [], None
    actions = np.flatnonzero(masks) if every_action else sorted(set(continued) | ({keep} - {None}))
    for a in actions:
        a = int(a)
        target = env.target(q, a)
        if a == keep or a in continued:  # the episode or a continuation goes on from here: it needs the observation
            result = env.step(a)
            terminated, info = result[2], result[4]
        else:
            _, terminated, _, info = env.step_outcome(a)
        cost = info["step_time"] + info["integral_cost"]
        row = {"obs": state_obs, "action": a, "target": target, "q": q, "time": info["step_time"],
               "wear": info["integral_cost"],
               "wear_parts": [info[f"integral_cost_{k}"] for k in WEAR_PARTS],
               "reached": info["goals_reached"] > reached_before, "terminated": terminated,
               "prob": np.nan if probs is None else float(probs[a]), "to_go": np.nan, "to_go_finished": False,
               "proposal": a in continued, "settled": _settled(info, reached_before), "to_go_settled": True}
        if a == keep:
            kept = (env.snapshot(), result)
        if a in continued:
            row["to_go"], row["to_go_finished"], settled = continue_greedily(env, agent, result, cost)
            row["to_go_settled"] = row["settled"] and settled
        if every_action or a in continued:
            rows.append(row)
        env.restore(snap)
    return rows, kept


def continue_greedily(env, agent, result: tuple, cost: float) -> tuple[float, bool, bool]:
    """From the state a step left ``env`` in (``result``, its ``cost``): the policy's most probable moves to the
    episode's end, as ppo-search continues a proposal; returns (time + ∫C dt of the step and the continuation,
    whether it finished the task, whether every settle at a goal on the way converged)."""
    from dresspack.agents.learned.policy import moving_masks

    obs, _, terminated, truncated, info = result
    total, settled = cost, True
    while not (terminated or truncated):
        action, before = agent.predict(obs, moving_masks(env, env.action_masks()), deterministic=True), env.goal_index
        obs, _, terminated, truncated, info = env.step(action)
        total += info["step_time"] + info["integral_cost"]
        settled = settled and _settled(info, before)
    return total, bool(terminated and info["is_success"]), settled


def _settled(info: dict, goals_before: int) -> bool:
    """Whether a step's wear was read from a cable at rest where it had to be: a step that reached a goal settles
    there to equilibrium (false if that settle ended above the residual); other steps are not held to it."""
    return bool(info["settle_converged"]) if info["goals_reached"] > goals_before else True


def run_episode(env, agent, index: int, seed: int, rollout: str, continued: int = 0,
                every_action: bool = True, chooser=None) -> dict:
    """One episode: the policy's rollout from episode ``index``'s seed (``rollout``: its most probable actions, its
    sampled ones, or those of ``chooser``, ppo-search's ranked rule), with every state's counterfactuals (and the
    cost to go of the policy's ``continued`` most probable moves)."""
    import torch
    from dresspack.agents.learned.policy import moving_masks
    from dresspack.agents.learned.search import ranked_proposals

    s = episode_seed(seed, index)
    torch.manual_seed(s)
    obs, _ = env.reset(seed=s)
    if rollout == "ranked":
        chooser.reset()
    rows, done, step, total, info = [], False, 0, 0.0, {}
    while not done:
        masks = env.action_masks()
        probs = agent.probabilities(obs, masks)
        # ranked as the search ranks them: by the policy's probabilities, less the moves to where the robot stands
        moving = moving_masks(env, masks)
        proposals = ranked_proposals(probs, moving, env.stay_action, continued) if continued else []
        if rollout == "ranked":
            action = chooser.choose(env, obs, probs, moving)
        else:  # a sampled action is drawn before any counterfactual: torch's generator is where it was without them
            action = agent.predict(obs, masks, deterministic=rollout == "argmax")
        state_rows, (snap, (obs, reward, terminated, truncated, info)) = counterfactual_rows(
            env, obs, masks, action, probs, proposals, agent, every_action)
        for r in state_rows:
            r.update(step=step, chosen=r["action"] == action)
        rows += state_rows
        env.restore(snap)
        total, done, step = total + reward, terminated or truncated, step + 1
    return {"index": index, "seed": s, "rows": rows, "success": bool(info.get("is_success", False)),
            "return": total, "states": step}


def _episode_job(job: tuple) -> dict:
    index, seed, rollout, continued, every_action = job
    return run_episode(_worker["env"], _worker["agent"], index, seed, rollout, continued, every_action,
                       _worker["chooser"])


def shard_arrays(result: dict) -> dict[str, np.ndarray]:
    """An episode's rows as arrays (one entry per row), as written to its shard."""
    rows = result["rows"]
    col = lambda k, dtype: np.array([r[k] for r in rows], dtype=dtype)  # noqa: E731
    n = len(rows)
    return {"obs": col("obs", np.float32), "action": col("action", np.int64), "target": col("target", np.float64),
            "q": col("q", np.float64), "time": col("time", np.float64), "wear": col("wear", np.float64),
            "wear_parts": col("wear_parts", np.float64).reshape(n, len(WEAR_PARTS)),
            "reached": col("reached", bool), "terminated": col("terminated", bool), "chosen": col("chosen", bool),
            "prob": col("prob", np.float64), "to_go": col("to_go", np.float64),
            "to_go_finished": col("to_go_finished", bool), "proposal": col("proposal", bool),
            "settled": col("settled", bool), "to_go_settled": col("to_go_settled", bool),
            "step": col("step", np.int64), "episode": np.full(n, result["index"], dtype=np.int64),
            "episode_seed": np.array(result["seed"], dtype=np.int64),
            "episode_success": np.array(result["success"]), "episode_return": np.array(result["return"])}


def shard_path(out: Path, index: int) -> Path:
    return out / "episodes" / f"ep_{index:06d}.npz"


def generate(cfg: CounterfactualConfig, out: str | Path, *, jobs: int = 1, progress: bool = True,
             max_minutes: float | None = None, backend: str = "process", ray_address: str | None = None) -> dict:
    """Write the shards of episodes 0 .. cfg.episodes - 1 not yet in ``out`` (resumable); returns the summary.
    With ``max_minutes`` no episode is written after that much wall time (those under way are dropped: a later
    run with the same settings makes them). ``backend``: ``process`` (``jobs`` processes here) or ``ray`` (``jobs``
    Ray actors, at ``ray_address`` or on this machine); the labels are the same either way."""
    from tqdm.auto import tqdm

    check_choice("backend", backend, BACKENDS)
    if backend == "ray":
        from dresspack_gym.ray_pool import require_ray

        require_ray()

    out = Path(out)
    spec = {k: getattr(cfg, k) for k in SPEC_FIELDS}
    model_path, env_id, env_kwargs = policy_env(cfg)
    spec["policy_file"] = str(model_path.resolve())
    spec["policy_digest"] = file_digest(model_path)
    cost_to_go = None if cfg.cost_to_go is None else _cost_to_go_file(cfg.cost_to_go, model_path)
    spec["cost_to_go_file"] = None if cost_to_go is None else str(cost_to_go.resolve())
    spec["cost_to_go_digest"] = None if cost_to_go is None else file_digest(cost_to_go)
    spec["code"] = code_fingerprint(ROLLOUT_CODE)
    spec["libraries"] = library_versions(LIBRARIES)
    spec_file = out / "spec.json"
    if spec_file.is_file():
        old = read_json(spec_file, "--out", "counterfactual data spec (spec.json)",
                        recover=f"give another --out, or delete {out} to start over")
        for k in ("libraries", "policy_digest"):  # written before these were recorded
            old.setdefault(k, spec[k])
        changed = [k for k in (*SPEC_FIELDS, "policy_file", "policy_digest", "cost_to_go_digest", "code", "libraries")
                   if old.get(k) != spec[k]]
        if changed:
            raise ConfigError(f"counterfactuals.{changed[0]}",
                              f"{out} holds labels made with {changed[0]}={old.get(changed[0])!r}, not "
                              f"{spec[changed[0]]!r}: use another --out folder")
    load_counterfactuals(out, field="--out")  # a damaged shard is found now, not after the new episodes
    (out / "episodes").mkdir(parents=True, exist_ok=True)
    write_text(spec_file, json.dumps(spec, indent=2) + "\n")
    todo = [(k, cfg.seed, cfg.rollout, cfg.continued, cfg.every_action) for k in range(cfg.episodes)
            if not shard_path(out, k).is_file()]
    jobs = max(1, min(jobs, len(todo)))
    init = (str(model_path), env_id, env_kwargs, None if cost_to_go is None else str(cost_to_go))
    # a wrong env argument fails here, naming the field, not inside a worker (one process: its env is the check)
    if todo:
        _checked(_init_worker if jobs == 1 and backend == "process" else _check_env, *init)
    t0, cpu0, labels, written = time.perf_counter(), _cpu_time(), 0, 0
    bar = tqdm(total=cfg.episodes, initial=cfg.episodes - len(todo), unit="episode", desc="counterfactuals",
               disable=not progress or not todo, file=sys.stderr)
    pool = None
    if backend == "ray" and todo:
        from dresspack_gym.ray_pool import ray_imap_unordered

        results = ray_imap_unordered(_init_worker, init, _episode_job, todo, jobs, ray_address)
    elif jobs > 1:
        pool = spawn_pool(jobs, _init_worker, init)  # each worker builds its own MuJoCo model, torch and env
        results = pool.imap_unordered(_episode_job, todo)
    else:
        results = map(_episode_job, todo)
    with pool or contextlib.nullcontext(), bar:
        for result in results:
            arrays = shard_arrays(result)
            path = shard_path(out, result["index"])
            with replacing(path) as tmp:  # a shard on disk is always a whole episode
                np.savez(tmp, **arrays)
            labels, written = labels + len(result["rows"]), written + 1
            bar.update(1)
            bar.set_postfix(labels=labels)
            if max_minutes is not None and time.perf_counter() - t0 > 60.0 * max_minutes:
                break
        if pool is not None:
            pool.terminate()  # nothing is left to do but what a time budget cut short
            pool.join()  # the workers' CPU time counts once they are waited for
    wall, cpu = time.perf_counter() - t0, _cpu_time() - cpu0
    return _write_summary(out, written, labels, wall, cpu, jobs)


def _cost_to_go_file(ref: str, policy_file: Path) -> Path:
    """The ranked rollout's model file, checked (a cost-to-go model for this policy's actions), or a ConfigError
    naming the field."""
    from dresspack.agents.learned.policy import policy_actions
    from dresspack.agents.learned.search import load_cost_to_go, resolve_cost_to_go

    try:
        path = resolve_cost_to_go(ref, policy_file)
        load_cost_to_go(path, policy_actions(policy_file))
    except ConfigError as exc:
        raise ConfigError(f"counterfactuals.{exc.field}", str(exc).split(": ", 1)[-1]) from None
    return path


def _check_env(model_path: str, env_id: str, env_kwargs: dict, cost_to_go: str | None = None) -> None:
    import gymnasium as gym

    gym.make(env_id, **env_kwargs).close()


def _checked(build, *args) -> None:
    try:
        build(*args)
    except TypeError as exc:
        raise ConfigError("counterfactuals.env_kwargs", f"{exc}; see DresspackEnv's arguments") from None
    except ConfigError as exc:
        raise ConfigError(f"counterfactuals.env_kwargs.{exc.field}", str(exc).split(": ", 1)[-1]) from None


def _cpu_time() -> float:
    """CPU seconds of this process and its finished children: labels per CPU minute do not depend on what else
    runs on the machine, labels per wall minute do."""
    import resource

    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _write_summary(out: Path, episodes: int, labels: int, wall: float, cpu: float, jobs: int) -> dict:
    path = out / "summary.json"
    sessions = read_json(path, "--out", "counterfactual summary (summary.json)", keys=("sessions",),
                         recover=f"delete it: the next run writes it again from {out}/episodes")["sessions"] \
        if path.is_file() else []
    if episodes:
        sessions.append({"episodes": episodes, "labels": labels, "jobs": jobs, "wall_time_s": round(wall, 1),
                         "cpu_time_s": round(cpu, 1), "labels_per_min": round(60.0 * labels / wall, 1),
                         "labels_per_cpu_min": round(60.0 * labels / cpu, 1) if cpu > 0 else None})
    data = load_counterfactuals(out)
    summary = {"episodes": int(len(np.unique(data["episode"]))) if data else 0,
               "rows": int(len(data["action"])) if data else 0,
               "states": int(len(np.unique(np.stack([data["episode"], data["step"]]), axis=1)[0])) if data else 0,
               "sessions": sessions}
    write_text(path, json.dumps(summary, indent=2) + "\n")
    return summary


def load_counterfactuals(folder: str | Path, episodes: int | None = None, field: str = "--data"
                         ) -> dict[str, np.ndarray]:
    """Every shard's rows in episode order (the first ``episodes`` shards if given); empty dict if none. The
    policy's probabilities and the costs to go are read where every shard has them. A damaged shard is a
    ConfigError of ``field`` naming it and how to make it again."""
    paths = sorted((Path(folder) / "episodes").glob("ep_*[0-9].npz"))[:episodes]
    per_row = ("obs", "action", "target", "q", "time", "wear", "wear_parts", "reached", "terminated", "chosen",
               "step", "episode")
    shards = [read_npz(p, field, "counterfactual label shard (.npz)", keys=per_row,
                       recover=f"delete it and run `dresspack counterfactuals --out {folder}` again with the same "
                               "settings: it makes that episode again") for p in paths]
    if not shards:
        return {}
    later = [k for k in ("prob", "to_go", "to_go_finished", "proposal", "settled", "to_go_settled")
             if all(k in s for s in shards)]
    return {k: np.concatenate([s[k] for s in shards]) for k in (*per_row, *later)}


def load_label_folders(folders, episodes: int | None = None) -> tuple[dict[str, np.ndarray], list[dict]]:
    """The rows of several data folders of one policy (the first ``episodes`` shards of each), and each folder's
    spec.json. Folder k's episode ids are offset by k * MAX_EPISODES, so episodes of different folders never share
    an id (held-out splits and states stay apart); the first folder's ids are its own."""
    data, specs = [], []
    for k, folder in enumerate(folders):
        spec_file = Path(folder) / "spec.json"
        rows = load_counterfactuals(folder, episodes)
        if not rows or not spec_file.is_file():
            raise ConfigError("--data", f"{folder} holds no counterfactual shards (episodes/ep_*.npz, spec.json)")
        spec = read_json(spec_file, "--data", "counterfactual data spec (spec.json)", keys=("policy_file",))
        if specs and _policy_identity(spec) != _policy_identity(specs[0]):
            raise ConfigError("--data", f"{folder} holds labels of {spec['policy_file']}, {folders[0]} of "
                                        f"{specs[0]['policy_file']}: one model is fit to one policy's labels")
        rows["episode"] = rows["episode"] + k * MAX_EPISODES
        data.append(rows)
        specs.append(spec)
    shared = set.intersection(*(set(d) for d in data))  # columns later label formats added are read where all have them
    return {c: np.concatenate([d[c] for d in data]) for c in data[0] if c in shared}, specs


def _policy_identity(spec: dict) -> str:
    """Which policy a data folder's labels are of: its model file's digest (the same policy in another checkout
    is the same), the path where the spec predates digests and the file is gone."""
    path = Path(spec["policy_file"])
    return spec.get("policy_digest") or (file_digest(path) if path.is_file() else str(path))


def add_counterfactuals_command(sub) -> None:
    p = sub.add_parser("counterfactuals", help="simulate every allowed action from the states a policy visits "
                                               "(cost labels for the segment-cost model)",
                       description=__doc__.split("\n")[0] + " Resumable: finished episodes are skipped.")
    p.add_argument("--config", default="cost_model",
                   help="cost-model YAML (path, or a name in configs/training/; default cost_model)")
    p.add_argument("--out", type=output_dir, required=True,
                   help="data folder (episodes/ shards, spec.json, summary.json)")
    p.add_argument("--episodes", type=number(1, 100_000, integer=True),
                   help="episodes in all (default: the config's counterfactuals.episodes)")
    p.add_argument("--jobs", type=number(1, MAX_JOBS, integer=True), default=ALL_CORES,
                   help=f"worker processes; the labels are the same for any number (default {ALL_CORES}: all cores)")
    p.add_argument("--backend", choices=BACKENDS, default="process",
                   help="process: --jobs processes on this machine; ray: --jobs Ray actors (a cluster at "
                        "--ray-address, else this machine); the labels are the same (default: %(default)s)")
    p.add_argument("--ray-address", default=None, help="with --backend ray: the cluster's address (default: local)")
    p.add_argument("--max-minutes", type=number(0.0, None, lo_open=True),
                   help="write no episode after this much wall time (the same command continues later)")
    p.add_argument("--no-progress", action="store_true", help="draw no progress bar")
    p.set_defaults(func=cmd_counterfactuals)


def cmd_counterfactuals(args) -> int:
    from dataclasses import replace

    cfg: CostStudyConfig = load_cost_config(args.config)
    cf = cfg.counterfactuals if args.episodes is None else replace(cfg.counterfactuals, episodes=args.episodes)
    try:
        with output_folder(args.out):  # a refused start leaves no folder behind; an interrupted one its episodes
            summary = generate(cf, args.out, jobs=args.jobs, progress=not args.no_progress,
                               max_minutes=args.max_minutes, backend=args.backend, ray_address=args.ray_address)
    except KeyboardInterrupt:
        saved = len(list((Path(args.out) / "episodes").glob("ep_*[0-9].npz")))
        print(f"\ninterrupted: {saved} episodes saved in {Path(args.out) / 'episodes'}; resume with: dresspack "
              f"{shlex.join(args.argv)}", file=sys.stderr)
        return 130
    print(json.dumps(summary, indent=2))
    return 0
