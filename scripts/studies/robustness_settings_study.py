"""Robustness-map settings study: flag agreement of faster settings with a slow quasi-static reference.

Maps the same fixed random sample of a grid (start "ry": every configuration from its Ry's settled
state, so configurations are independent) with each setting, and reports per setting the non-robust
fraction, the agreement of the robust flags with the reference, the unconverged count and the wall time
per configuration. Usage (from the repository root):

    .venv/bin/python scripts/studies/robustness_settings_study.py --grid thesis_67500 --sample 100 --out out/study
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from dresspack_gym.io.loading import load_station, read_yaml
from dresspack_gym.maps.robustness.algorithm import RobustnessSettings
from dresspack_gym.maps.robustness.grid import RobustnessGrid
from dresspack_gym.maps.robustness.runner import run_map
from dresspack_gym.maps.robustness.store import load_results, load_unconverged
from dresspack_gym.shipped import find_shipped

REFERENCE = RobustnessSettings(start="ry", speed_fraction=0.125, min_speed_fraction=0.125, max_dynamic_ratio=1.0,
                               timestep=0.002, settle_timestep=0.008)
CANDIDATES = {
    "rated speed, 4/16 ms": RobustnessSettings(start="ry", speed_fraction=1.0, min_speed_fraction=1.0,
                                               max_dynamic_ratio=1.0),
    "half speed, 4/16 ms": RobustnessSettings(start="ry", speed_fraction=0.5, min_speed_fraction=0.5,
                                              max_dynamic_ratio=1.0),
    "quarter speed, 4/16 ms": RobustnessSettings(start="ry", speed_fraction=0.25, min_speed_fraction=0.25,
                                                 max_dynamic_ratio=1.0),
    "adaptive (<= 0.2 g), 4/16 ms": RobustnessSettings(start="ry", speed_fraction=0.5, min_speed_fraction=0.125,
                                                       max_dynamic_ratio=0.2),
    "adaptive from 1/4 (<= 0.5 g), 4/16 ms": RobustnessSettings(start="ry", speed_fraction=0.25,
                                                                min_speed_fraction=1 / 16, max_dynamic_ratio=0.5),
    "rated speed, contact on": RobustnessSettings(start="ry", speed_fraction=1.0, min_speed_fraction=1.0,
                                                  max_dynamic_ratio=1.0, cable_robot_contact=True),
}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grid", default="thesis_67500")
    p.add_argument("--station", default="default")
    p.add_argument("--sample", type=int, default=100)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--out", default="out/robustness_study")
    args = p.parse_args()
    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    station = load_station(args.station)
    idx = sorted(np.random.default_rng(args.seed).choice(len(grid), args.sample, replace=False).tolist())
    out = Path(args.out)
    report = {"grid": grid.name, "sample": len(idx), "seed": args.seed, "settings": {}}

    def run(name: str, settings: RobustnessSettings) -> dict[int, bool]:
        folder = out / name.replace(" ", "_").replace("/", "-").replace(",", "").replace("(", "").replace(")", "")
        t = time.perf_counter()
        summary = run_map(grid, station, folder, settings, workers=args.workers, progress=True, indices=idx)
        wall = time.perf_counter() - t
        rows = load_results(folder)
        report["settings"][name] = {"fraction_non_robust": summary["fraction_non_robust"],
                                    "n_unconverged": len(load_unconverged(folder)),
                                    "wall_s_per_config": wall / len(idx), "settings": repr(settings)}
        return {i: rows[i][2] for i in idx}

    ref = run("reference (1/8 speed, 2/8 ms)", REFERENCE)
    for name, settings in CANDIDATES.items():
        flags = run(name, settings)
        report["settings"][name]["agreement_with_reference"] = float(np.mean([flags[i] == ref[i] for i in idx]))
    (out / "study.json").write_text(json.dumps(report, indent=2))
    for name, r in report["settings"].items():
        print(f"{name:32s} non-robust {100 * r['fraction_non_robust']:5.1f} %  unconverged {r['n_unconverged']:3d}  "
              f"agreement {100 * r.get('agreement_with_reference', 1.0):5.1f} %  {r['wall_s_per_config']:.2f} s/config")


if __name__ == "__main__":
    main()


def tolerance_check(grid_name: str = "thesis_67500", sample: int = 100, seed: int = 0, out: str = "out/robustness_tol",
                    workers: int = 1) -> dict:
    """Fraction of non-robust flags that survive a 10x tighter equilibrium tolerance (default settings)."""
    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(grid_name, "grids", "grid"), "grid"))
    base = load_station("default")
    sim = base.simulation
    tight = replace(base, simulation=replace(sim, equilibrium_tolerance=sim.equilibrium_tolerance / 10,
                                             equilibrium_speed=sim.equilibrium_speed / 10))
    idx = sorted(np.random.default_rng(seed).choice(len(grid), sample, replace=False).tolist())
    flags = {}
    for name, cfg in (("default", base), ("tight", replace(tight, name=tight.name + "_tight"))):
        run_map(grid, cfg, Path(out) / name, RobustnessSettings(start="ry"), workers=workers, progress=True,
                indices=idx)
        rows = load_results(Path(out) / name)
        flags[name] = {i: rows[i][2] for i in idx}
    non_robust = [i for i in idx if not flags["default"][i]]
    survive = [i for i in non_robust if not flags["tight"][i]]
    return {"n": len(idx), "non_robust_default": len(non_robust), "survive_tight": len(survive),
            "agreement": float(np.mean([flags["default"][i] == flags["tight"][i] for i in idx]))}
