"""Per-method fatigue life and damage of an evaluation's trajectories, and the figures of damage along the cable.

    python scripts/studies/damage_study.py out/demo [--axial-stiffness 1.8e6] [--figures docs/]

Replays every successful trajectory of an evaluation folder (``dresspack demo`` / ``dresspack eval``) with the
station's dresspack (optionally with the conductors' own axial stiffness), prints per method the shortest life,
where, and the geometric-mean life beside the mean integral of C, ranks the methods both ways, and writes the damage
figures of the task on which the shortest-lived method is worst.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
from dresspack.agents.planners.registry import COLORS
from dresspack.eval.runs import load_trajectory

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import replay
from dresspack_gym.plots.damage import plot_damage_along_cable, plot_damage_strip
from dresspack_gym.stations.station import Station


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("folder", type=Path)
    p.add_argument("--axial-stiffness", type=float, default=None, help="conductors' E A [N] (default: the EA)")
    p.add_argument("--figures", type=Path, default=None, help="folder for the figures")
    args = p.parse_args()
    spec = json.loads((args.folder / "spec.json").read_text())
    cfg = load_station(spec["station"])
    if args.axial_stiffness is not None:
        r0 = cfg.robots[0]
        fat = replace(r0.dresspack.fatigue, axial_stiffness=args.axial_stiffness)
        cfg = replace(cfg, robots=(replace(r0, dresspack=replace(r0.dresspack, fatigue=fat)), *cfg.robots[1:]))
    sim = CableSimulator(Station(cfg))
    rows = [json.loads(line) for line in (args.folder / "results.jsonl").read_text().splitlines()]
    per_method: dict[str, list] = {}
    for r in rows:
        traj = load_trajectory(args.folder, r)
        if traj is not None:
            per_method.setdefault(r["method"], []).append((r, replay(sim, traj, robot=spec.get("robot", 0))))
    life, cost = {}, {}
    for m, runs in per_method.items():
        lives = np.array([rep.fatigue.life_cycles.min() for _, rep in runs])
        k = int(np.argmin(lives))
        rep = runs[k][1]
        life[m] = float(np.exp(np.log(lives).mean()))
        cost[m] = float(np.mean([rep2.integrated_cost() for _, rep2 in runs]))
        print(f"{m:13s} shortest life {lives.min():9.3g} cycles at {rep.fatigue.arc[rep.fatigue.weakest_segment]:.2f} m "
              f"({runs[k][0]['task']}, seed {runs[k][0]['seed']}); geometric mean {life[m]:9.3g}; "
              f"mean ∫C dt {cost[m]:6.0f}; mean worst-segment damage "
              f"{np.mean([r2.damage.total.max() for _, r2 in runs]):.1f}")
    print("ranked by life:", ", ".join(sorted(life, key=lambda m: -life[m])))
    print("ranked by ∫C dt:", ", ".join(sorted(cost, key=lambda m: cost[m])))
    if args.figures is not None and life:
        worst = min(life, key=life.get)
        r, _ = min(per_method[worst], key=lambda x: x[1].fatigue.life_cycles.min())
        task = r["task"]
        same_task = {f"{m} (seed {r2['seed']})": rep for m, runs in per_method.items() for r2, rep in runs
                     if r2["task"] == task and r2["seed"] == r["seed"]}
        args.figures.mkdir(parents=True, exist_ok=True)
        print(plot_damage_along_cable(same_task, args.figures / "damage_along_cable_demo.png", COLORS))
        rep = next(rep for r2, rep in per_method[worst] if r2["key"] == r["key"])
        print(plot_damage_strip(rep, args.figures / "damage_strip_demo.png",
                                f"Damage strip: {worst} on {task}, seed {r['seed']} (shortest life of the demo)"))


if __name__ == "__main__":
    main()
