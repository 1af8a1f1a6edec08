"""Issue 17's measurement: does the global wear-aware planner find the route under the cuboid on thesis_tension
and on three variants (cuboid moved -10 / +10 cm along x, cuboid enlarged 20 %), for every seed?

    .venv/bin/python scripts/studies/tension_route_study.py --seeds 20 --out out/tension_study [--workers 2]
    .venv/bin/python scripts/studies/tension_route_study.py --planner ompl-wear-fmt --seeds 5 --baseline-seeds 0 \
        --out out/tension_study_fmt

Appends one JSON line per plan to OUT/plans.jsonl (resumable: finished plans are skipped) and writes
OUT/summary.json: per variant the best route's max tension, how many seeds came within 2x of it, cycle times,
planning times, and (seeds 0-4) the same without the wear map (via routes only) for the time ratio."""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

VARIANTS = ("shipped", "moved_-10cm", "moved_+10cm", "enlarged_20pct")


def station_config(variant: str):
    from dresspack_gym.io.loading import load_station

    config = load_station("thesis_tension")
    if variant == "shipped":
        return config
    obstacles = []
    for o in config.obstacles:
        if variant.startswith("moved"):
            dx = -0.1 if "-10" in variant else 0.1
            o = replace(o, pos=(o.pos[0] + dx, o.pos[1], o.pos[2]))
        elif o.name == "cuboid":
            o = replace(o, size=tuple(1.2 * v for v in o.size))
        obstacles.append(o)
    return replace(config, obstacles=tuple(obstacles), name=f"thesis_tension_{variant}")


def plan_one(job: tuple[str, int, bool, str]) -> dict:
    from dresspack.agents.planners.registry import plan_station

    from dresspack_gym.stations.station import Station

    variant, seed, use_map, planner = job
    kwargs = {} if use_map else {"wear_map": False}
    t = time.perf_counter()
    s = plan_station(Station(station_config(variant)), planner, seed=seed, **kwargs).summary()
    if use_map and s["planner_info"].get("wear_map") is None:  # e.g. the shipped map renamed while this ran
        raise RuntimeError(f"{variant} seed {seed}: planned without a wear map; no row written")
    return {"variant": variant, "seed": seed, "map": use_map, "planner": planner, "max_tension": s["max_tension"],
            "cycle_time": s["cycle_time"], "cost": s["cost"], "unconverged_stops": s["unconverged_stops"],
            "plan_seconds": round(time.perf_counter() - t, 2),
            "wear_map": s["planner_info"].get("wear_map")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--baseline-seeds", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("out/tension_study"))
    ap.add_argument("--planner", default="ompl-wear", choices=("ompl-wear", "ompl-wear-fmt"))
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    log = args.out / "plans.jsonl"
    done = [json.loads(x) for x in log.read_text().splitlines() if x.strip()] if log.exists() else []
    done = [d for d in done if d.get("planner", "ompl-wear") == args.planner]  # rows before planners were named
    have = {(d["variant"], d["seed"], d["map"], args.planner) for d in done}
    jobs = [(v, s, True, args.planner) for v in args.variants for s in range(args.seeds)]
    jobs += [(v, s, False, args.planner) for v in args.variants[:1] for s in range(args.baseline_seeds)]
    jobs = [j for j in jobs if j not in have]
    with ProcessPoolExecutor(args.workers) as pool, log.open("a") as f:
        for row in pool.map(plan_one, jobs):
            f.write(json.dumps(row) + "\n")
            f.flush()
            done.append(row)
            print(json.dumps(row), flush=True)
    summary = {}
    for v in VARIANTS:
        rows = [d for d in done if d["variant"] == v and d["map"]]
        if not rows:
            continue
        best = min(d["max_tension"] for d in rows)
        summary[v] = {"plans": len(rows), "best_max_tension": best,
                      "within_2x_of_best": sum(d["max_tension"] <= 2 * best for d in rows),
                      "max_tension": sorted(round(d["max_tension"], 1) for d in rows),
                      "mean_cycle_time": sum(d["cycle_time"] for d in rows) / len(rows),
                      "mean_plan_seconds": sum(d["plan_seconds"] for d in rows) / len(rows)}
    base = [d for d in done if not d["map"]]
    if base:
        with_map = [d for d in done if d["map"] and d["variant"] == "shipped" and d["seed"] < len(base)]
        summary["without_map_shipped"] = {
            "plans": len(base), "max_tension": sorted(round(d["max_tension"], 1) for d in base),
            "mean_plan_seconds": sum(d["plan_seconds"] for d in base) / len(base),
            "plan_time_ratio_map_over_no_map": (sum(d["plan_seconds"] for d in with_map)
                                                / max(1e-9, sum(d["plan_seconds"] for d in base[:len(with_map)])))}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
