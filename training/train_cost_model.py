"""``dresspack train-cost-model``: fit the segment-cost MLP on counterfactual labels, rank-test it on held-out data.

    dresspack train-cost-model --config configs/training/cost_model.yaml --data runs/cost/data --out runs/cost/model

Run folder: ``config.yaml`` (resolved), ``model.pt`` (network and normalisers, agents/learned/cost_model.py),
``metrics.json`` (Spearman ρ globally and per state, top-1 agreement, the cost spread per state, on the held-out
episodes and on the training ones), ``tb/`` (TensorBoard: both losses per epoch).
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import yaml

from dresspack_gym.cli.args import number, output_dir
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.outputs import output_folder, replacing, write_text

from .cost_config import MAX_EPISODES, CostStudyConfig, load_cost_config


def train_cost_model(cfg: CostStudyConfig, data_dir, out: str | Path, *, episodes: int | None = None,
                     tensorboard: bool = True, folds: int = 0) -> dict:
    """Fit on the shards of ``data_dir`` (a folder, or a list of folders of one policy's labels: e.g. a DAgger
    round's beside the first; the first ``episodes`` of each if given), write the run folder; returns the metrics.
    ``folds`` > 1: also a cross-validation by episode (each fold's episodes predicted by a model fit on the others;
    metrics["cross_validation"] ranks those predictions), which one held-out split is too small to judge."""
    import torch
    from dresspack.agents.learned.cost_model import (
        features,
        fit,
        labelled,
        labels,
        most_probable,
        rank_metrics,
        state_ids,
    )
    from dresspack.agents.learned.policy import policy_actions

    from .counterfactuals import load_label_folders

    torch.set_num_threads(1)  # a small MLP; the cores are the data generation's
    folders = [str(d) for d in ([data_dir] if isinstance(data_dir, (str, Path)) else data_dir)]
    data, specs = load_label_folders(folders, episodes)
    folder_of_row = data["episode"] // MAX_EPISODES  # load_label_folders offsets folder k's ids by k * MAX_EPISODES
    per_folder = []
    for k, (folder, folder_spec) in enumerate(zip(folders, specs)):
        ids = np.unique(data["episode"][folder_of_row == k]) - k * MAX_EPISODES
        per_folder.append({"folder": folder, "episodes": _ranges(ids),
                           **{f: folder_spec.get(f) for f in ("rollout", "seed", "cost_to_go", "code", "libraries")}})
    data = labelled(data, cfg.model.label)
    spec = specs[0]
    n_actions = policy_actions(spec["policy_file"])
    episode_ids = np.unique(data["episode"])
    if folds > len(episode_ids):
        raise ConfigError("--folds", f"{folds} folds need as many episodes; the data have {len(episode_ids)}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    writer = None
    if tensorboard:
        from torch.utils.tensorboard import SummaryWriter

        writer = SummaryWriter(str(out / "tb"))

    def log(epoch, train_loss, held_loss):
        if writer is not None:
            writer.add_scalar("cost_model/train_loss", train_loss, epoch)
            writer.add_scalar("cost_model/held_out_loss", held_loss, epoch)

    model, record = fit(data, n_actions, log=log, **asdict(cfg.model))
    if writer is not None:
        writer.close()
    x = features(data["obs"], data["action"], data["target"], data["q"], n_actions)
    predicted = model.predict_all(x)[:, 0]
    true = labels(data, False, cfg.model.label)[:, 0]
    states = state_ids(data)
    held = np.isin(data["episode"], record["held_out_episodes"])
    # the policy's action the model competes with: the one the rollout took (segment costs), or the most probable
    # proposal (costs to go: the one ppo's rollout takes)
    chosen = data["chosen"] if cfg.model.label == "step" else most_probable(data, states)
    # an action whose target is where the robot stands (a via it already is at) costs nothing and tops every
    # state's ranking: the moves alone say how well the model orders real alternatives
    moving = held & (np.abs(data["target"] - data["q"]).max(axis=1) > 0)
    if folds > 1:
        out_of_fold = out_of_fold_predictions(data, x, n_actions, asdict(cfg.model), episode_ids, folds)
    metrics = {"held_out": rank_metrics(predicted[held], true[held], states[held], chosen[held]),
               "held_out_moves_only": rank_metrics(predicted[moving], true[moving], states[moving]),
               "train": rank_metrics(predicted[~held], true[~held], states[~held], chosen[~held]),
               "episodes": int(len(set(data["episode"].tolist()))), "rows": int(len(true)), "data": per_folder,
               **({"unsettled_rows": int((~data["to_go_settled"]).sum())}
                  if cfg.model.label == "to_go" and "to_go_settled" in data else {}),
               "held_out_episodes": record["held_out_episodes"],
               **({"cross_validation": {"folds": folds, **rank_metrics(out_of_fold, true, states, chosen)}}
                  if folds > 1 else {}),
               "final_train_loss": record["train_loss"][-1], "final_held_out_loss": record["held_out_loss"][-1],
               "loss_by_epoch": {"train": record["train_loss"], "held_out": record["held_out_loss"]}}
    # written last, each whole: a run stopped before this point leaves no model.pt that --force would be needed for
    write_text(out / "config.yaml", yaml.safe_dump({**cfg.to_dict(), "data": folders[0] if len(folders) == 1
                                                    else folders}, sort_keys=False))
    with replacing(out / "model.pt") as tmp:
        model.save(tmp, extra={"policy_file": spec["policy_file"]})
    write_text(out / "metrics.json", json.dumps(metrics, indent=2) + "\n")
    return metrics


def out_of_fold_predictions(data: dict, x: np.ndarray, n_actions: int, model_cfg: dict, episodes, folds: int
                            ) -> np.ndarray:
    """The predicted cost of every row of ``episodes``, each fold of them (drawn by the model's seed) predicted by a
    model fit on all other rows; NaN on the rows of other episodes (always fit on)."""
    from dresspack.agents.learned.cost_model import fit

    predicted = np.full(len(x), np.nan)
    for fold in np.array_split(np.random.default_rng(model_cfg["seed"]).permutation(episodes), folds):
        model, _ = fit(data, n_actions, **{**model_cfg, "held_out_episodes": fold})
        rows = np.isin(data["episode"], fold)
        predicted[rows] = model.predict_all(x[rows])[:, 0]
    return predicted


def _ranges(ids) -> str:
    """Episode ids as ranges, e.g. 0-305,307: which episodes a model was fit on, in a line."""
    ids, parts, k = [int(i) for i in ids], [], 0
    while k < len(ids):
        j = k
        while j + 1 < len(ids) and ids[j + 1] == ids[j] + 1:
            j += 1
        parts.append(str(ids[k]) if j == k else f"{ids[k]}-{ids[j]}")
        k = j + 1
    return ",".join(parts)


def add_train_cost_model_command(sub) -> None:
    p = sub.add_parser("train-cost-model", help="fit the segment-cost model on counterfactual labels and rank-test it",
                       description=__doc__.split("\n")[0])
    p.add_argument("--config", default="cost_model",
                   help="cost-model YAML (path, or a name in configs/training/; default cost_model)")
    p.add_argument("--data", required=True, nargs="+", metavar="FOLDER",
                   help="folder(s) written by dresspack counterfactuals for one policy (e.g. a DAgger round's "
                        "labels beside the first)")
    p.add_argument("--out", type=output_dir, required=True, help="run folder (model.pt, metrics.json, tb/)")
    p.add_argument("--episodes", type=number(2, 100_000, integer=True),
                   help="use only the first N episodes' shards of each folder (learning curves)")
    p.add_argument("--folds", type=number(2, 100, integer=True), default=None,
                   help="also cross-validate by episode in this many folds (metrics.json's cross_validation)")
    p.add_argument("--force", action="store_true", help="replace a model already in --out")
    p.set_defaults(func=cmd_train_cost_model)


def cmd_train_cost_model(args) -> int:
    if (Path(args.out) / "model.pt").exists() and not args.force:
        raise ConfigError("--out", f"{args.out} already holds a model.pt: choose another --out or replace it with "
                                   "--force")
    cfg = load_cost_config(args.config)
    with output_folder(args.out, keep_on_interrupt=False):  # a refused or stopped fit leaves no folder it made
        metrics = train_cost_model(cfg, args.data, args.out, episodes=args.episodes, folds=args.folds or 0)
    print(json.dumps({k: metrics[k] for k in ("episodes", "rows", "final_train_loss", "final_held_out_loss")}))
    print(f"held out: {_ranking(metrics['held_out'])}; run folder {args.out}")
    if "cross_validation" in metrics:
        print(f"{metrics['cross_validation']['folds']}-fold by episode: {_ranking(metrics['cross_validation'])}")
    return 0


def _ranking(m: dict) -> str:
    """One line of rank metrics: Spearman ρ, how often the model's cheapest is the cheapest, and its regret beside
    the policy's action's."""
    per_state, overall = ("-" if m[k] is None else f"{m[k]:.3f}" for k in ("spearman_per_state_mean",
                                                                        "spearman_global"))
    policy = (f" (the policy's action: top-1 {100 * m['policy_action_top1']:.1f} %, regret "
              f"{m['policy_action_regret_mean']:.2f})" if "policy_action_top1" in m else "")
    return (f"{m['rows']} rows, {m['states']} states: Spearman global {overall}, per state {per_state}, top-1 "
            f"{100 * m['top1_agreement']:.1f} %, regret {m['mean_regret']:.2f}{policy}")
