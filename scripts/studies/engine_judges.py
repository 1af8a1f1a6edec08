"""An evaluation's trajectories judged by both cable engines: each successful run's saved trajectory replayed on MuJoCo
(dynamic) and on the rod engine (fast), the methods' means and ranks side by side, so a plan made on one engine is
seen keeping (or losing) its rank on the other.

    .venv/bin/dresspack demo --out out/demo
    PYTHONPATH=. .venv/bin/python scripts/studies/engine_judges.py out/demo --json docs/data/engine_judges_demo.json

No planning happens here: the trajectories are the folder's (``trajectories/*.npz``), replayed from Home as the
evaluation replays them.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main() -> None:
    from dresspack.eval.runs import load_trajectory

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.physics.profiles import ENGINES, make_simulator, spearman
    from dresspack_gym.physics.trajectory import replay
    from dresspack_gym.stations.station import Station

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="a finished dresspack eval / demo folder")
    ap.add_argument("--json", type=Path, default=None, help="write the table and every run's figures here")
    args = ap.parse_args()
    spec = json.loads((args.folder / "spec.json").read_text())
    rows = [json.loads(line) for line in (args.folder / "results.jsonl").read_text().splitlines() if line.strip()]
    station = Station(load_station(spec["station"]))
    sims = {e: make_simulator(station, e) for e in ENGINES}
    runs = []
    for row in rows:
        traj = load_trajectory(args.folder, row)
        if traj is None:
            continue
        run = {"key": row["key"], "method": row["method"], "task": row["task"], "seed": row["seed"]}
        for engine, sim in sims.items():
            s = replay(sim, traj, robot=spec.get("robot", 0), cost_variant=spec["cost_variant"],
                       record_states=False).summary()
            run[engine] = {"cycle_time": s["cycle_time"], "cost": s["cost"], "objective": s["cycle_time"] + s["cost"],
                           "max_tension": s["max_tension"], "max_curvature": s["max_curvature"]}
        runs.append(run)
        print(run["key"], {e: round(run[e]["objective"], 2) for e in ENGINES}, flush=True)
    methods = list(dict.fromkeys(r["method"] for r in runs))
    table = {m: {e: float(np.mean([r[e]["objective"] for r in runs if r["method"] == m])) for e in ENGINES}
             for m in methods}
    ranks = {e: sorted(methods, key=lambda m: table[m][e]) for e in ENGINES}
    # per task and seed: do both engines order the methods alike?
    groups = {}
    for r in runs:
        groups.setdefault((r["task"], r["seed"]), []).append(r)
    same_order = sum(sorted(g, key=lambda r: r["dynamic"]["objective"]) == sorted(g, key=lambda r: r["fast"]["objective"])
                     for g in groups.values())
    out = {
        "folder": str(args.folder),
        "mean_objective": table,
        "ranking": ranks,
        "same_ranking": ranks["dynamic"] == ranks["fast"],
        "spearman_objective_over_runs": spearman([r["dynamic"]["objective"] for r in runs],
                                                 [r["fast"]["objective"] for r in runs]),
        "median_abs_rel_diff_cost": float(np.median([abs(r["fast"]["cost"] - r["dynamic"]["cost"])
                                                     / max(abs(r["dynamic"]["cost"]), 1e-9) for r in runs])),
        "groups_with_same_method_order": f"{same_order}/{len(groups)}",
        "runs": runs,
    }
    print("| method | T + ∫C dt on MuJoCo | T + ∫C dt on the rod engine |")
    print("|---|---|---|")
    for m in ranks["dynamic"]:
        print(f"| {m} | {table[m]['dynamic']:.1f} | {table[m]['fast']:.1f} |")
    print({k: v for k, v in out.items() if k not in ("runs", "mean_objective")})
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
