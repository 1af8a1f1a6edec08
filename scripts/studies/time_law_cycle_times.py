"""Cycle times of the demo before and after the time law changed from version 0's cubic to Ruckig's profile.

Two comparisons per method: the very trajectories an earlier demo planned, timed by both laws (the law's effect
alone, no simulation needed: a cycle's time is its motions' time), and the earlier demo's results against a
demo run with the new law (the plans themselves may change, since planners weigh time). Usage, from the
repository root:

    .venv/bin/python scripts/studies/time_law_cycle_times.py --before OLD_DEMO_DIR [--after NEW_DEMO_DIR] \
        [--out FILE.md]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.trajectory import load_trajectory_file

# Version 0's law, kept here only to reproduce the old figures: a segment lasted 1.5x the slowest joint's time at
# its programmed speed (the cubic s = 3t^2 - 2t^3 peaks at 1.5x its mean speed).
CUBIC_PEAK_FACTOR = 1.5


def _results(folder: Path) -> list[dict]:
    return [json.loads(line) for line in (folder / "results.jsonl").read_text().splitlines() if line.strip()]


def _mean(rows: list[dict], method: str) -> float:
    vals = [r["cycle_time"] for r in rows if r["method"] == method and r["success"]]
    return float(np.mean(vals)) if vals else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="a demo folder written with the cubic law")
    ap.add_argument("--after", type=Path, help="a demo folder written with the current law")
    ap.add_argument("--out", type=Path, help="write the markdown table here (default: print it)")
    args = ap.parse_args(argv)
    spec = json.loads((args.before / "spec.json").read_text())
    config = load_station(spec.get("station", "default"))
    robot = config.robots[0].robot
    frac = config.simulation.speed_fraction
    limits = robot.joint_motion_limits.at_speed(frac)
    same = defaultdict(lambda: [[], []])  # method -> (cubic times, new-law times) of the same trajectories
    for f in sorted((args.before / "trajectories").glob("*.npz")):
        traj, _ = load_trajectory_file(f)
        method = f.name.split("__")[0]
        dq = np.abs(np.diff(traj.waypoints, axis=0))
        same[method][0].append(float(np.sum(CUBIC_PEAK_FACTOR * np.max(dq / (robot.joint_speed * frac), axis=1))))
        same[method][1].append(float(traj.segment_durations(limits).sum()))
    before = _results(args.before)
    after = _results(args.after) if args.after else []
    lines = ["| method | trajectories | same paths: cubic law [s] | same paths: new law [s] | ratio | demo before [s] "
             "| demo after [s] | ratio |", "|---|---|---|---|---|---|---|---|"]
    for method in sorted(same):
        old, new = (float(np.mean(x)) for x in same[method])
        b, a = _mean(before, method), _mean(after, method) if after else float("nan")
        lines.append(f"| {method} | {len(same[method][0])} | {old:.2f} | {new:.2f} | {new / old:.2f} | {b:.2f} | "
                     + (f"{a:.2f} | {a / b:.2f} |" if after else "– | – |"))
    text = "\n".join(lines) + "\n"
    if args.out:
        args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
