"""The README's table of the thesis scenarios: every planner on thesis_curvature, thesis_tension and
thesis_distance, seeds 0 and 1, default work budgets (what `dresspack plan SCENARIO --planner P --seed S --json`
gives), one plan after another in this process.

    .venv/bin/python scripts/scenario_table.py [--out docs/scenario_table.json] [--seeds 0 1]

Writes one JSON row per plan (appended as it goes, so an interrupted run resumes) and prints the README's
markdown rows."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

SCENARIOS = ("curvature", "tension", "distance")
PLANNERS = ("ompl", "thesis-local", "ompl-wear")
COLUMNS = (("cycle_time", "{:.2f}"), ("max_curvature", "{:.1f}"), ("max_tension", "{:.0f}"),
           ("min_clearance", "{:.3f}"), ("max_twist_rate", "{:.2f}"), ("cost", "{:.3g}"), ("planning_time", "{:.1f}"))


def main() -> None:
    from dresspack.agents.budget import Budget
    from dresspack.agents.planning import plan_station

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/scenario_table.json"))
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = ap.parse_args()
    rows = json.loads(args.out.read_text()) if args.out.exists() else []
    have = {(r["scenario"], r["planner"], r["seed"]) for r in rows}
    budget = Budget()
    for scenario in SCENARIOS:
        for planner in PLANNERS:
            for seed in args.seeds:
                if (scenario, planner, seed) in have:
                    continue
                t = time.perf_counter()
                s = plan_station(f"thesis_{scenario}", planner, seed=seed).summary()
                rows.append({"scenario": scenario, "planner": planner, "seed": seed,
                             "budget": {"iterations": budget.iterations, "routes": budget.routes,
                                        "evaluations": budget.evaluations},
                             **{k: s[k] for k, _ in COLUMNS if k in s},
                             "unconverged_stops": s["unconverged_stops"],
                             "with_replay_seconds": round(time.perf_counter() - t, 1)})
                args.out.write_text(json.dumps(rows, indent=1))
                print(json.dumps(rows[-1]), flush=True)
    for scenario in SCENARIOS:
        for planner in PLANNERS:
            got = sorted((r for r in rows if r["scenario"] == scenario and r["planner"] == planner),
                         key=lambda r: r["seed"])
            if got:
                cells = [" / ".join(fmt.format(r[k]) for r in got) for k, fmt in COLUMNS]
                print(f"| {scenario} | {planner} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
