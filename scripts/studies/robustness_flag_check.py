"""Issue 13's checks on a finished robustness map: do its non-robust flags survive a 10x tighter equilibrium
tolerance, and do its unconverged configurations converge with a 4x longer settle cap (and how do they flag)?

Every listed configuration is re-mapped from its own Ry's settled state (start "ry", so each is independent of
the grid row it sat in; the full map continues along rows), once with the map's settings ("rerun") and once with
the changed one, so the comparison isolates the change. Resumable (each run is a robustness-map folder).

    .venv/bin/python scripts/studies/robustness_flag_check.py --map maps/default_thesis_24336 --grid thesis_24336 \
        --out out/flag_check [--workers 2] [--sample N]

Writes OUT/flag_check.json (also printed)."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from dresspack_gym.io.loading import load_station, read_yaml
from dresspack_gym.maps.robustness.algorithm import RobustnessSettings
from dresspack_gym.maps.robustness.grid import RobustnessGrid
from dresspack_gym.maps.robustness.runner import run_map
from dresspack_gym.maps.robustness.store import _rows
from dresspack_gym.shipped import find_shipped

TIGHTER = 10.0  # the tolerance check: residual and speed tolerances divided by this
LONGER = 4.0  # the unconverged check: settle cap multiplied by this


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--map", default="maps/default_thesis_24336")
    p.add_argument("--grid", default="thesis_24336")
    p.add_argument("--station", default="default")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--sample", type=int, default=None,
                   help="a fixed random sample (seed 0) of at most this many configurations of each kind")
    p.add_argument("--out", default="out/flag_check")
    args = p.parse_args()
    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    rows = _rows(args.map)  # index -> (v, deviation, robust, converged)
    rng = np.random.default_rng(0)

    def pick(indices):
        indices = sorted(indices)
        if args.sample is None or len(indices) <= args.sample:
            return indices
        return sorted(rng.choice(indices, args.sample, replace=False).tolist())

    flagged = pick(i for i, (_, _, robust, conv) in rows.items() if conv and not robust)
    unconverged = pick(i for i, (_, _, _, conv) in rows.items() if not conv)
    base = load_station(args.station)
    sim = base.simulation
    tight = replace(base, name=base.name + "_tight", simulation=replace(
        sim, equilibrium_tolerance=sim.equilibrium_tolerance / TIGHTER, equilibrium_speed=sim.equilibrium_speed / TIGHTER))
    settings = RobustnessSettings(start="ry")
    longer = replace(settings, settle_time=settings.settle_time * LONGER)
    out = Path(args.out)

    def run(name, config, s, indices):
        run_map(grid, config, out / name, s, workers=args.workers, progress=True, indices=indices)
        return _rows(out / name)

    report = {"map": args.map, "grid": grid.name, "sample": args.sample, "flagged": len(flagged),
              "unconverged": len(unconverged)}
    rerun = run("flagged_rerun", base, settings, flagged)
    still = [i for i in flagged if rerun[i][3] and not rerun[i][2]]
    tight_rows = run("flagged_tight", tight, settings, still)
    survive = [i for i in still if tight_rows[i][3] and not tight_rows[i][2]]
    report["tolerance"] = {
        "flagged_again_in_rerun": len(still), "survive_10x_tighter": len(survive),
        "survive_fraction": len(survive) / len(still) if still else None,
        "tight_unconverged": sum(not tight_rows[i][3] for i in still),
        "survive_fraction_of_decided": (len(survive) / max(1, sum(tight_rows[i][3] for i in still))) if still else None,
        "note": "flags of the full map re-mapped from Ry's state; of those flagged again, how many stay flagged "
                "with residual and speed tolerances 10x tighter"}
    long_rows = run("unconverged_longer_cap", base, longer, unconverged)
    converged = [i for i in unconverged if long_rows[i][3]]
    report["longer_cap"] = {
        "settle_cap_s": longer.settle_time, "converge_now": len(converged),
        "robust_among_converged": sum(long_rows[i][2] for i in converged),
        "non_robust_among_converged": sum(not long_rows[i][2] for i in converged),
        "still_unconverged": len(unconverged) - len(converged)}
    (out / "flag_check.json").write_text(json.dumps(report, indent=2))
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
