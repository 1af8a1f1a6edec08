"""The rod engine against MuJoCo on fixed weld cycles: integral of C, peak curvature and tension, and wall time.

    .venv/bin/python scripts/studies/rod_agreement.py --station default --paths 20 --segments 48 \
        --mujoco-timestep 0.016 --out docs/data/rod_agreement_default_48.json

``--mujoco-segments`` runs MuJoCo at another resolution than the rod engine (its 96-segment reference, or the 24
segments at 8 ms that MuJoCo's replays use today, for the speed ratio).
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
from dresspack_gym.physics.wear_cost import wear_cost
from dresspack_gym.rod.simulator import RodSimulator
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.validity import MotionValidity


def at_resolution(config, segments: int, timestep: float | None):
    robots = tuple(replace(r, dresspack=replace(r.dresspack, segments=segments)) for r in config.robots)
    sim = config.simulation if timestep is None else replace(config.simulation, timestep=timestep)
    return replace(config, robots=robots, simulation=sim)


def fast_replay(sim: RodSimulator, traj, robot: int = 0, record_every: float = 0.05) -> dict:
    """The trajectory on the rod engine, sampled and scored as physics.trajectory.replay scores it."""
    q_all = sim.station.home.copy()

    def full(q):
        q_all[robot] = q
        return q_all.copy()

    sim.reset(full(traj.waypoints[0]))
    cfg = sim.station.config.wear_cost
    times, measures = [0.0], [sim.measures()]
    stops = set(traj.stops)
    unconverged = 0
    for i, q in enumerate(traj.waypoints[1:], start=1):
        trace = sim.move_to(full(q), settle=i in stops, record_every=record_every)
        times += trace.time
        measures += trace.measures
        if i in stops:
            unconverged += int(not sim.last_settle.converged)
            times.append(sim.motion_time)
            measures.append(sim.measures())
    cost = np.array([wear_cost(m, cfg).total for m in measures])
    return {"J": float(np.trapezoid(cost, times)), "kappa": max(m.max_curvature for m in measures),
            "tension": max(m.max_tension for m in measures), "clearance": min(m.min_clearance for m in measures),
            "cycle_time": sim.motion_time, "unconverged": unconverged}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--station", default="default")
    ap.add_argument("--paths", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--segments", type=int, default=48)
    ap.add_argument("--mujoco-timestep", type=float, default=0.016)
    ap.add_argument("--mujoco-segments", type=int, default=None, help="MuJoCo's resolution (default: --segments)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    base = load_station(args.station)
    station = Station(at_resolution(base, args.segments, args.mujoco_timestep))
    dynamic_station = station if args.mujoco_segments in (None, args.segments) else Station(
        at_resolution(base, args.mujoco_segments, args.mujoco_timestep))
    paths = random_paths(station, 0, MotionValidity(station, 0, 0.005), args.paths, seed=args.seed)
    dyn, fast = CableSimulator(dynamic_station), RodSimulator(station)
    fast_replay(fast, paths[0])  # compiled kernels loaded before timing
    rows = []
    for k, traj in enumerate(paths):
        t0 = time.perf_counter()
        rep = replay(dyn, traj, record_states=False)
        t1 = time.perf_counter()
        f = fast_replay(fast, traj)
        t2 = time.perf_counter()
        rows.append({"path": k, "dynamic": {"J": rep.integrated_cost(), "kappa": float(rep.measures["curvature"].max()),
                                            "tension": float(rep.measures["tension"].max()),
                                            "clearance": float(rep.measures["clearance"].min()),
                                            "cycle_time": rep.cycle_time, "unconverged": rep.unconverged_stops},
                     "fast": f, "wall_dynamic_s": t1 - t0, "wall_fast_s": t2 - t1})
        r = rows[-1]
        print(f"{k:3d} J {r['dynamic']['J']:9.3f} {f['J']:9.3f}  kappa {r['dynamic']['kappa']:6.2f} {f['kappa']:6.2f}  "
              f"F {r['dynamic']['tension']:7.2f} {f['tension']:7.2f}  d {r['dynamic']['clearance']:.3f} "
              f"{f['clearance']:.3f}  wall {t1 - t0:6.2f} s {t2 - t1:6.3f} s", flush=True)
    jd = np.array([r["dynamic"]["J"] for r in rows])
    jf = np.array([r["fast"]["J"] for r in rows])
    summary = {
        "station": args.station, "segments": args.segments, "mujoco_timestep": args.mujoco_timestep,
        "mujoco_segments": args.mujoco_segments or args.segments,
        "paths": len(rows), "seed": args.seed,
        "spearman_J": spearman(jd, jf) if len(rows) > 2 else None,
        "median_rel_dJ": float(np.median(np.abs(jf - jd) / np.maximum(jd, 1e-9))),
        "median_rel_dkappa": float(np.median([abs(r["fast"]["kappa"] / r["dynamic"]["kappa"] - 1) for r in rows])),
        "median_rel_dtension": float(np.median([abs(r["fast"]["tension"] / r["dynamic"]["tension"] - 1)
                                                for r in rows])),
        "wall_dynamic_s": float(sum(r["wall_dynamic_s"] for r in rows)),
        "wall_fast_s": float(sum(r["wall_fast_s"] for r in rows)),
        "motion_s": float(sum(r["fast"]["cycle_time"] for r in rows)),
    }
    summary["speedup"] = summary["wall_dynamic_s"] / summary["wall_fast_s"]
    print(json.dumps(summary, indent=1))
    if args.out:
        with open(args.out, "w") as fh:
            json.dump({"summary": summary, "rows": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
