"""Does imitating a beam search over its own actions teach the goal-conditioned policy to wear the cable less? The
teacher is ``action_set_bound.py``'s search (the planners' objective, time + ∫C dt, over the policy's masked actions
in its own training env), run on episodes of the policy's own task distribution; the policy's actor is then fitted
to the teacher's actions (``dresspack self-imitate``'s masked cross-entropy) and both policies are rolled out, most
probable actions first, on held-out episodes of the same distribution.

    PYTHONPATH=. .venv/bin/python scripts/studies/beam_imitation.py collect --episodes 40 --jobs 2 \
        --out runs/beam_teacher
    PYTHONPATH=. .venv/bin/python scripts/studies/beam_imitation.py fit --teacher runs/beam_teacher \
        --learning-rate 1e-4 --epochs 20 --out runs/beam_fit/1e-4_20 \
        --json docs/data/beam_imitation.json    # and 1e-3 20, 3e-4 10, 3e-5 20

Seeds: the teacher's episodes are 40000 + k (apart from the training, callback, select-model, self-imitate,
map-study and evaluation seeds). Both policies are judged as ``dresspack select-model`` judges a run's models, on
its 90 held-out episodes (seed 20000 + k), so the figures sit beside the README's self-imitation table.
``collect`` is resumable: an episode is logged in ``teacher.jsonl`` once its search, its replay and the policy's
own rollout on it are done. The search is bounded by env steps (``--beam``, ``--leg-steps``), so it gives the same
answer on any machine. Only episodes where the teacher beats the policy's most probable rollout on time + ∫C dt
(or the policy does not finish) are imitated.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from pathlib import Path
from types import SimpleNamespace

import numpy as np

TEACHER_SEED = 40000
SELECT_SEED = 20000  # select-model's held-out episodes (training/select.py)
LEG_STARTS, PATIENCE = 2, 2  # action_set_bound's defaults


def _teach(job) -> dict:
    """One episode: the policy's argmax rollout, the beam search, and the best sequence replayed from reset (its
    observations and masks, written to ``episodes/<seed>.npz``)."""
    import gymnasium as gym
    import torch
    from dresspack.agents.learned.policy import resolve_policy
    from dresspack.training.rollouts import roll_out
    from sb3_contrib import MaskablePPO

    import dresspack_gym  # noqa: F401  (registers the env ids)
    from scripts.action_set_bound import search_episode

    policy, seed, beam, leg_steps, out = job
    torch.set_num_threads(1)  # one process per core
    model_path, config = resolve_policy(policy)
    env = gym.make(config["env_id"], **config["env_kwargs"]).unwrapped
    model = MaskablePPO.load(model_path, device="cpu")
    total, wear, info, _ = roll_out(env, model, seed, deterministic=True)
    row = {"seed": seed, "policy": {"return": total, "success": bool(info["is_success"]),
                                    "cycle_time": info.get("cycle_time"), "wear": wear}}
    sim = env.station.config.simulation
    limits = env.station.config.robots[0].robot.joint_motion_limits.at_speed(sim.speed_fraction)
    env.reset(seed=seed)  # the env's own episode draw (the evaluation's tasks are action_set_bound's)
    best, _ = search_episode(env, limits, SimpleNamespace(beam=beam, leg_steps=leg_steps, leg_starts=LEG_STARTS,
                                                          patience=PATIENCE))
    row["found"] = best is not None
    if best is not None:
        seen, replay = replay_actions(env, seed, best.actions)
        if not (replay["success"] and abs(replay["wear"] - best.wear) <= 1e-6 * max(1.0, best.wear)):
            raise RuntimeError(f"episode {seed}: the replay of the searched actions differs from the search")
        o, m, a = zip(*seen)
        np.savez(Path(out) / "episodes" / f"{seed}.npz", obs=np.array(o, dtype=np.float32),
                 masks=np.array(m, dtype=bool), actions=np.array(a, dtype=np.int64))
        row.update(actions=[int(x) for x in best.actions], time=best.time, wear=best.wear, return_=replay["return"],
                   weld_settles=replay["weld_settles"])
    env.close()
    return row


def replay_actions(env, seed: int, actions) -> tuple[list, dict]:
    """``actions`` taken from ``env.reset(seed)``: each step's (observation, masks, action), and the return, ∫C dt,
    success and the settles at the welds (the env settles each to equilibrium: how many did not converge, and the
    largest residual left)."""
    obs, _ = env.reset(seed=seed)
    seen, ret, wear, residuals, unconverged = [], 0.0, 0.0, [], 0
    for a in actions:  # the env is deterministic: the replay is the searched sequence (the caller checks)
        masks = env.action_masks()
        seen.append((obs, masks, a))
        before = env.goal_index
        obs, reward, _, _, info = env.step(a)
        ret, wear = ret + reward, wear + info["integral_cost"]
        if env.goal_index > before:
            residuals.append(float(info["equilibrium_residual"]))
            unconverged += not info["settle_converged"]
    return seen, {"return": ret, "wear": wear, "success": bool(info["is_success"]),
                  "weld_settles": {"count": len(residuals), "unconverged": unconverged,
                                   "max_residual": max(residuals, default=float("nan"))}}


def collect(args) -> None:
    out = Path(args.out)
    (out / "episodes").mkdir(parents=True, exist_ok=True)
    settings = {"policy": args.policy, "beam": args.beam, "leg_steps": args.leg_steps}
    spec = out / "spec.json"
    if spec.is_file() and json.loads(spec.read_text()) != settings:  # resuming: the same search, or another folder
        raise SystemExit(f"{out} holds a teacher searched with {spec.read_text().strip()}: give another --out")
    spec.write_text(json.dumps(settings) + "\n")
    log = out / "teacher.jsonl"
    done = {json.loads(line)["seed"] for line in log.read_text().splitlines()} if log.is_file() else set()
    todo = [(args.policy, TEACHER_SEED + k, args.beam, args.leg_steps, str(out)) for k in range(args.episodes)
            if TEACHER_SEED + k not in done]
    pool = multiprocessing.get_context("forkserver").Pool(args.jobs) if args.jobs > 1 and len(todo) > 1 else None
    for row in (pool.imap_unordered if pool else map)(_teach, todo):
        with log.open("a") as f:
            f.write(json.dumps(row) + "\n")
        print(json.dumps({k: v for k, v in row.items() if k != "actions"}), flush=True)
    if pool:
        pool.close()


def _objective(r: dict) -> float:
    return r["cycle_time"] + r["wear"]


def fit_and_compare(args) -> None:
    import torch
    import yaml
    from dresspack.agents.learned.policy import resolve_policy
    from dresspack.training.self_imitation import fit

    torch.set_num_threads(1)
    teacher = Path(args.teacher)
    spec = teacher / "spec.json"
    if spec.is_file() and json.loads(spec.read_text())["policy"] != args.policy:
        raise SystemExit(f"{teacher} teaches {json.loads(spec.read_text())['policy']}, not {args.policy}")
    rows = [json.loads(line) for line in (teacher / "teacher.jsonl").read_text().splitlines()]
    rows.sort(key=lambda r: r["seed"])
    better = [r for r in rows if r["found"] and (not r["policy"]["success"] or r["time"] + r["wear"] < _objective(r["policy"]))]
    out = Path(args.out)
    (out / "episodes").mkdir(parents=True, exist_ok=True)
    for r in better:  # fit() reads out/episodes/<seed>.npz
        (out / "episodes" / f"{r['seed']}.npz").write_bytes((teacher / "episodes" / f"{r['seed']}.npz").read_bytes())
    model_path, config = resolve_policy(args.policy)
    fitted = fit(model_path, [{"seed": r["seed"], "best": 0} for r in better], out, epochs=args.epochs,
                 learning_rate=args.learning_rate, batch_size=args.batch_size, fit_seed=TEACHER_SEED)
    (out / "config.yaml").write_text(f"# model.zip: {args.policy} fitted to the beam teacher in {teacher}\n"
                                     + yaml.safe_dump(config, sort_keys=False))
    both = [r for r in rows if r["found"] and r["policy"]["success"]]
    summary = {"args": vars(args), "teacher_episodes": len(rows), "teacher_found": sum(r["found"] for r in rows),
               "teacher_better": len(better),
               "teacher_vs_policy_on_both": {
                   "episodes": len(both), "policy_wear": sum(r["policy"]["wear"] for r in both),
                   "teacher_wear": sum(r["wear"] for r in both),
                   "policy_time": sum(r["policy"]["cycle_time"] for r in both),
                   "teacher_time": sum(r["time"] for r in both)},
               "policy_success_on_teacher_episodes": sum(r["policy"]["success"] for r in rows),
               "fit": fitted}
    # judged like select-model and self-imitate's table in the README: its 90 held-out episodes, rolled out as the
    # evaluation rolls a policy out; the policy's own figures are computed once per teacher folder
    cached = teacher / f"policy_validation_{SELECT_SEED}_{args.eval_episodes}.json"
    jobs = [(out / "model.zip", out)] + ([] if cached.is_file() else [(model_path, model_path.parent)])
    with multiprocessing.get_context("forkserver").Pool(len(jobs)) as pool:
        results = pool.map(_validate, [(m, d, args.eval_episodes) for m, d in jobs])
    if not cached.is_file():
        cached.write_text(json.dumps(results[1], indent=1) + "\n")
    summary["held_out"] = {"episodes": args.eval_episodes, "first_seed": SELECT_SEED,
                           "policy": json.loads(cached.read_text()), "fitted": results[0]}
    (out / "beam_imitation.json").write_text(json.dumps(summary, indent=1) + "\n")
    if args.json:
        add_to_record(Path(args.json), summary, rows)
    print(f"teacher: {len(better)} of {len(rows)} episodes beat the policy; fit on {fitted['samples']} steps, loss "
          + " -> ".join(f"{x:.3f}" for x in fitted["loss_by_epoch"]))
    for label in ("policy", "fitted"):
        v = summary["held_out"][label]
        print(f"{label}: success {100 * v['success_rate']:.1f} % ({100 * v['argmax_success_rate']:.1f} % first try), "
              f"return {v['mean_return']:.2f}, cycle {v['mean_cycle_time']:.2f} s, ∫C {v['mean_integral_cost']:.1f}")


def add_to_record(path: Path, summary: dict, rows: list[dict]) -> None:
    """One file for every fit of a teacher: the teacher's episodes once, each fit under its settings."""
    record = json.loads(path.read_text()) if path.is_file() else {}
    record["teacher"] = {k: summary[k] for k in ("teacher_episodes", "teacher_found", "teacher_better",
                                                 "teacher_vs_policy_on_both", "policy_success_on_teacher_episodes")}
    record["teacher"]["episodes"] = [{k: v for k, v in r.items() if k != "return_"} for r in rows]
    record["policy"] = summary["held_out"]["policy"]
    fits = record.setdefault("fits", {})
    fits[f"lr {summary['args']['learning_rate']:g}, {summary['args']['epochs']} epochs"] = {
        "fit": summary["fit"], "held_out": summary["held_out"]["fitted"]}
    path.write_text(json.dumps(record, indent=1) + "\n")


def _validate(job) -> dict:
    from dresspack.training.select import validate

    model, run_dir, episodes = job
    return validate(Path(model), Path(run_dir), episodes, SELECT_SEED)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--policy", default="goal_conditioned")
    sub = ap.add_subparsers(dest="command", required=True)
    c = sub.add_parser("collect", help="the teacher's sequences on the policy's own episodes (resumable)")
    c.add_argument("--episodes", type=int, default=40)
    c.add_argument("--beam", type=int, default=3)
    c.add_argument("--leg-steps", type=int, default=200, help="env steps a leg's search may take (work budget)")
    c.add_argument("--jobs", type=int, default=1)
    c.add_argument("--out", required=True)
    f = sub.add_parser("fit", help="fit the policy to the teacher and compare both on held-out episodes")
    f.add_argument("--teacher", required=True)
    f.add_argument("--epochs", type=int, default=20)
    f.add_argument("--learning-rate", type=float, default=1e-4)
    f.add_argument("--batch-size", type=int, default=32)
    f.add_argument("--eval-episodes", type=int, default=90)
    f.add_argument("--out", required=True)
    f.add_argument("--json",
                   help="also add the fit to this record of the teacher's fits (docs/data/beam_imitation.json)")
    args = ap.parse_args()
    (collect if args.command == "collect" else fit_and_compare)(args)


if __name__ == "__main__":
    main()
