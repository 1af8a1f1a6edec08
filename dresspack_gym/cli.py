"""The ``dresspack`` command line: inspect, render and benchmark stations."""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from .errors import DresspackError


def _load(station_ref: str):
    from .loading import load_station
    from .simulation import CableSimulator
    from .station import Station

    station = Station(load_station(station_ref))
    return station, CableSimulator(station)


def _measure_report(sim) -> dict:
    from .wear_cost import normalized_wear_cost, wear_cost

    m = sim.measures()
    cfg = sim.station.config.wear_cost
    cost = wear_cost(m, cfg)
    norm = normalized_wear_cost(m, cfg)
    return {
        "max_curvature": m.max_curvature,
        "max_tension": m.max_tension,
        "min_clearance": m.min_clearance,
        "max_twist_rate": m.max_twist_rate,
        "cost": cost.total,
        "cost_terms": cost.terms(),
        "normalized_cost": norm.total,
        "normalized_cost_terms": norm.terms(),
        "curvature_at": m.curvature_at,
        "tension_at": m.tension_at,
        "clearance_at": m.clearance_at,
        "nearest_obstacle": m.nearest_obstacle,
    }


def cmd_inspect(args) -> int:
    station, sim = _load(args.station)
    report = _measure_report(sim)
    cfg = station.config
    if args.json:
        report["station"] = cfg.name
        report["weld_points"] = {k: int(len(v)) for k, v in station.weld_configurations.items()}
        print(json.dumps(report, indent=2))
        return 0
    print(f"Station {cfg.name!r}: {cfg.description}")
    for r, idx in zip(cfg.robots, station.robots):
        k = r.robot.kinematics
        reach = k.a1 + k.a2 + float(np.hypot(k.d4, k.a3))
        dp = r.dresspack
        print(f"\nRobot {r.name!r}: {r.robot.name} (wrist reach {reach:.3f} m) at {r.base_pos}, yaw "
              f"{np.degrees(r.base_yaw):.0f} deg\n  source: {r.robot.source}")
        print(f"  Home [deg]: {np.round(np.degrees(r.home), 1).tolist()}")
        print(f"  Dresspack {dp.name!r}: L={dp.length} m, r={dp.radius} m, rho={dp.linear_density} kg/m, "
              f"EI={dp.bending_stiffness} N m^2, GJ={dp.torsional_stiffness} N m^2, EA={dp.tensile_stiffness} N")
        print(f"    MuJoCo DER: {dp.segments} segments of {dp.segment_length * 1000:.1f} mm, young={dp.young_modulus:.4g} "
              f"Pa, shear={dp.shear_modulus:.4g} Pa, inextensible edges")
        for n in dp.nodes:
            kind = "clamp" if n.direction is not None else "ring"
            print(f"    node {n.name!r}: {kind} on {n.body} at {n.pos} (arc {n.arc_length:.3f} m)")
        if dp.free_end:
            print("    free hanging end")
    print(f"\nObstacles: {len(cfg.obstacles)}" + (" + floor" if cfg.floor else ""))
    print(f"Weld points: {len(cfg.weld_points)}")
    for w in cfg.weld_points:
        print(f"  {w.name}: pos {w.pos}, approach {[round(float(a), 3) for a in w.approach]}, "
              f"{len(station.weld_configurations[w.name])} IK solutions within limits")
    print("\nSettled at Home:")
    print(f"  max curvature  {report['max_curvature']:8.3f} 1/m   (at {report['curvature_at']:.2f} m along the cable)")
    print(f"  max tension    {report['max_tension']:8.3f} N     (at {report['tension_at']:.2f} m)")
    print(f"  min clearance  {report['min_clearance']:8.3f} m     (to {report['nearest_obstacle'] or '-'})")
    print(f"  max twist rate {report['max_twist_rate']:8.3f} rad/m")
    terms = report["cost_terms"]
    print(f"  wear cost (4.10) {report['cost']:.4f} = curvature {terms['curvature']:.4f} + tension "
          f"{terms['tension']:.4f} + distance {terms['distance']:.4f}; normalized {report['normalized_cost']:.4f}")
    return 0


def cmd_render(args) -> int:
    from .rendering import StationRenderer, default_camera, save_png

    station, sim = _load(args.station)
    renderer = StationRenderer(station.model, width=args.width, height=args.height)
    cam = default_camera(station.model, azimuth=args.azimuth, elevation=args.elevation, distance=args.distance)
    save_png(renderer.render(sim.data, cam), args.out)
    renderer.close()
    print(f"wrote {args.out}")
    return 0


def cmd_restrictions(args) -> int:
    from .loading import load_station

    cfg = load_station(args.station)
    for r in cfg.robots:
        print(f"Robot {r.name!r}: {len(r.restrictions)} joint restriction(s), combined with AND (thesis 4.7)")
        for rule in r.restrictions.rules:
            print(f"  - {rule.describe()}")
    if args.plot:
        from .restriction_plot import plot_restrictions

        summary = plot_restrictions(cfg, args.plot)
        for name, frac in summary.items():
            print(f"{name}: {100 * frac:.1f} % of the (j5, j6) plane is forbidden at Home's j4")
        print(f"wrote {args.plot}")
    return 0


def cmd_robustness(args) -> int:
    from pathlib import Path

    from .loading import load_station, read_yaml
    from .robustness.algorithm import RobustnessSettings
    from .robustness.grid import RobustnessGrid
    from .robustness.plots import plot_map
    from .robustness.runner import run_map
    from .shipped import find_shipped

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    settings = RobustnessSettings(threshold=args.threshold, n_samples=args.samples, n_paths=args.n_paths,
                                  speed_fraction=args.speed_fraction, settle_time=args.settle_time, start=args.start,
                                  excursion=tuple(math.radians(e) for e in args.excursion), timestep=args.timestep,
                                  settle_timestep=args.settle_timestep)
    summary = run_map(grid, load_station(args.station), args.out, settings, backend=args.backend,
                      workers=args.workers, ray_address=args.ray_address, progress=not args.json, limit=args.limit)
    (Path(args.out) / "summary.json").write_text(json.dumps(summary, indent=2))
    plots = plot_map(args.out, grid, settings.threshold) if summary["n_configs"] else []
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{summary['n_non_robust']} of {summary['n_configs']} configurations non-robust "
              f"({100 * summary['fraction_non_robust']:.1f} %), threshold {1000 * settings.threshold:.0f} mm")
        for ry, s in summary["per_ry"].items():
            print(f"  Ry {float(ry):7.1f} deg: {100 * s['fraction_non_robust']:5.1f} % of {s['n']}")
        print("wrote " + ", ".join([str(Path(args.out) / "results.csv"), str(Path(args.out) / "summary.json")] + plots))
    return 0


def cmd_robustness_paths(args) -> int:
    from .loading import load_station, read_yaml
    from .robustness.algorithm import RobustnessSettings
    from .robustness.grid import RobustnessGrid
    from .robustness.paths import compare_paths

    grid = RobustnessGrid.from_dict(read_yaml(find_shipped(args.grid, "grids", "grid"), "grid"))
    report = compare_paths(grid, load_station(args.station), args.out, RobustnessSettings(), args.k_paths,
                           args.sample, args.seed, backend=args.backend, workers=args.workers,
                           progress=not args.json)
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


def cmd_bench(args) -> int:
    from .bench import env_benchmark, physics_benchmark, restrictions_benchmark, robustness_benchmark

    bench = {"physics": physics_benchmark, "restrictions": restrictions_benchmark, "env": env_benchmark,
             "robustness": robustness_benchmark}[args.what]
    result = bench(args.station, **({} if args.repeats is None else {"repeats": args.repeats}))
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for k, v in result.items():
            print(f"{k:32s} {v}")
    return 0


def registered_commands() -> list:
    """``add(subparsers)`` functions that packages built on this one register under the entry-point group
    ``dresspack.commands`` (``plan`` from dresspack.agents, ``demo`` from dresspack.eval): the core names none."""
    from importlib.metadata import entry_points

    return [ep.load() for ep in sorted(entry_points(group="dresspack.commands"), key=lambda ep: ep.name)]


def build_parser(extensions=None) -> argparse.ArgumentParser:
    """The ``dresspack`` parser with the core subcommands and ``extensions`` (default: the registered ones)."""
    from .robustness.algorithm import START_MODES, RobustnessSettings

    p = argparse.ArgumentParser(prog="dresspack", description="Robot dresspack wear simulation and planning.")
    sub = p.add_subparsers(dest="command", required=True)
    for add in registered_commands() if extensions is None else extensions:
        add(sub)
    q = sub.add_parser("inspect", help="build a station, settle at Home and print robot, cable and wear measures")
    q.add_argument("station", help="station YAML file or shipped station name (e.g. default)")
    q.add_argument("--json", action="store_true", help="print one JSON object")
    q.set_defaults(func=cmd_inspect)
    r = sub.add_parser("render", help="write a PNG picture of the station at Home")
    r.add_argument("station")
    r.add_argument("--out", required=True, help="output PNG path")
    r.add_argument("--width", type=int, default=960)
    r.add_argument("--height", type=int, default=720)
    r.add_argument("--azimuth", type=float, default=-60.0)
    r.add_argument("--elevation", type=float, default=-22.0)
    r.add_argument("--distance", type=float, default=5.5)
    r.set_defaults(func=cmd_render)
    x = sub.add_parser("restrictions", help="list a station's joint restrictions and plot the forbidden j5/j6 zones")
    x.add_argument("station")
    x.add_argument("--plot", help="output PNG path for the forbidden-zone plot (thesis Figure 4.2)")
    x.set_defaults(func=cmd_restrictions)
    rm = sub.add_parser("robustness-map", help="map non-robust cable configurations (thesis Algorithm 1), resumable")
    rm.add_argument("--grid", required=True, help="grid YAML or shipped grid name (thesis_24336, thesis_67500, small)")
    rm.add_argument("--station", required=True, help="station YAML or shipped name (its robot and dresspack are mapped)")
    rm.add_argument("--out", required=True, help="output folder; rerunning with the same folder resumes")
    rm.add_argument("--workers", type=int, default=2)
    rm.add_argument("--backend", choices=["serial", "process", "ray"], default="process")
    rm.add_argument("--ray-address", default=None, help="address of an existing Ray cluster (backend ray)")
    d = RobustnessSettings()  # the one owner of the defaults
    excursion = [round(math.degrees(e), 6) for e in d.excursion]
    rm.add_argument("--threshold", type=float, default=d.threshold, help=f"d_thresh [m] (default {d.threshold:g})")
    rm.add_argument("--samples", type=int, default=d.n_samples, help=f"N_s shape samples (default {d.n_samples})")
    rm.add_argument("--excursion", type=float, nargs=4, default=excursion, metavar=("RY", "J4", "J5", "J6"),
                    help="excursion sizes [deg] (default " + " ".join(f"{e:g}" for e in excursion) + ")")
    rm.add_argument("--n-paths", type=int, default=d.n_paths,
                    help="K random approach paths instead of the thesis's two")
    rm.add_argument("--speed-fraction", type=float, default=d.speed_fraction)
    rm.add_argument("--settle-time", type=float, default=d.settle_time, help="max relaxation after each return [s]")
    rm.add_argument("--timestep", type=float, default=d.timestep,
                    help=f"physics step during motions [s] (default {d.timestep:g}; 0.005 is 1.2x faster at 92.5 %% "
                         "flag agreement with 1 ms, 0.004: 95 %%)")
    rm.add_argument("--settle-timestep", type=float, default=d.settle_timestep,
                    help=f"physics step while the cable relaxes [s] (default {d.settle_timestep:g})")
    rm.add_argument("--start", choices=START_MODES, default=d.start,
                    help="row: each configuration continues from the previous one of its grid row (default); "
                         "ry: every configuration from the settled state of its Ry")
    rm.add_argument("--limit", type=int, default=None, help="compute at most this many new configurations")
    rm.add_argument("--json", action="store_true")
    rm.set_defaults(func=cmd_robustness)
    rp = sub.add_parser("robustness-paths", help="how often the thesis's 2-path test and a K-path test disagree")
    rp.add_argument("--grid", required=True, help="grid YAML or shipped grid name (the sample is drawn from it)")
    rp.add_argument("--station", required=True)
    rp.add_argument("--out", required=True, help="output folder (two resumable maps and paths_report.json)")
    rp.add_argument("--k-paths", type=int, default=8, help="K random approach paths (default 8)")
    rp.add_argument("--sample", type=int, default=100, help="configurations drawn from the grid (default 100)")
    rp.add_argument("--seed", type=int, default=0)
    rp.add_argument("--workers", type=int, default=2)
    rp.add_argument("--backend", choices=["serial", "process", "ray"], default="process")
    rp.add_argument("--json", action="store_true")
    rp.set_defaults(func=cmd_robustness_paths)
    b = sub.add_parser("bench", help="benchmarks")
    b.add_argument("what", choices=["physics", "restrictions", "env", "robustness"], help="which benchmark")
    b.add_argument("--station", default="default")
    b.add_argument("--repeats", type=int, default=None, help="repetitions (best is reported)")
    b.add_argument("--json", action="store_true")
    b.set_defaults(func=cmd_bench)
    return p


def main(argv: list[str] | None = None, extensions=None) -> int:
    args = build_parser(extensions).parse_args(argv)
    try:
        return args.func(args)
    except DresspackError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
