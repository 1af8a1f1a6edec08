"""The fatigue calibration table: each published rated test (physics/ratings.py RATED_TESTS) simulated on a dresspack's
cable with its fatigue model, rated life against simulated life; ``--fit`` also prints the strain and torsion radii
that make the simulated lives the rated ones (what configs/dresspacks/stud_welding_rated.yaml ships). Usage:
  PYTHONPATH=. .venv/bin/python scripts/studies/fatigue_calibration.py --dresspack stud_welding_rated [--fit]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from dresspack_gym.cable.config import DresspackConfig
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.loading import read_yaml
from dresspack_gym.physics.ratings import calibrate, calibration_table
from dresspack_gym.shipped import find_shipped

# this checkout's dresspacks first, then the installed package's
REPO_DRESSPACKS = Path(__file__).resolve().parents[2] / "configs" / "dresspacks"


def load_dresspack(ref: str) -> DresspackConfig:
    path = REPO_DRESSPACKS / f"{ref}.yaml"
    path = path if path.is_file() else find_shipped(ref, "dresspacks", "--dresspack")
    return DresspackConfig.from_dict(read_yaml(path, "--dresspack"))


def table(rows: list[dict]) -> str:
    head = "| rated test | kind | rated life [cycles] | simulated life [cycles] | simulated / rated |"
    lines = [head, "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['test']} | {r['kind']} | {r['rated_cycles']:,.0f} | {r['simulated_cycles']:,.0f} | "
                     f"{r['ratio']:.3f} |")
    return "\n".join(lines + [""] + [f"- {r['test']}: {r['source']}" for r in rows])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dresspack", default="stud_welding_rated", help="a shipped dresspack name or a YAML path")
    p.add_argument("--fit", action="store_true", help="also fit the strain and torsion radii to the ratings")
    args = p.parse_args(argv)
    try:
        dp = load_dresspack(args.dresspack)
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"dresspack {dp.name}: outer diameter {2 * dp.radius * 1e3:.0f} mm, strain radius "
          f"{dp.fatigue.strain_radius * 1e3:.3g} mm, torsion radius {dp.fatigue.shear_radius * 1e3:.3g} mm")
    print(table(calibration_table(dp)))
    if args.fit:
        fitted = calibrate(dp)
        print(f"\nfitted: strain_radius {fitted.strain_radius:.4g} m, torsion_radius {fitted.torsion_radius:.4g} m")
        print(table(calibration_table(replace(dp, fatigue=fitted))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
