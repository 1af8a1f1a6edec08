"""Travel postures from a wear-aware planner's plans: the via configurations its routes pass through most often,
for a policy's ``via_postures_deg`` (the env's "via travel posture k" actions).

    .venv/bin/dresspack eval --planners ompl-wear --drawn-tasks 16 --drawn-seed 4242 --seeds 0 \
        --start-noise-deg 10 --no-render --out runs/eval/postures_4242
    PYTHONPATH=. .venv/bin/python scripts/studies/travel_postures.py runs/eval/postures_4242 [more folders] --count 4

Use welds of a drawn seed of their own (the evaluation's is 1,000,000), so a policy given these postures has seen
nothing of the welds it is judged on. Every interior waypoint of every successful plan (not its start, stops or
end) is a candidate; a posture is the candidate with the most plans passing within ``--radius-deg`` of it (every
joint), and the plans it stands for are then set aside, until ``--count`` postures are found or no candidate is
shared by ``--min-plans`` plans. A wear-aware planner's vias are where it found the cable hanging easy: a tuck of
the arm with the wrist straight (j5 near 0) recurs on welds of both sides of the car body.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def interior_waypoints(results: Path, method: str) -> list[tuple[str, np.ndarray]]:
    """(run key, configuration) of every successful ``method`` plan's via waypoints, in the runs' order."""
    rows = [json.loads(line) for line in (results / "results.jsonl").read_text().splitlines() if line.strip()]
    out = []
    for row in rows:
        if row["method"] != method or not row["success"]:
            continue
        traj = np.load(results / "trajectories" / f"{method}__{row['task']}__{row['seed']}.npz")
        waypoints, stops = traj["waypoints"], {int(s) for s in traj["stops"]}
        out += [(f"{results}|{row['key']}", waypoints[i]) for i in range(1, len(waypoints) - 1) if i not in stops]
    return out


def shared_postures(candidates: list[tuple[str, np.ndarray]], count: int, radius: float,
                     min_plans: int) -> list[tuple[np.ndarray, int]]:
    """Greedy: the candidate the most plans pass near, those plans set aside, repeated; (posture, plans)."""
    keys = np.array([k for k, _ in candidates])
    qs = np.array([q for _, q in candidates]).reshape(-1, 6)
    near = np.max(np.abs(qs[:, None, :] - qs[None, :, :]), axis=2) <= radius  # (candidate, candidate)
    left = set(keys.tolist())
    chosen = []
    while len(chosen) < count:
        support = [len(set(keys[near[i]].tolist()) & left) for i in range(len(qs))]
        best = int(np.argmax(support))  # ties: the earliest candidate (runs in the results' order)
        if support[best] < min_plans:
            break
        chosen.append((qs[best], support[best]))
        left -= set(keys[near[best]].tolist())
    return chosen


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path, nargs="+", help="evaluation folders with the planner's trajectories")
    ap.add_argument("--method", default="ompl-wear")
    ap.add_argument("--count", type=int, default=4)
    ap.add_argument("--radius-deg", type=float, default=20.0)
    ap.add_argument("--min-plans", type=int, default=2)
    args = ap.parse_args(argv)
    candidates = [c for folder in args.results for c in interior_waypoints(folder, args.method)]
    if not candidates:
        raise SystemExit(f"no successful {args.method} plan with via waypoints in {[str(r) for r in args.results]}")
    postures = shared_postures(candidates, args.count, np.radians(args.radius_deg), args.min_plans)
    print(f"# {len(postures)} travel postures from {len(candidates)} vias of {args.method} in "
          f"{', '.join(str(r) for r in args.results)} "
          f"(radius {args.radius_deg:g} deg)")
    print("via_postures_deg:")
    for q, plans in postures:
        print(f"  - [{', '.join(f'{v:.1f}' for v in np.degrees(q))}]  # passed near by {plans} plans")


if __name__ == "__main__":
    main()
