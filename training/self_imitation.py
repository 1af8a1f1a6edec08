"""``dresspack self-imitate POLICY``: a trained policy's best of several rollouts per episode, imitated (one round of
expert iteration): the policy's own sampled rollouts that beat its most probable one become its targets."""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import shlex
import sys
from pathlib import Path

import numpy as np
import yaml

from dresspack_gym.cli.args import number, seed
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.artefacts import read_json
from dresspack_gym.io.provenance import code_fingerprint

# Episode k resets the env with seed + k: apart from the training envs' seeds (seed, seed + 1, ...), the callback's
# (10,000), select-model's (20,000) and the evaluation's weld draws (1,000,000).
IMITATION_SEED = 30_000
IMITATION_EPISODES = 240
SAMPLES = 8  # rollouts per episode: the most probable actions, then sampled ones
EPOCHS = 4
LEARNING_RATE = 3e-5  # a tenth of PPO's: the fine-tune moves the policy toward its best rollouts, not away from itself
BATCH_SIZE = 64
MAX_EPISODES = 5000


def _episode(job) -> dict:
    """Roll the policy out ``samples`` times on one episode (first with the most probable actions, then sampled,
    torch seeded by the episode's seed); returns every rollout's figures and the best finishing rollout's
    observations, masks and actions (the highest return: the objective the policy was trained on)."""
    import gymnasium as gym
    import torch
    from sb3_contrib import MaskablePPO

    import dresspack_gym  # noqa: F401  (registers the env ids)

    from .rollouts import roll_out

    model_path, env_id, env_kwargs, episode_seed, samples = job
    torch.set_num_threads(1)  # one process per core
    env = gym.make(env_id, **env_kwargs).unwrapped
    model = MaskablePPO.load(model_path, device="cpu")
    torch.manual_seed(episode_seed)
    rollouts, best = [], None
    for k in range(samples):
        total, wear, info, seen = roll_out(env, model, episode_seed, deterministic=k == 0, record=True)
        row = {"return": total, "success": bool(info["is_success"]), "cycle_time": info.get("cycle_time"),
               "integral_cost": wear, "steps": len(seen)}
        rollouts.append(row)
        if row["success"] and (best is None or total > rollouts[best[0]]["return"]):
            best = (k, seen)
    env.close()
    out = {"seed": episode_seed, "rollouts": rollouts, "best": None if best is None else best[0]}
    if best is not None:
        obs, masks, actions = zip(*best[1])
        out["data"] = (np.array(obs, dtype=np.float32), np.array(masks, dtype=bool), np.array(actions, dtype=np.int64))
    return out


def collect(model_path: Path, config: dict, out: Path, *, episodes: int, samples: int, first_seed: int,
            jobs: int = 1, progress=print) -> list[dict]:
    """Every episode's rollouts, written as they finish (``rollouts.jsonl``, ``episodes/<seed>.npz``): an
    interrupted collection resumes where it stopped."""
    log, folder = out / "rollouts.jsonl", out / "episodes"
    folder.mkdir(parents=True, exist_ok=True)
    done = {row["seed"]: row for row in _read_log(log)}
    seeds = [first_seed + k for k in range(episodes)]
    todo = [(str(model_path), config["env_id"], dict(config.get("env_kwargs") or {}), s, samples)
            for s in seeds if s not in done]
    if todo:
        progress(f"rolling out {len(todo)} episodes x {samples} (seeds {first_seed}..{seeds[-1]}), {jobs} at a time")
    pool = multiprocessing.get_context("forkserver").Pool(min(jobs, len(todo))) if jobs > 1 and len(todo) > 1 else None
    with pool or contextlib.nullcontext():
        for n, result in enumerate((pool.imap if pool else map)(_episode, todo), 1):
            data = result.pop("data", None)
            if data is not None:  # the data first: a row in the log means its episode is complete
                np.savez(folder / f"{result['seed']}.npz", obs=data[0], masks=data[1], actions=data[2])
            with log.open("a") as f:
                f.write(json.dumps(result) + "\n")
            done[result["seed"]] = result
            if n % 10 == 0 or n == len(todo):
                progress(f"  {n}/{len(todo)} episodes")
    return [done[s] for s in seeds]


def _read_log(log: Path) -> list[dict]:
    """The log's complete rows. A row cut short by an interrupt (only the last can be) is dropped from the file
    too, so the rows appended on resume start on a line of their own."""
    if not log.is_file():
        return []
    rows, lines = [], log.read_text().splitlines()
    for line in lines:
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            break
    if len(rows) < len(lines) or not log.read_text().endswith("\n"):
        log.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return rows


def fit(model_path: Path, rows: list[dict], out: Path, *, epochs: int, learning_rate: float, batch_size: int,
        fit_seed: int) -> dict:
    """Fine-tune the policy's actor on the best rollouts (masked cross-entropy; the value network is untouched)
    and save it as ``out/model.zip``."""
    import torch
    from sb3_contrib import MaskablePPO

    torch.set_num_threads(1)
    torch.manual_seed(fit_seed)
    arrays = [np.load(out / "episodes" / f"{r['seed']}.npz") for r in rows if r["best"] is not None]
    if not arrays:
        raise ConfigError("episodes", "no rollout of any episode finished: nothing to imitate")
    obs = torch.as_tensor(np.concatenate([a["obs"] for a in arrays]))
    masks = np.concatenate([a["masks"] for a in arrays])
    actions = torch.as_tensor(np.concatenate([a["actions"] for a in arrays]))
    model = MaskablePPO.load(model_path, device="cpu")
    policy = model.policy
    actor = [p for name, p in policy.named_parameters()
             if not name.startswith(("mlp_extractor.value_net", "value_net"))]
    optimizer = torch.optim.Adam(actor, lr=learning_rate)
    rng = np.random.default_rng(fit_seed)
    losses = []

    def loss_of(index) -> torch.Tensor:
        dist = policy.get_distribution(obs[index], action_masks=masks[index])
        return -dist.log_prob(actions[index]).mean()

    policy.set_training_mode(False)
    with torch.no_grad():
        losses.append(float(loss_of(np.arange(len(actions)))))
    for _ in range(epochs):
        for batch in np.array_split(rng.permutation(len(actions)), max(1, len(actions) // batch_size)):
            loss = loss_of(batch)
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
        with torch.no_grad():
            losses.append(float(loss_of(np.arange(len(actions)))))
    model.save(out / "model.zip")
    return {"samples": len(actions), "episodes": len(arrays), "loss_by_epoch": losses}


def self_imitate(policy: str | Path, out: str | Path, *, episodes: int = IMITATION_EPISODES, samples: int = SAMPLES,
                 first_seed: int = IMITATION_SEED, epochs: int = EPOCHS, learning_rate: float = LEARNING_RATE,
                 batch_size: int = BATCH_SIZE, jobs: int = 1, progress=print) -> dict:
    """Collect (resumable), fit, and write ``out/`` as a policy folder (model.zip, config.yaml) with
    ``self_imitation.json`` (the settings, the rollouts' figures and the fit's losses)."""
    from dresspack.agents.learned.policy import resolve_policy

    from .config import check_env_kwargs, train_config_from_dict
    from .rollouts import ROLLOUT_CODE

    model_path, config = resolve_policy(policy)
    # the policy's training config read and its env built here, as training reads them: a bad field is refused
    # by name before any rollout, not inside a worker
    check_env_kwargs(train_config_from_dict(config))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    settings = {"policy": str(model_path), "episodes": episodes, "samples": samples, "first_seed": first_seed,
                "epochs": epochs, "learning_rate": learning_rate, "batch_size": batch_size,
                "code": code_fingerprint(ROLLOUT_CODE)}
    spec = out / "spec.json"
    if spec.is_file():  # resuming: the rollouts on disk must be the ones these settings make
        old = read_json(spec, "--out", "self-imitation spec (spec.json)",
                        recover=f"give another --out, or delete {out} to start over")
        keys = ("policy", "samples", "first_seed", "code")
        changed = [k for k in keys if old.get(k) != settings[k]]
        if changed:
            raise ConfigError(changed[0], f"{out} was collected with {changed[0]}={old.get(changed[0])!r}, not "
                                          f"{settings[changed[0]]!r}: use another --out folder")
    spec.write_text(json.dumps(settings, indent=2) + "\n")
    rows = collect(model_path, config, out, episodes=episodes, samples=samples, first_seed=first_seed, jobs=jobs,
                   progress=progress)
    fitted = fit(model_path, rows, out, epochs=epochs, learning_rate=learning_rate, batch_size=batch_size,
                 fit_seed=first_seed)
    # the base policy's training config (its env is this policy's), headed by where the model came from
    (out / "config.yaml").write_text(f"# model.zip: `dresspack self-imitate` of {model_path} (self_imitation.json)\n"
                                     + yaml.safe_dump(config, sort_keys=False))
    summary = {**settings, **_figures(rows), "fit": fitted}
    (out / "self_imitation.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def _figures(rows: list[dict]) -> dict:
    """How much the best rollout beats the most probable one: success, mean return, and on the episodes both
    finish, mean cycle time and ∫C dt."""
    first = [r["rollouts"][0] for r in rows]
    best = [r["rollouts"][r["best"]] if r["best"] is not None else r["rollouts"][0] for r in rows]
    both = [(a, b) for a, b in zip(first, best) if a["success"] and b["success"]]

    def mean(xs):
        return float(np.mean(xs)) if xs else None

    return {"argmax_success_rate": mean([a["success"] for a in first]),
            "best_success_rate": mean([b["success"] for b in best]),
            "argmax_mean_return": mean([a["return"] for a in first]),
            "best_mean_return": mean([b["return"] for b in best]),
            "both_finished": len(both),
            "argmax_cycle_time": mean([a["cycle_time"] for a, _ in both]),
            "best_cycle_time": mean([b["cycle_time"] for _, b in both]),
            "argmax_integral_cost": mean([a["integral_cost"] for a, _ in both]),
            "best_integral_cost": mean([b["integral_cost"] for _, b in both])}


def add_self_imitate_command(sub) -> None:
    p = sub.add_parser("self-imitate",
                       help="fine-tune a policy on its own best rollouts (one round of expert iteration)",
                       description="Rolls POLICY out SAMPLES times on each of EPISODES training episodes (the most "
                                   "probable actions, then sampled ones), keeps each episode's best finishing "
                                   "rollout and fine-tunes the policy's actor on them. Resumable; OUT becomes a "
                                   "policy folder (--policy OUT).")
    p.add_argument("policy", help="shipped policy name, run folder or model .zip")
    p.add_argument("--out", required=True, help="folder for the rollouts and the fine-tuned policy")
    p.add_argument("--episodes", type=number(1, MAX_EPISODES, integer=True), default=IMITATION_EPISODES,
                   help=f"training episodes rolled out (default {IMITATION_EPISODES})")
    p.add_argument("--samples", type=number(2, 64, integer=True), default=SAMPLES,
                   help=f"rollouts per episode (default {SAMPLES})")
    p.add_argument("--seed", type=seed, default=IMITATION_SEED, help=f"first episode's seed (default {IMITATION_SEED})")
    p.add_argument("--epochs", type=number(0, 100, integer=True), default=EPOCHS,
                   help=f"passes of the fine-tune over the best rollouts' steps (default {EPOCHS}; 0: the policy "
                        "unchanged)")
    p.add_argument("--learning-rate", type=number(0.0, 1.0, lo_open=True), default=LEARNING_RATE,
                   help=f"the fine-tune's Adam learning rate (default {LEARNING_RATE:g})")
    p.add_argument("--jobs", type=number(1, 64, integer=True), default=1,
                   help="processes collecting the rollouts (one per core; default 1)")
    p.set_defaults(func=cmd_self_imitate)


def cmd_self_imitate(args) -> int:
    try:
        summary = self_imitate(args.policy, args.out, episodes=args.episodes, samples=args.samples,
                               first_seed=args.seed, epochs=args.epochs, learning_rate=args.learning_rate,
                               jobs=args.jobs)
    except KeyboardInterrupt:
        log = Path(args.out) / "rollouts.jsonl"
        saved = len(_read_log(log)) if log.is_file() else 0
        print(f"\ninterrupted: {saved} episodes' rollouts saved in {log}; resume with: dresspack "
              f"{shlex.join(args.argv)}", file=sys.stderr)
        return 130
    print(f"argmax: success {100 * summary['argmax_success_rate']:.1f} %, return {summary['argmax_mean_return']:.2f}; "
          f"best of {summary['samples']}: success {100 * summary['best_success_rate']:.1f} %, return "
          f"{summary['best_mean_return']:.2f}; on the {summary['both_finished']} both finish, ∫C "
          f"{summary['argmax_integral_cost']:.1f} -> {summary['best_integral_cost']:.1f}, cycle "
          f"{summary['argmax_cycle_time']:.2f} -> {summary['best_cycle_time']:.2f} s")
    loss = " -> ".join(f"{x:.3f}" for x in summary["fit"]["loss_by_epoch"])
    print(f"fit on {summary['fit']['samples']} steps: loss {loss}; policy folder {args.out}")
    return 0
