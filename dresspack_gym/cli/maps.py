"""``dresspack robustness-map``, ``robustness-paths`` and ``wear-map``: the maps built over a station."""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from pathlib import Path

from ..io.outputs import write_text
from .args import add_physics_argument, add_station_argument, file_to_write, number, output_dir, positive_int, seed
from .common import INTERRUPTED, robot_index

MAX_WORKERS = 256  # worker processes (one per core; Ray clusters may have more)


def cmd_robustness(args) -> int:
    from ..io.loading import load_station, read_yaml
    from ..maps.robustness.algorithm import RobustnessSettings
    from ..maps.robustness.grid import RobustnessGrid
    from ..maps.robustness.plots import plot_map
    from ..maps.robustness.runner import run_map
    from ..shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    # Only the options given override RobustnessSettings' defaults (they live there, once).
    given = {"threshold": args.threshold, "n_samples": args.samples, "n_paths": args.n_paths,
             "speed_fraction": args.speed_fraction, "settle_time": args.settle_time, "start": args.start,
             "timestep": args.timestep, "settle_timestep": args.settle_timestep,
             "max_dynamic_ratio": args.max_dynamic_ratio, "min_speed_fraction": args.min_speed_fraction,
             "cable_robot_contact": args.cable_robot_contact, "engine": args.physics,
             "excursion": tuple(math.radians(e) for e in args.excursion) if args.excursion else None}
    settings = RobustnessSettings(**{k: v for k, v in given.items() if v is not None})
    indices = None
    if args.every_row is not None:  # a sample of whole rows (each row's configurations continue from each other)
        n = len(grid.j6)
        indices = [i for r in range(0, len(grid) // n, args.every_row) for i in range(r * n, (r + 1) * n)]
    try:
        summary = run_map(grid, load_station(args.station), args.out, settings, backend=args.backend,
                          workers=args.workers, ray_address=args.ray_address, progress=not args.json,
                          limit=args.limit, indices=indices)
    except KeyboardInterrupt:
        results = Path(args.out) / "results.csv"
        saved = max(0, len(results.read_text().splitlines()) - 1) if results.is_file() else 0
        print(f"\ninterrupted: {saved} configurations saved in {results}; resume with: "
              f"dresspack {shlex.join(args.argv)}", file=sys.stderr)
        return INTERRUPTED
    write_text(Path(args.out) / "summary.json", json.dumps(summary, indent=2))
    plots = plot_map(args.out, grid, settings.threshold) if summary["n_configs"] else []
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{summary['n_non_robust']} of {summary['n_configs']} configurations non-robust "
              f"({100 * summary['fraction_non_robust']:.1f} %), threshold {1000 * settings.threshold:.0f} mm; "
              f"{summary['n_unconverged']} unconverged (no equilibrium: reported, not counted)"
              + (f", {summary['n_jammed']} of them jammed (a link against the cable)" if "n_jammed" in summary else ""))
        for ry, s in summary["per_ry"].items():
            print(f"  Ry {float(ry):7.1f} deg: {100 * s['fraction_non_robust']:5.1f} % of {s['n']}")
        print("wrote " + ", ".join([str(Path(args.out) / "results.csv"), str(Path(args.out) / "summary.json")] + plots))
    return 0


def cmd_robustness_paths(args) -> int:
    from ..io.loading import load_station, read_yaml
    from ..maps.robustness.algorithm import RobustnessSettings
    from ..maps.robustness.grid import RobustnessGrid
    from ..maps.robustness.paths import compare_paths
    from ..shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    try:
        report = compare_paths(grid, load_station(args.station), args.out, RobustnessSettings(), args.k_paths,
                               args.sample, args.seed, backend=args.backend, workers=args.workers,
                               progress=not args.json)
    except KeyboardInterrupt:
        print(f"\ninterrupted: the configurations mapped so far are saved in {args.out}/two_path and "
              f"{args.out}/k_path; resume with: dresspack {shlex.join(args.argv)}", file=sys.stderr)
        return INTERRUPTED
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(f"{report['n_compared']} configurations: 2-path and {args.k_paths}-path tests agree on "
              f"{100 * report['agreement']:.1f} %")
        print(f"  non-robust: 2-path {100 * report['fraction_non_robust_two_path']:.1f} %, "
              f"{args.k_paths}-path {100 * report['fraction_non_robust_k_path']:.1f} %; only the K-path test flags "
              f"{report['only_k_path_non_robust']}, only the 2-path test flags {report['only_two_path_non_robust']}")
        print(f"wrote {args.out}/paths_report.json" + (f", {report['plot']}" if "plot" in report else ""))
    return 0


def cmd_wear_map(args) -> int:
    from ..io.loading import load_station
    from ..maps.wear_map import WearMapSettings, build_wear_map, shipped_map_path
    from ..physics.profiles import ENGINE_TITLES

    config = load_station(args.station)
    robot = robot_index(config, args.robot)
    settings = WearMapSettings(samples=args.samples, seed=args.seed)
    out = args.out or shipped_map_path(config, robot, args.physics)
    wear_map = build_wear_map(config, robot, settings, progress=not args.json, engine=args.physics)
    wear_map.save(out)
    info = {**wear_map.info, "path": str(out)}
    if args.json:
        print(json.dumps(info))
    else:
        print(f"wear map of {info['station']} / {info['robot']} on the {ENGINE_TITLES[info['engine']]}: "
              f"{info['settled']} of {info['drawn']} drawn "
              f"configurations settled ({info['unconverged']} unconverged) in {info['build_seconds']} s; "
              f"wrote {out}")
    return 0


def add_worker_flags(p, result: str) -> None:
    """--workers and --backend of a robustness command (``result``: e.g. "the map does", which the count does not
    change)."""
    p.add_argument("--workers", type=number(1, MAX_WORKERS, integer=True), default=2,
                   help=f"worker processes, one per core (default %(default)s; {result} not depend on it)")
    p.add_argument("--backend", choices=["serial", "process", "ray"], default="process",
                   help="where the workers run: this process, local processes or a Ray cluster (default: %(default)s)")


def add_robustness_map(sub) -> None:
    """``dresspack robustness-map``."""
    from ..maps.robustness.algorithm import START_MODES

    rm = sub.add_parser("robustness-map", help="map non-robust cable configurations (thesis Algorithm 1), resumable")
    rm.add_argument("--grid", required=True, help="grid YAML or shipped grid name (thesis_24336, thesis_67500, small)")
    add_station_argument(rm, "station YAML or shipped name (its robot and dresspack are mapped; required)",
                         default=None, required=True)
    rm.add_argument("--out", required=True, type=output_dir,
                    help="output folder; rerunning with the same folder resumes")
    add_worker_flags(rm, "the map does")
    rm.add_argument("--ray-address", default=None,
                    help="address of an existing Ray cluster (backend ray; default: start a local one)")
    rm.add_argument("--threshold", type=number(0, 10, lo_open=True, unit="m"), default=None,
                    help="d_thresh [m] (default 0.1)")
    rm.add_argument("--samples", type=number(2, 10000, integer=True), default=None,
                    help="N_s shape samples (default 20)")
    rm.add_argument("--excursion", type=number(0, 180, unit="deg"), nargs=4, default=None,
                    metavar=("RY", "J4", "J5", "J6"), help="excursion sizes [deg] (default 20 100 100 100)")
    rm.add_argument("--n-paths", type=number(0, 1000, integer=True), default=None,
                    help="K random approach paths instead of the thesis's two (default: the thesis's two)")
    rm.add_argument("--speed-fraction", type=number(0, 1, lo_open=True), default=None,
                    help="excursion speed tried first, as a fraction of the rated joint speeds (default 0.25)")
    rm.add_argument("--min-speed-fraction", type=number(0, 1, lo_open=True), default=None,
                    help="slowest excursion speed tried when the motion is too dynamic (default 1/16)")
    rm.add_argument("--max-dynamic-ratio", type=number(0, 1000, lo_open=True), default=None,
                    help="quasi-static bound: largest cable vertex acceleration / g during excursions (default 0.5)")
    rm.add_argument("--settle-time", type=number(0, 60, lo_open=True, unit="s"), default=None,
                    help="max relaxation to equilibrium after each return [s] (default 5)")
    rm.add_argument("--cable-robot-contact", action=argparse.BooleanOptionalAction, default=None,
                    help="the cable touches the robot's links (default: off, the cable alone, as the thesis maps it); "
                         "a map keeps its setting")
    add_physics_argument(rm, "maps on (a map keeps its engine)")
    rm.add_argument("--timestep", type=number(1e-4, 0.01, unit="s"), default=None,
                    help="physics step during motions [s] (default 0.004)")
    rm.add_argument("--settle-timestep", type=number(1e-4, 0.02, unit="s"), default=None,
                    help="physics step while the cable relaxes [s] (default 0.016)")
    rm.add_argument("--start", choices=START_MODES, default=None,
                    help="row: each configuration continues from the previous one of its grid row (default); "
                         "ry: every configuration from the settled state of its Ry")
    rm.add_argument("--every-row", type=positive_int, default=None,
                    help="map only every K-th grid row (rows 0, K, 2K, ...; a row: all j6 at one Ry, j4, j5): a "
                         "sample of the grid, resumable into the whole map")
    rm.add_argument("--limit", type=positive_int, default=None, help="compute at most this many new configurations")
    rm.add_argument("--json", action="store_true", help="print the summary as one JSON object (no progress bar)")
    rm.set_defaults(func=cmd_robustness)


def add_robustness_paths(sub) -> None:
    """``dresspack robustness-paths``."""
    rp = sub.add_parser("robustness-paths", help="how often the thesis's 2-path test and a K-path test disagree")
    rp.add_argument("--grid", required=True, help="grid YAML or shipped grid name (the sample is drawn from it)")
    add_station_argument(rp, "station YAML or shipped name (its robot and dresspack are mapped; required)",
                         default=None, required=True)
    rp.add_argument("--out", required=True, type=output_dir,
                    help="output folder (two resumable maps and paths_report.json)")
    rp.add_argument("--k-paths", type=number(1, 1000, integer=True), default=8,
                    help="K random approach paths (default 8)")
    rp.add_argument("--sample", type=positive_int, default=100, help="configurations drawn from the grid (default 100)")
    rp.add_argument("--seed", type=seed, default=0,
                    help="seed of the sample and of the K random paths (default %(default)s)")
    add_worker_flags(rp, "the maps do")
    rp.add_argument("--json", action="store_true", help="print the report as one JSON object (no progress bar)")
    rp.set_defaults(func=cmd_robustness_paths)


def add_wear_map(sub) -> None:
    """``dresspack wear-map``."""
    wm = sub.add_parser("wear-map", help="settle the free cable over sampled configurations: the planners' wear map")
    add_station_argument(wm, deprecated_positional=True)
    wm.add_argument("--robot", type=number(0, 63, integer=True), default=0, help="robot index (default 0)")
    wm.add_argument("--samples", type=number(1, 1_000_000, integer=True), default=16000,
                    help="configurations drawn (default 16000; those the cable cannot span are skipped)")
    wm.add_argument("--seed", type=seed, default=0, help="the map's own sampling seed (default 0)")
    wm.add_argument("--out", type=file_to_write(".npz"),
                    help="output .npz (default: the shipped location for this robot and dresspack, "
                         "configs/wear_maps/<key>.npz)")
    add_physics_argument(wm, "settles the map's samples on (a map keeps its engine)")
    wm.add_argument("--json", action="store_true", help="print the map's summary as one JSON object (no progress "
                                                         "bar)")
    wm.set_defaults(func=cmd_wear_map)
