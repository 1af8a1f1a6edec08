"""Each leg's simulated wear (its robot's cable alone, as the station planner runs it) against that leg's part of
the station replay (every robot and cable on one clock): how far the solver's per-leg figures are from the cycle.

    .venv/bin/python scripts/station_leg_wear_check.py station_plans/time --station side_framing_4r

Reads a plan folder written by ``dresspack station-plan`` (plan.json and one trajectory per robot), replays it, runs
every leg alone and prints per leg both integrals and their difference; ``--out`` writes them as JSON. It first
prints where the replayed wear accrues (by what each robot was doing, and by the cost's terms); ``--split-only``
stops there."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def main() -> None:
    from dresspack.agents.station_planning import RECORD_EVERY, StationPlanConfig, StationPlanner

    from dresspack_gym.loading import load_station
    from dresspack_gym.station import Station
    from dresspack_gym.station_schedule import RobotSchedule, StationSchedule

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("plan", type=Path, help="a plan folder (plan.json, <robot>.npz)")
    ap.add_argument("--station", default="side_framing_4r")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--split-only", action="store_true", help="print the wear split and skip the per-leg runs")
    args = ap.parse_args()

    station = Station(load_station(args.station))
    plan = json.loads((args.plan / "plan.json").read_text())
    config = StationPlanConfig(cost_variant=plan["config"]["cost_variant"], cable_repairs=0)
    planner = StationPlanner(station, config)
    weld_time = float(plan["config"]["weld_time"])
    robots = []
    for r, (name, info) in enumerate(plan["robots"].items()):
        data = np.load(args.plan / info["trajectory"])
        stops = np.r_[0, data["stops"]]
        legs = tuple(data["waypoints"][a:b + 1] for a, b in zip(stops[:-1], stops[1:]))
        robots.append(RobotSchedule(r, tuple(info["welds"]), legs, np.array(info["leg_start"]), planner.limits[r],
                                    weld_time))
    schedule = StationSchedule(tuple(robots), station.home)

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
    # the replay's samples do not fall on the legs' ends: its running integral per robot, interpolated there
    running = np.vstack([np.zeros(replay.cost.shape[1]),
                         np.cumsum(0.5 * (replay.cost[1:] + replay.cost[:-1]) * np.diff(replay.time)[:, None],
                                   axis=0)])
    for s in robots:
        name = station.config.robots[s.robot].name
        for k, leg in enumerate(s.legs):
            weld = weld_time if k < len(s.welds) else 0.0
            run = planner.leg_run(s.robot, leg, weld)
            start, end = s.leg_start[k], s.leg_start[k] + s.leg_durations()[k] + weld
            own = running[:, s.robot]
            part = float(np.interp(end, replay.time, own) - np.interp(start, replay.time, own))
            rows.append({"robot": name, "leg": k, "vias": len(leg) - 2, "alone": run.wear, "replay": part,
                         "difference": run.wear / part - 1.0 if part > 0 else None,
                         "max_tension_alone": run.max_tension})
            print(f"{name} leg {k:2d} ({len(leg) - 2} vias): alone {run.wear:8.1f}  in the replay {part:8.1f}  "
                  f"({100 * rows[-1]['difference']:+.2f} %)")
    diffs = np.array([abs(r["difference"]) for r in rows if r["difference"] is not None])
    print(f"{len(rows)} legs: median |difference| {100 * np.median(diffs):.2f} %, largest {100 * diffs.max():.2f} %, "
          f"over 1 %: {int((diffs > 0.01).sum())}")
    if args.out is not None:
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
