"""Planning time of two planners on the same tasks, measured in one run (alternating plan by plan, so machine load
falls on both alike): the ratio issue 17 asks for between ompl-wear-fmt and ompl-wear.

    .venv/bin/python scripts/studies/planner_time_ratio.py --station thesis_tension --seeds 0 1 2 \
        --planners ompl-wear ompl-wear-fmt --out docs/data/planner_time_ratio.json
    .venv/bin/python scripts/studies/planner_time_ratio.py --planners ompl-wear:no-map ompl-wear \
        --out docs/data/planner_time_ratio_map.json   # with the wear map against the via routes alone

A planner name ending in ``:no-map`` plans without the wear map (``wear_map=False``: direct and via routes only,
the global planner as it was before the map).

Each plan is timed alone (planning only, not the replay); the planners are built once per seed (the map's roadmap
or FMT* search set up outside the timed plan, as a planner reused over tasks would be)."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path


def main() -> None:
    from dresspack.agents.planners.registry import make_planner

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station
    from dresspack_gym.stations.tasks import make_task

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--station", default="thesis_tension")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--planners", nargs=2, default=["ompl-wear", "ompl-wear-fmt"])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    for name in args.planners:
        if name.partition(":")[2] not in ("", "no-map"):
            ap.error(f"--planners: {name!r}: the only suffix is ':no-map'")
    station = Station(load_station(args.station))
    rows = []
    for seed in args.seeds:
        for name in args.planners:
            base, _, variant = name.partition(":")
            planner = make_planner(base, station, 0, seed=seed, **({"wear_map": False} if variant else {}))
            task = make_task(station, 0, planner.validity.checker.collides, None)
            t = time.perf_counter()
            result = planner.plan(task)
            rows.append({"planner": name, "seed": seed, "plan_seconds": round(time.perf_counter() - t, 2),
                         "objective": result.info.get("objective"),
                         "cable_evaluations": result.info.get("cable_evaluations")})
            print(json.dumps(rows[-1]), flush=True)
    total = {n: sum(r["plan_seconds"] for r in rows if r["planner"] == n) for n in args.planners}
    summary = {"station": args.station, "seeds": args.seeds, "plans": rows, "total_seconds": total,
               "ratio": total[args.planners[1]] / total[args.planners[0]]}
    print(json.dumps(summary, indent=1))
    if args.out:
        args.out.write_text(json.dumps(summary, indent=1) + "\n")


if __name__ == "__main__":
    main()
