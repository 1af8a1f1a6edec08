"""Each leg's simulated wear (its robot's cable alone, as the station planner runs it) against that leg's part of
the station replay (every robot and cable on one clock): how far the solver's per-leg figures are from the cycle.

    .venv/bin/python scripts/studies/station_leg_wear_check.py station_plans/time --station side_framing_4r

Reads a plan folder written by ``dresspack station-plan`` (plan.json and one trajectory per robot), replays it, runs
every leg alone and prints per leg both integrals and their difference; ``--out`` writes them as JSON. It first
prints where the replayed wear accrues (by what each robot was doing, and by the cost's terms); ``--split-only``
stops there.

``--path-order`` explains the legs that differ: it also runs each robot's whole program alone, in path order (each
leg from the state the previous one left, as in the replay but without the other robots), and for every leg more
than 1 % off settles the carried state at the leg's start and compares that equilibrium with the one a fresh
settle there finds (the leg runs' start). Two different equilibria (the cable's shape depends on the way it came)
make the legs differ however exact the simulation is."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main() -> None:
    from dresspack.agents.stations import RECORD_EVERY, StationPlanConfig, StationPlanner

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.multi.schedule import load_schedule
    from dresspack_gym.stations.station import Station

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("plan", type=Path, help="a plan folder (plan.json, <robot>.npz)")
    ap.add_argument("--station", default="side_framing_4r")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--split-only", action="store_true", help="print the wear split and skip the per-leg runs")
    ap.add_argument("--path-order", action="store_true",
                    help="also run each robot's program alone in path order and check the legs' start equilibria")
    args = ap.parse_args()

    station = Station(load_station(args.station))
    plan = json.loads((args.plan / "plan.json").read_text())
    # legs fly by their via points as the plan did (a plan.json without fly_by stopped at each)
    config = StationPlanConfig(cost_variant=plan["config"]["cost_variant"], cable_repairs=0,
                               fly_by=plan["config"].get("fly_by", False))
    planner = StationPlanner(station, config)
    schedule, _ = load_schedule(args.plan, station)  # a plan.json without fly_by: every leg stops
    robots = schedule.robots

    class _Plan:  # what StationPlanner.replay reads
        pass

    holder = _Plan()
    holder.schedule = schedule
    replay = planner.replay(holder, record_every=RECORD_EVERY)
    split = replay.wear_split(schedule)
    print(f"replayed ∫C dt {replay.integrated_cost().sum():.1f}, makespan {schedule.makespan:.2f} s")
    for by in ("by_phase", "by_term"):
        total = {k: sum(v[by][k] for v in split.values()) for k in split[0][by]}
        print(f"  {by.replace('_', ' ')}: " + ", ".join(f"{k} {v:.1f}" for k, v in total.items()))
    if args.split_only:
        return
    rows = []
    running = _running_integral(replay.time, replay.cost)
    for s in robots:
        name = station.config.robots[s.robot].name
        for k, leg in enumerate(s.legs):
            start, end, weld = _leg_window(s, k)
            run = planner.legs.run(s.robot, leg, weld)
            part = _between(replay.time, running[:, s.robot], start, end)
            rows.append({"robot": name, "leg": k, "vias": len(leg) - 2, "alone": run.wear, "replay": part,
                         "difference": run.wear / part - 1.0 if part > 0 else None,
                         "max_tension_alone": run.max_tension})
            print(f"{name} leg {k:2d} ({len(leg) - 2} vias): alone {run.wear:8.1f}  in the replay {part:8.1f}  "
                  f"({100 * rows[-1]['difference']:+.2f} %)")
    if args.path_order:
        explain_in_path_order(planner, station, robots, rows)
    diffs = np.array([abs(r["difference"]) for r in rows if r["difference"] is not None])
    print(f"{len(rows)} legs: median |difference| {100 * np.median(diffs):.2f} %, largest {100 * diffs.max():.2f} %, "
          f"over 1 %: {int((diffs > 0.01).sum())}")
    if args.out is not None:
        args.out.write_text(json.dumps(rows, indent=1))


def _leg_window(schedule, k: int) -> tuple[float, float, float]:
    """Leg ``k``'s part of its robot's cycle: (start, end) [s] of its motion and the weld after it, and that weld's
    time (none after the last leg, into Home)."""
    weld = schedule.weld_time if k < len(schedule.welds) else 0.0
    start = float(schedule.leg_start[k])
    return start, start + schedule.leg_durations()[k] + weld, weld


def _running_integral(t: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """The trapezoid integral of ``rate`` (samples along axis 0 at times ``t``) from ``t[0]`` to each sample."""
    rate = np.asarray(rate, dtype=float)
    dt = np.diff(t).reshape(-1, *([1] * (rate.ndim - 1)))
    return np.concatenate([np.zeros((1, *rate.shape[1:])), np.cumsum(0.5 * (rate[1:] + rate[:-1]) * dt, axis=0)])


def _between(t: np.ndarray, running: np.ndarray, start: float, end: float) -> float:
    """The integral from ``start`` to ``end``: samples do not fall on a leg's ends, so the running integral is
    interpolated there."""
    return float(np.interp(end, t, running) - np.interp(start, t, running))


def explain_in_path_order(planner, station, robots, rows) -> None:
    """Per robot, its program alone from Home in path order; per leg more than 1 % off, the carried start state
    settled against a fresh settle at the same configuration (adds ``alone_in_path_order`` and, for those legs,
    ``start_equilibria`` to ``rows``)."""
    from dresspack.agents.stations import RECORD_EVERY

    from dresspack_gym.multi.schedule import RobotSchedule, StationSchedule
    from dresspack_gym.physics.wear_cost import cost_function

    cost_fn, weights = cost_function(planner.config.cost_variant), station.config.wear_cost
    for s in robots:
        name = station.config.robots[s.robot].name
        own = [r for r in rows if r["robot"] == name]
        sim = planner.costs.alone(s.robot)
        alone = RobotSchedule(0, s.welds, s.legs, s.leg_start, s.limits, s.weld_time, s.fly_by)
        program = StationSchedule((alone,), station.home[None, s.robot])
        sim.reset(station.home[None, s.robot])
        first = sim.cable_measures()
        times, samples = sim.follow(program.at, alone.end_time, record_every=RECORD_EVERY)
        t = np.array([0.0, *times])
        rate = np.array([cost_fn(m[0], weights).total for m in [first, *samples]])
        running = _running_integral(t, rate)
        for k, row in enumerate(own):
            start, end, _ = _leg_window(s, k)
            row["alone_in_path_order"] = _between(t, running, start, end)
            line = (f"{name} leg {k:2d}: alone from settled {row['alone']:8.1f}, alone in path order "
                    f"{row['alone_in_path_order']:8.1f}, in the replay {row['replay']:8.1f}")
            if row["difference"] is not None and abs(row["difference"]) > 0.01:
                row["start_equilibria"] = _start_equilibria(sim, program, start, s.legs[k][0], cost_fn, weights)
                e = row["start_equilibria"]
                line += (f"\n    start: carried and settled C {e['carried']['cost_rate']:.1f} (converged "
                         f"{e['carried']['converged']}), fresh settle C {e['fresh']['cost_rate']:.1f} (converged "
                         f"{e['fresh']['converged']}); cable points up to {e['largest_point_distance']:.3f} m apart, "
                         f"total twist {e['carried']['total_twist']:.2f} vs {e['fresh']['total_twist']:.2f} rad")
            print(line)


def _start_equilibria(sim, program, start: float, q, cost_fn, weights) -> dict:
    """The cable at time ``start`` of ``program`` (run from settled at Home), settled, against a fresh settle at
    ``q``: their cost rates, convergence, total twist and how far apart their points lie."""
    from dresspack.agents.stations import RECORD_EVERY

    sim.reset(program.homes)  # the program starts at its robot's Home, as the whole run did
    sim.follow(program.at, start, record_every=RECORD_EVERY)
    out = {}
    result = sim.settle()
    m = sim.measures()
    out["carried"] = {"cost_rate": float(cost_fn(m, weights).total), "converged": bool(result.converged),
                      "total_twist": float(m.total_twist)}
    carried = sim.cable_points(0).copy()
    sim.reset(np.asarray(q)[None])
    m = sim.measures()
    out["fresh"] = {"cost_rate": float(cost_fn(m, weights).total), "converged": bool(sim.last_settle.converged),
                    "total_twist": float(m.total_twist)}
    out["largest_point_distance"] = float(np.abs(sim.cable_points(0) - carried).max())
    return out


if __name__ == "__main__":
    main()
