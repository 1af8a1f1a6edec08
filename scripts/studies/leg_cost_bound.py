"""Planning time with and without bounded leg-cost queries, measured in one run: each drawn weld planned by one
planner twice in a row (bounded first, then every query simulated to its leg's end), so machine load falls on both
alike; the two plans must be the same route.

    PYTHONPATH=. .venv/bin/python scripts/studies/leg_cost_bound.py --planner ompl-wear --welds 0-9 \
        --out docs/data/leg_cost_bound_ompl_wear.json
    PYTHONPATH=. .venv/bin/python scripts/studies/leg_cost_bound.py --planner ppo-search --welds 0-9 \
        --out docs/data/leg_cost_bound_ppo_search.json

The welds are the evaluation's drawn welds (``dresspack eval --drawn-tasks 30 --seeds 0 --start-noise-deg 10``:
the same tasks and start). A query is unbounded here by giving it no ``give_up`` (what ``LegCost`` did before
bounds). Times are planning only, not the replay.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def weld_range(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def main() -> None:
    from dresspack.agents.planners.leg_cost import LegCost
    from dresspack.agents.planners.registry import make_planner
    from dresspack.eval.runs import EvalSpec, build_tasks

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--planner", default="ompl-wear")
    ap.add_argument("--station", default="default")
    ap.add_argument("--welds", type=weld_range, default=weld_range("0-9"), help="drawn welds, e.g. 0-9")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    spec = EvalSpec(station=args.station, methods=(args.planner,), drawn_tasks=30, seeds=(args.seed,),
                    start_noise_deg=10.0)
    station = Station(load_station(args.station))
    tasks = build_tasks(station, spec)
    bounded_above = LegCost._above
    rows = []
    for k in args.welds:
        task = tasks[((f"drawn_{k}",), args.seed)]
        plans = {}
        for mode in ("bounded", "unbounded"):
            LegCost._above = bounded_above if mode == "bounded" else (lambda self, traj, bound: None)
            planner = make_planner(args.planner, station, 0, seed=args.seed)
            t = time.perf_counter()
            try:
                result = planner.plan(task)
            except Exception as exc:  # a failed plan fails alike both ways; recorded, not fatal
                plans[mode] = (time.perf_counter() - t, None, str(exc))
                continue
            plans[mode] = (time.perf_counter() - t, result, None)
        LegCost._above = bounded_above
        (tb, rb, eb), (tu, ru, eu) = plans["bounded"], plans["unbounded"]
        same = (rb is None and ru is None and eb == eu) or (
            rb is not None and ru is not None and np.array_equal(rb.trajectory.waypoints, ru.trajectory.waypoints))
        row = {"weld": f"drawn_{k}", "same_route": bool(same), "bounded_s": round(tb, 2), "unbounded_s": round(tu, 2),
               "error": eb or eu}
        if rb is not None:
            row.update(cable_evaluations=rb.info.get("cable_evaluations"),
                       given_up=rb.info.get("cable_simulations_given_up"),
                       unbounded_cable_evaluations=ru.info.get("cable_evaluations") if ru is not None else None)
        rows.append(row)
        print(json.dumps(row), flush=True)
    tb, tu = sum(r["bounded_s"] for r in rows), sum(r["unbounded_s"] for r in rows)
    summary = {"planner": args.planner, "station": args.station, "seed": args.seed, "welds": len(rows),
               "same_routes": sum(r["same_route"] for r in rows), "bounded_s": round(tb, 1),
               "unbounded_s": round(tu, 1), "speedup": round(tu / tb, 3),
               "given_up": sum(r.get("given_up") or 0 for r in rows),
               "cable_evaluations": sum(r.get("cable_evaluations") or 0 for r in rows)}
    print(json.dumps(summary))
    if args.out is not None:
        args.out.write_text(json.dumps({"summary": summary, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
