"""Does the time law change the robustness map? Re-map configurations that an earlier run mapped under version 0's
cubic law (a robustness-map folder with start "ry", e.g. the "flagged_rerun" of
scripts/studies/robustness_flag_check.py) with the current law and the same settings, and compare flags and deviations
configuration by configuration.

    .venv/bin/python scripts/studies/robustness_time_law_check.py --old out/flag_check/flagged_rerun \
        --grid thesis_24336 --out out/law_check [--workers 2]

Writes OUT/time_law_check.json (also printed). Resumable (the new run is a robustness-map folder)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from dresspack_gym.io.loading import load_station, read_yaml
from dresspack_gym.maps.robustness.algorithm import RobustnessSettings
from dresspack_gym.maps.robustness.grid import RobustnessGrid
from dresspack_gym.maps.robustness.runner import run_map
from dresspack_gym.maps.robustness.store import _rows
from dresspack_gym.robots.time_law import TIME_LAW
from dresspack_gym.shipped import find_shipped


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--old", required=True, help="a map folder computed with the cubic law, start 'ry'")
    p.add_argument("--grid", default="thesis_24336")
    p.add_argument("--station", default="default")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", default="out/law_check")
    args = p.parse_args()
    old_meta = json.loads((Path(args.old) / "meta.json").read_text())
    if "time_law" in old_meta:  # maps record their law since the cubic was replaced
        raise SystemExit(f"--old {args.old} was not computed with the cubic law: {old_meta['time_law']}")
    settings = RobustnessSettings(**{**old_meta["settings"], "excursion": tuple(old_meta["settings"]["excursion"])})
    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    old = _rows(args.old)  # index -> (v, deviation, robust, converged)
    indices = sorted(old)
    out = Path(args.out)
    run_map(grid, load_station(args.station), out, settings, workers=args.workers, progress=True, indices=indices)
    new = _rows(out)
    both = [i for i in indices if old[i][3] and new[i][3]]  # converged under both laws
    dev_old = np.array([old[i][1] for i in both])
    dev_new = np.array([new[i][1] for i in both])
    report = {
        "old": args.old, "grid": grid.name, "configurations": len(indices), "time_law": TIME_LAW,
        "converged_both": len(both),
        "unconverged_old": sum(not old[i][3] for i in indices), "unconverged_new": sum(not new[i][3] for i in indices),
        "non_robust_old": sum(not old[i][2] for i in both), "non_robust_new": sum(not new[i][2] for i in both),
        "same_flag": sum(old[i][2] == new[i][2] for i in both),
        "deviation_median_abs_change_m": float(np.median(np.abs(dev_new - dev_old))) if both else None,
        "deviation_correlation": float(np.corrcoef(dev_old, dev_new)[0, 1]) if len(both) > 2 else None,
    }
    (out / "time_law_check.json").write_text(json.dumps(report, indent=2))
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
