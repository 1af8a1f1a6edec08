"""How well cost-to-go models rank the proposals on the states the ranked planner itself visits (a DAgger round's
labels): the shipped model, never fit on them, against models fit on the first labels plus the other folds of the
DAgger episodes (a cross-validation by episode over the DAgger labels).

    PYTHONPATH=. .venv/bin/python scripts/studies/cost_to_go_dagger.py --first runs/ctg/data --dagger runs/ctg/dagger \
        --out docs/data/cost_to_go_dagger.json

``--first``: labels of the policy's own rollouts (``dresspack counterfactuals --config cost_to_go``); ``--dagger``:
labels of the ranked rule's (``--config cost_to_go_ranked``). Both are read as ``train-cost-model`` reads several
folders; the models are fit with ``configs/training/cost_to_go.yaml``'s settings. Top-1: how often the model's
cheapest of a state's 4 proposals is the simulated cheapest; regret: the cost to go it gives up on the mean.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
from dresspack.agents.learned.cost_model import (
    CostModel,
    features,
    labelled,
    labels,
    most_probable,
    rank_metrics,
    state_ids,
)
from dresspack.agents.learned.policy import policy_actions, resolve_policy
from dresspack.training.cost_config import MAX_EPISODES, load_cost_config
from dresspack.training.counterfactuals import load_label_folders
from dresspack.training.train_cost_model import out_of_fold_predictions


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--first", required=True, help="labels of the policy's rollouts (the shipped model's)")
    p.add_argument("--dagger", required=True, help="labels of the ranked rule's rollouts")
    p.add_argument("--model", default=None, help="the model the ranked rule used (default: the shipped one)")
    p.add_argument("--folds", type=int, default=5)
    p.add_argument("--config", default="cost_to_go")
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args()
    data, specs = load_label_folders([args.first, args.dagger])
    data = labelled(data, "to_go")
    n_actions = policy_actions(specs[0]["policy_file"])
    x = features(data["obs"], data["action"], data["target"], data["q"], n_actions)
    true = labels(data, False, "to_go")[:, 0]
    states = state_ids(data)
    chosen = most_probable(data, states)  # the policy's most probable proposal, for comparison
    dagger = data["episode"] >= MAX_EPISODES
    model_file = args.model or resolve_policy(None)[0].parent / "cost_to_go.pt"
    shipped = CostModel.load(model_file).predict_all(x)[:, 0]
    cfg = asdict(load_cost_config(args.config).model)
    predicted = out_of_fold_predictions(data, x, n_actions, cfg, np.unique(data["episode"][dagger]), args.folds)
    out = {"first": args.first, "dagger": args.dagger, "model": str(model_file), "folds": args.folds,
           "dagger_states": int(len(np.unique(states[dagger]))), "dagger_rows": int(dagger.sum()),
           "model_on_dagger_states": rank_metrics(shipped[dagger], true[dagger], states[dagger], chosen[dagger]),
           "model_on_first_labels": rank_metrics(shipped[~dagger], true[~dagger], states[~dagger], chosen[~dagger]),
           "refit_on_dagger_states": rank_metrics(predicted[dagger], true[dagger], states[dagger], chosen[dagger])}
    text = json.dumps(out, indent=2) + "\n"
    if args.out:
        args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
