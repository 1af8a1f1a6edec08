"""The README's table of the thesis scenarios: every planner on thesis_curvature, thesis_tension and
thesis_distance, seeds 0 and 1, default work budgets (what
`dresspack plan --station SCENARIO --planner P --seed S --json` gives, with those budgets passed explicitly), one plan
after another.

    .venv/bin/python scripts/studies/scenario_table.py [--out docs/data/scenario_table.json] [--seeds 0 1] \
        [--scenarios curvature]

Writes one JSON row per plan (appended as it goes, so an interrupted run resumes) and prints the README's
markdown rows."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

SCENARIOS = ("curvature", "tension", "distance")
PLANNERS = ("ompl", "thesis-local", "ompl-wear")
BUDGET = {"iterations": 3000, "routes": 12, "evaluations": 40}  # the CLI's defaults
COLUMNS = (("cycle_time", "{:.2f}"), ("max_curvature", "{:.1f}"), ("max_tension", "{:.0f}"),
           ("min_clearance", "{:.3f}"), ("max_twist_rate", "{:.2f}"), ("cost", "{:.3g}"), ("planning_time", "{:.1f}"))


def plan(dresspack: list[str], scenario: str, planner: str, seed: int) -> dict:
    cmd = [*dresspack, "plan", "--station", f"thesis_{scenario}", "--planner", planner, "--seed", str(seed), "--json",
           *[a for k, v in BUDGET.items() for a in (f"--{k}", str(v))]]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    return json.loads(done.stdout)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/data/scenario_table.json"))
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS))
    ap.add_argument("--dresspack", nargs="+", default=[str(Path(sys.executable).with_name("dresspack"))],
                    help="the dresspack command (default: the one beside this Python)")
    args = ap.parse_args()
    rows = json.loads(args.out.read_text()) if args.out.exists() else []
    have = {(r["scenario"], r["planner"], r["seed"]) for r in rows}
    for scenario in args.scenarios:
        for planner in PLANNERS:
            for seed in args.seeds:
                if (scenario, planner, seed) in have:
                    continue
                t = time.perf_counter()
                s = plan(args.dresspack, scenario, planner, seed)
                rows.append({"scenario": scenario, "planner": planner, "seed": seed,
                             "budget": BUDGET,
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
