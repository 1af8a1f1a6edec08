"""Which held-out welds the env's planner-like actions can finish at all: a search over the action set alone
(geometry and masks, no policy), per leg the fewest via actions after which "straight to the goal" is free.

    PYTHONPATH=. .venv/bin/python scripts/studies/primitive_reach.py --station default --drawn-tasks 30 \
        --anchors midpoint --anchors midpoint,here --anchors midpoint,here/here --out docs/data/primitive_reach.json

The tasks are `dresspack eval --drawn-tasks N --seeds 0`'s (Home to one weld drawn on the parts, back Home). Each
leg is searched breadth first: at most ``--vias`` actions (every unmasked via of the env: its own targets, masks and
continuous check, ``DresspackEnv.masks_at``), then the straight segment to the leg's end must be free. A set
``ANCHORS/FALLBACKS`` (e.g. ``midpoint,here/here``) makes the anchors after the slash fallbacks (the env's
``fallback_anchors``: offered only where no other move is free). A weld is reachable when both legs are.
What a policy can finish is bounded by this (up to ``--vias`` per leg); which welds it does finish is the
evaluation's business."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

# a leg's search keeps at most this many configurations per depth (the via tree grows up to 48x per level): with
# --vias 2 the deepest level holds at most 48 x 48 = 2,304, so the search is exhaustive and "unreachable" is
# proven for the action set; deeper searches may cut the frontier, and then a miss proves nothing
FRONTIER_CAP = 3000


def fewest_vias(env, start: np.ndarray, end: np.ndarray, max_vias: int) -> int | None:
    """The fewest via actions after which the straight segment from ``start`` reaches ``end``; None beyond
    ``max_vias``. Uses the env's own action targets and masks, with ``end`` as the goal."""
    goal = np.asarray(end, dtype=float)
    frontier = [np.asarray(start, dtype=float)]
    for depth in range(max_vias + 1):
        masks = [env.masks_at(q, goal) for q in frontier]
        if any(m[0] for m in masks):  # action 0: straight to the goal
            return depth
        if depth == max_vias:
            return None
        frontier = [env.target(q, a, goal) for q, m in zip(frontier, masks)
                    for a in np.flatnonzero(m[1:env.stay_action]) + 1][:FRONTIER_CAP]
    return None


def main() -> None:
    from dresspack.eval.runs import EvalSpec, build_tasks

    from dresspack_gym.env.dresspack_env import DresspackEnv
    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station
    from dresspack_gym.stations.validity import PLANNER_MARGIN

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--station", default="default")
    ap.add_argument("--drawn-tasks", type=int, default=30)
    ap.add_argument("--anchors", action="append", required=True,
                    help="comma-separated via anchors of one action set, then optionally /fallback anchors "
                         "(e.g. midpoint,here/here; repeat to compare sets)")
    ap.add_argument("--vias", type=int, default=2, help="via actions per leg before the straight segment")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    station = Station(load_station(args.station))
    tasks = build_tasks(station, EvalSpec(station=args.station, methods=("ompl",), seeds=(0,),
                                          drawn_tasks=args.drawn_tasks))
    result = {"station": args.station, "drawn_tasks": args.drawn_tasks, "vias_per_leg": args.vias, "sets": {}}
    for anchors in args.anchors:
        names, _, fallback = anchors.partition("/")
        env = DresspackEnv(station=station, action_set="primitives", via_anchors=names.split(","),
                           fallback_anchors=fallback.split(",") if fallback else [], collision_margin=PLANNER_MARGIN)
        per_task = {}
        for (welds, _), task in tasks.items():
            there = fewest_vias(env, task.start, task.goals[0], args.vias)
            back = fewest_vias(env, task.goals[0], task.end, args.vias)
            per_task[welds[0]] = {"to_weld": there, "back_home": back}
            print(anchors, welds[0], there, back, flush=True)
        reachable = sorted(k for k, v in per_task.items() if v["to_weld"] is not None and v["back_home"] is not None)
        result["sets"][anchors] = {"actions": env.n_actions, "reachable": len(reachable),
                                   "unreachable": sorted(set(per_task) - set(reachable)), "per_task": per_task}
        print(f"{anchors}: {len(reachable)}/{len(per_task)} reachable")
    if args.out:
        args.out.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
