"""Planning for life against planning for T + ∫C dt: per evaluation folder and method, the success, cycle time T, ∫C dt
under the thesis cost (4.10) and the fatigue life (geometric mean ×/÷ its spread over the runs, with what fails the
weakest segment); the runs of a folder planned under another cost variant (``--cost-variant life``) are replayed
again on its station under the thesis cost, so that it is measured like the others. Usage (the demo's tasks on the
calibrated dresspack; a station file naming ``dresspack: stud_welding_rated``):
  dresspack eval --station STATION --planners ompl ompl-wear --welds sill_rear,roof_rail_top \\
      b_pillar_outer,sill_front floor_pan_inner --seeds 0 1 --out out/life_thesis
  dresspack eval ... --planners ompl-wear --cost-variant life --out out/life_life
  PYTHONPATH=. .venv/bin/python scripts/studies/life_objective_study.py out/life_thesis out/life_life
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import load_trajectory_file, replay
from dresspack_gym.stations.station import Station


def _path(out: Path, key: str) -> Path:
    return out / "trajectories" / (key.replace("|", "__").replace("+", "-") + ".npz")


def measure(out: Path) -> list[dict]:
    """Per method of the folder ``out``: its runs replayed under the thesis cost, summarised."""
    spec = json.loads((out / "spec.json").read_text())
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines() if line.strip()]
    thesis = spec["cost_variant"] == "thesis"
    sim = None if thesis else CableSimulator(Station(load_station(spec["station"])))
    label = "" if thesis else f" (--cost-variant {spec['cost_variant']})"
    label += "" if spec.get("time_weight", 1.0) == 1.0 else f" (--time-weight {spec['time_weight']:g})"
    table = []
    for method in spec["methods"]:
        mine = [r for r in rows if r["method"] == method]
        runs = []
        for r in (r for r in mine if r["success"]):
            if thesis:  # the row is the replay under the thesis cost
                runs.append(r)
                continue
            traj, _ = load_trajectory_file(_path(out, r["key"]))
            runs.append(replay(sim, traj, robot=spec.get("robot", 0), cost_variant="thesis").summary())
        if not runs:
            table.append({"method": method + label, "success": f"0/{len(mine)}"})
            continue
        lives = np.array([s["life_cycles"] for s in runs])
        weakest = min(runs, key=lambda s: s["life_cycles"])
        causes = Counter(s["weakest_cause"] for s in runs)
        table.append({"method": method + label, "success": f"{len(runs)}/{len(mine)}",
                      "T": float(np.mean([s["cycle_time"] for s in runs])),
                      "cost": float(np.mean([s["cost"] for s in runs])),
                      "objective": float(np.mean([s["cycle_time"] + s["cost"] for s in runs])),
                      "life": float(np.exp(np.mean(np.log(lives)))), "spread": float(np.exp(np.std(np.log(lives)))),
                      "shortest": float(lives.min()), "weakest_m": weakest["weakest_segment_m"],
                      "causes": ", ".join(f"{c} {n}" for c, n in causes.most_common())})
    return table


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folders", nargs="+", type=Path, help="evaluation folders (dresspack eval --out)")
    p.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = p.parse_args(argv)
    rows = [row for out in args.folders for row in measure(out)]
    print("| method | success | T [s] | ∫C dt (4.10) | T + ∫C dt | life [cycles] ×/÷ spread | shortest life | "
          "weakest segment of the shortest | what fails the weakest segment (runs) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "life" not in r:
            print(f"| {r['method']} | {r['success']} | – | – | – | – | – | – | – |")
            continue
        print(f"| {r['method']} | {r['success']} | {r['T']:.2f} | {r['cost']:.1f} | {r['objective']:.1f} | "
              f"{r['life']:.3g} ×/÷ {r['spread']:.2f} | {r['shortest']:.3g} | {r['weakest_m']:.2f} m | "
              f"{r['causes']} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
