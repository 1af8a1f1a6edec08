"""Rest after settling: per weld, settle there, simulate on with the robots still, and report how far the cable moved.

A settled cable is at rest when more simulation leaves it where it is. For every weld of the given stations and
segment counts this moves the robot Home -> weld (settling there), then simulates ``--more`` seconds at the motion
timestep and reports the largest vertex displacement [mm] and the changes of max tension, max twist rate and the
largest clamp force/torque [%]. Usage:
  PYTHONPATH=. .venv/bin/python scripts/studies/rest_table.py --stations default default_variant --segments 24 48 \
      --json docs/data/rest_table.json
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import Station
from dresspack_gym.stations.tasks import select_weld_goals
from dresspack_gym.stations.validity import MotionValidity


def with_settings(config, segments: int, simulation: dict):
    """``config`` with every dresspack at ``segments`` and the simulation fields in ``simulation`` replaced."""
    robots = tuple(replace(r, dresspack=replace(r.dresspack, segments=segments)) for r in config.robots)
    return replace(config, robots=robots, simulation=replace(config.simulation, **simulation))


def snapshot(sim: CableSimulator) -> dict:
    measures = sim.measures()
    forces, torques = sim.node_loads(0)
    return {"points": sim.cable_points(0).copy(), "tension": measures.max_tension,
            "twist_rate": measures.max_twist_rate, "clamp_force": float(np.linalg.norm(forces, axis=1).max()),
            "clamp_torque": float(np.linalg.norm(torques, axis=1).max())}


def percent(after: float, before: float) -> float:
    return 100.0 * abs(after - before) / max(abs(before), 1e-9)


def rest_rows(station_ref: str, segments: int, more: float, simulation: dict | None = None) -> list[dict]:
    station = Station(with_settings(load_station(station_ref), segments, simulation or {}))
    sim = CableSimulator(station)
    goals = select_weld_goals(station, 0, MotionValidity(station, 0, 0.005).checker.collides)
    home_state = sim.get_state()
    rows = []
    for name, q in goals.items():
        sim.set_state(home_state)
        target = station.home.copy()
        target[0] = q
        sim.move_to(target)
        settle = sim.last_settle
        before = snapshot(sim)
        qflat, zero = sim.q.ravel(), np.zeros(sim.q.size)
        for _ in range(int(round(more / station.model.opt.timestep))):
            sim._step(qflat, zero)
        after = snapshot(sim)
        rows.append({
            "station": station_ref, "segments": segments, "weld": name,
            "settle_converged": bool(settle.converged), "settle_time_s": round(settle.time, 3),
            "force_residual": round(settle.equilibrium.force_residual, 5),
            "torque_residual": round(settle.equilibrium.torque_residual, 5),
            "drift_mm": round(1000 * float(np.linalg.norm(after["points"] - before["points"], axis=1).max()), 2),
            **{f"{k}_change_pct": round(percent(after[k], before[k]), 2)
               for k in ("tension", "twist_rate", "clamp_force", "clamp_torque")},
            **{f"{k}_settled": round(before[k], 4) for k in ("tension", "twist_rate", "clamp_force", "clamp_torque")},
        })
        print(json.dumps(rows[-1]), flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stations", nargs="+", default=["default", "default_variant"])
    parser.add_argument("--segments", nargs="+", type=int, default=[24, 48])
    parser.add_argument("--more", type=float, default=20.0, help="seconds simulated on after the settle")
    parser.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                        help="simulation settings to change, e.g. impratio=10 friction_cone=pyramidal")
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args()
    simulation = {k: (v if k == "friction_cone" else float(v)) for k, v in (x.split("=", 1) for x in args.set)}
    rows = [r for s in args.stations for n in args.segments for r in rest_rows(s, n, args.more, simulation)]
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
