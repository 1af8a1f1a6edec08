"""Cable evaluation speed against accuracy: fixed weld cycles replayed at several segment counts and motion steps.

Replays the same valid weld cycles (``random_paths``: Home -> random via -> weld -> Home, seed 0) under each setting
and compares them with a fine reference (by default 96 segments at 2 ms): Spearman rank correlation of the cycles'
integrated wear cost (all cycles, and the cycles whose every settle reached the equilibrium residual in both),
mean ratio of integrated cost and of peak curvature to the reference, and wall time (all settings timed in this
one run, so the ratios between them hold on any machine). Usage:
  PYTHONPATH=. .venv/bin/python scripts/studies/physics_speed_accuracy.py --settings 24:0.002 24:0.008 48:0.008 \
      --reference 96:0.002 --paths 12 --json docs/data/physics_speed_accuracy.json
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import random_paths, spearman
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import replay
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.validity import MotionValidity


def setting(config, segments: int, timestep: float, settle_timestep: float | None = None,
            tolerance: float | None = None):
    """``config`` with every dresspack at ``segments``, motions stepped at ``timestep`` and, where given, settles at
    ``settle_timestep`` and the equilibrium ``tolerance`` (else the station's)."""
    robots = tuple(replace(r, dresspack=replace(r.dresspack, segments=segments)) for r in config.robots)
    simulation = replace(config.simulation, timestep=timestep)
    if settle_timestep is not None:
        simulation = replace(simulation, settle_timestep=settle_timestep)
    if tolerance is not None:
        simulation = replace(simulation, equilibrium_tolerance=tolerance)
    return replace(config, robots=robots, simulation=simulation)


def run(config, segments: int, timestep: float, settle_timestep: float | None, tolerance: float | None,
        paths) -> dict:
    sim = CableSimulator(Station(setting(config, segments, timestep, settle_timestep, tolerance)))
    start = time.perf_counter()
    replays = [replay(sim, p, record_states=False) for p in paths]
    wall = time.perf_counter() - start
    return {"segments": segments, "timestep_s": timestep, "settle_timestep_s": sim.config.settle_timestep,
            "tolerance": sim.config.equilibrium_tolerance,
            "wall_s": round(wall, 2), "motion_s": round(float(sum(r.cycle_time for r in replays)), 3),
            "stops": int(sum(len(r.stop_times) for r in replays)),
            "cost": [float(r.integrated_cost()) for r in replays],
            "unconverged_stops": [int(r.unconverged_stops) for r in replays],
            "peak_curvature": [float(np.max(r.measures["curvature"])) for r in replays]}


def compare(row: dict, ref: dict) -> dict:
    cost, ref_cost = np.array(row["cost"]), np.array(ref["cost"])
    settled = np.array([a == 0 and b == 0 for a, b in zip(row["unconverged_stops"], ref["unconverged_stops"])])
    return {"spearman_all": round(spearman(ref_cost, cost), 3),
            "spearman_settled": round(spearman(ref_cost[settled], cost[settled]), 3),
            "settled_paths": int(settled.sum()),
            "cost_ratio": round(float(np.mean(cost / ref_cost)), 3),
            "peak_curvature_ratio": round(float(np.mean(np.array(row["peak_curvature"]) / ref["peak_curvature"])), 3),
            "speed_vs_reference": round(ref["wall_s"] / row["wall_s"], 2),
            "wall_per_motion_second": round(row["wall_s"] / row["motion_s"], 4)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--station", default="default", help="station (default: default)")
    parser.add_argument("--settings", nargs="+", default=["24:0.002:0.008:0.02", "24:0.008", "48:0.008"],
                        help="SEGMENTS:TIMESTEP[:SETTLE_TIMESTEP[:TOLERANCE]] settings to compare, the settle step "
                             "and tolerance defaulting to the station's (default: 24:0.002:0.008:0.02 24:0.008 "
                             "48:0.008)")
    parser.add_argument("--reference", default="96:0.002", help="the fine reference (default: 96:0.002)")
    parser.add_argument("--paths", type=int, default=12, help="weld cycles (default: 12)")
    parser.add_argument("--json", help="write the table to this file")
    args = parser.parse_args()
    config = load_station(args.station)
    station = Station(config)
    paths = random_paths(station, 0, MotionValidity(station, 0, 0.005), args.paths, seed=0)
    parse = [s.split(":") for s in [args.reference, *args.settings]]
    rows = [run(config, int(p[0]), float(p[1]), *[float(x) for x in p[2:4]], *[None] * (4 - max(len(p), 2)), paths)
            for p in parse]
    ref = rows[0]
    keys = ("segments", "timestep_s", "settle_timestep_s", "tolerance", "wall_s")
    table = [{**{k: r[k] for k in keys}, **compare(r, ref)} for r in rows]
    for r in table:
        print(json.dumps(r), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"station": args.station, "paths": args.paths, "reference": args.reference, "table": table,
                       "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
