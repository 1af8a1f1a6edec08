"""The ``dresspack`` command line: inspect, render and benchmark stations."""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import sys
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DresspackError
from .args import add_station_argument, ensure_parent, number, output_dir, output_file, positive_int, seed


def _load(station_ref: str):
    from ..io.loading import load_station
    from ..physics.simulation import CableSimulator
    from ..stations.station import Station

    station = Station(load_station(station_ref))
    return station, CableSimulator(station)


def _measure_report(sim) -> dict:
    from ..physics.wear_cost import normalized_wear_cost, wear_cost

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
        "total_twist": m.total_twist,
        "max_compression": m.max_compression,
        "max_node_force": m.max_node_force,
        "max_node_torque": m.max_node_torque,
        "max_damage_rate": m.max_damage_rate,
        "damage_at": m.damage_at,
        "nodes": _node_report(sim),
        "equilibrium": _equilibrium_report(sim),
    }


def _node_report(sim) -> dict:
    """Per node: the force [N] and torque [N m] it carries, in its frame (x = cable direction of a clamp)."""
    out = {}
    for i, cable in enumerate(sim.station.cables):
        forces, torques = sim.node_loads(i)
        for att, f, t in zip(cable.attachments, forces, torques):
            out[f"{cable.robot}/{att.node.name}"] = {"force": [round(float(v), 6) for v in f],
                                                     "torque": [round(float(v), 6) for v in t]}
    return out


def _equilibrium_report(sim) -> dict:
    """The last settle's equilibrium residual (a settled shape carries its proof)."""
    r = sim.last_settle
    eq = r.equilibrium if r is not None else sim.equilibrium()
    return {"converged": eq.converged, "force_residual": eq.force_residual, "torque_residual": eq.torque_residual,
            "kinetic_energy": eq.kinetic_energy, "settle_time": r.time if r is not None else None}


def cmd_inspect(args) -> int:
    station, sim = _load(args.station)
    report = _measure_report(sim)
    cfg = station.config
    unusable = _unusable(report["equilibrium"], cfg)
    if args.json:
        report["station"] = cfg.name
        report["weld_points"] = {k: int(len(v)) for k, v in station.weld_configurations.items()}
        report["usable"] = unusable is None
        if unusable:
            report["unusable"] = unusable
        print(json.dumps(report, indent=2))
        return 0 if unusable is None else 1
    print(f"Station {cfg.name!r}: {cfg.description}")
    for r, idx in zip(cfg.robots, station.robots):
        k = r.robot.kinematics
        if k is not None:
            reach = f"wrist reach {k.a1 + k.a2 + float(np.hypot(k.d4, k.a3)):.3f} m"
        else:  # a general joint chain: the sum of its link offsets bounds the reach
            c = r.robot.chain
            links = sum(np.linalg.norm(o) for o in c.origins[1:]) + np.linalg.norm(c.flange_pos)
            reach = f"joint chain, numeric IK, links {links:.3f} m"
        dp = r.dresspack
        print(f"\nRobot {r.name!r}: {r.robot.name} ({reach}) at {r.base_pos}, yaw "
              f"{np.degrees(r.base_yaw):.0f} deg\n  source: {r.robot.source}")
        print(f"  Home [deg]: {np.round(np.degrees(r.home), 1).tolist()}")
        print(f"  Dresspack {dp.name!r}: L={dp.length} m, r={dp.radius} m, rho={dp.linear_density} kg/m, "
              f"EI={dp.bending_stiffness} N m^2, GJ={dp.torsional_stiffness} N m^2, EA={dp.tensile_stiffness} N")
        print(f"    MuJoCo DER: {dp.segments} segments of {dp.segment_length * 1000:.1f} mm, "
              f"young={dp.young_modulus:.4g} Pa, shear={dp.shear_modulus:.4g} Pa, edges stretch with EA")
        for n in dp.nodes:
            kind = "clamp" if n.direction is not None else "ring"
            print(f"    node {n.name!r}: {kind} on {n.body} at {n.pos} (arc {n.arc_length:.3f} m)")
        if dp.free_end:
            print("    free hanging end")
    print(f"\nObstacles: {len(cfg.obstacles)}" + (" + floor" if cfg.floor else ""))
    print(f"Weld points: {len(cfg.weld_points)}")
    for w in cfg.weld_points:
        reach = station.unreachable_welds.get(w.name) or \
            f"{len(station.weld_configurations[w.name])} IK solutions within limits"
        print(f"  {w.name}: pos {w.pos}, approach {[round(float(a), 3) for a in w.approach]}, {reach}")
    print("\nSettled at Home:")
    print(f"  max curvature  {report['max_curvature']:8.3f} 1/m   (at {report['curvature_at']:.2f} m along the cable)")
    print(f"  max tension    {report['max_tension']:8.3f} N     (at {report['tension_at']:.2f} m)")
    print(f"  min clearance  {report['min_clearance']:8.3f} m     (to {report['nearest_obstacle'] or '-'})")
    print(f"  max twist rate {report['max_twist_rate']:8.3f} rad/m (total twist between clamps "
          f"{report['total_twist']:.3f} rad)")
    for name, load in report["nodes"].items():
        f, t = np.array(load["force"]), np.array(load["torque"])
        print(f"  node {name}: force {np.linalg.norm(f):7.2f} N (axial {f[0]:7.2f}), "
              f"torque {np.linalg.norm(t):6.3f} N m (twist {t[0]:6.3f})")
    print(f"  damage rate    {report['max_damage_rate']:8.3f} /s    (at {report['damage_at']:.2f} m; dresspack "
          f"damage weights)")
    eq = report["equilibrium"]
    print(f"  equilibrium: {'converged' if eq['converged'] else 'NOT CONVERGED'} (force residual "
          f"{eq['force_residual']:.4f} of a vertex weight, kinetic energy {eq['kinetic_energy']:.2e} J)")
    terms = report["cost_terms"]
    print(f"  wear cost (4.10) {report['cost']:.4f} = curvature {terms['curvature']:.4f} + tension "
          f"{terms['tension']:.4f} + distance {terms['distance']:.4f} + twist {terms['twist']:.4f}; "
          f"normalized {report['normalized_cost']:.4f}")
    if unusable:
        print(f"\nTHE STATION CANNOT BE USED: {unusable}")
        return 1
    return 0


# [vertex weights] an unbalanced force this large at Home is no near-equilibrium: the cable is not at rest in any
# meaningful sense (numerically stiff or over-constrained), and every measure and plan of the station is noise
UNUSABLE_RESIDUAL = 1.0


def _unusable(eq: dict, cfg) -> str | None:
    """Why the station cannot be used (its cable does not settle at Home at all), or None."""
    if eq["converged"] or eq["force_residual"] <= UNUSABLE_RESIDUAL:
        return None
    cables = "; ".join(f"{r.name}: EI={r.dresspack.bending_stiffness:g} N m^2, GJ={r.dresspack.torsional_stiffness:g} "
                       f"N m^2, EA={r.dresspack.tensile_stiffness:g} N, L={r.dresspack.length:g} m" for r in cfg.robots)
    return (f"the cable does not settle at Home (force residual {eq['force_residual']:.3g} vertex weights, "
            f"settled means <= {cfg.simulation.equilibrium_tolerance:g}): its dresspack is too stiff for the "
            f"simulation step or stretched between its nodes ({cables}); lower the stiffness or the timestep")


def cmd_render(args) -> int:
    from ..stations.rendering import StationRenderer, default_camera, save_png

    station, sim = _load(args.station)
    renderer = StationRenderer(station.model, width=args.width, height=args.height)
    cam = default_camera(station.model, azimuth=args.azimuth, elevation=args.elevation, distance=args.distance)
    save_png(renderer.render(sim.data, cam), ensure_parent(args.out))
    renderer.close()
    print(f"wrote {args.out}")
    return 0


def cmd_restrictions(args) -> int:
    from ..io.loading import load_station

    cfg = load_station(args.station)
    for r in cfg.robots:
        print(f"Robot {r.name!r}: {len(r.restrictions)} joint restriction(s), combined with AND (thesis 4.7)")
        for rule in r.restrictions.rules:
            print(f"  - {rule.describe()}")
    if args.plot:
        from ..plots.restrictions import plot_restrictions

        summary = plot_restrictions(cfg, ensure_parent(args.plot))
        for name, frac in summary.items():
            print(f"{name}: {100 * frac:.1f} % of the (j5, j6) plane is forbidden at Home's j4")
        print(f"wrote {args.plot}")
    return 0


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
             "cable_robot_contact": args.cable_robot_contact or None, "engine": args.physics,
             "excursion": tuple(math.radians(e) for e in args.excursion) if args.excursion else None}
    settings = RobustnessSettings(**{k: v for k, v in given.items() if v is not None})
    try:
        summary = run_map(grid, load_station(args.station), args.out, settings, backend=args.backend,
                          workers=args.workers, ray_address=args.ray_address, progress=not args.json,
                          limit=args.limit)
    except KeyboardInterrupt:
        results = Path(args.out) / "results.csv"
        saved = max(0, len(results.read_text().splitlines()) - 1) if results.is_file() else 0
        print(f"\ninterrupted: {saved} configurations saved in {results}; resume with: "
              f"dresspack {shlex.join(args.argv)}", file=sys.stderr)
        return INTERRUPTED
    (Path(args.out) / "summary.json").write_text(json.dumps(summary, indent=2))
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


def cmd_twist_sweep(args) -> int:
    from tqdm import tqdm

    from ..physics.twist_sweep import plot_twist_sweep, twist_sweep

    if not 0 < args.step <= args.span:
        raise ConfigError("--step", f"must be in (0, --span={args.span}] degrees, got {args.step}")
    station, sim = _load(args.station)
    with tqdm(total=2 * int(round(args.span / args.step)) + 1, desc="twist sweep", unit="step",
              disable=args.json) as bar:
        sweep = twist_sweep(sim, span_deg=args.span, step_deg=args.step, progress=bar)
    if args.plot:
        plot_twist_sweep(sweep, ensure_parent(args.plot))
    if args.out:
        ensure_parent(args.out).write_text(json.dumps(sweep.as_dict(), indent=1))
    if args.json:
        print(json.dumps(sweep.as_dict()))
        return 0
    print(f"{'j4+j6 [deg]':>11} {'twist torque [N m]':>30} {'max twist rate':>15} {'max curvature':>14} converged")
    for i, s in enumerate(sweep.sum_deg):
        tq = " ".join(f"{t:7.3f}" for t in sweep.node_twist_torque[i])
        print(f"{s:11.0f} {tq:>30} {sweep.max_twist_rate[i]:15.3f} {sweep.max_curvature[i]:14.2f} "
              f"{sweep.converged[i]}")
    return 0


def cmd_wear_map(args) -> int:
    from ..io.loading import load_station
    from ..maps.wear_map import WearMapSettings, build_wear_map, shipped_map_path

    config = load_station(args.station)
    robot = _robot_index(config, args.robot)
    settings = WearMapSettings(samples=args.samples, seed=args.seed)
    out = args.out or shipped_map_path(config, robot)
    wear_map = build_wear_map(config, robot, settings, progress=not args.json)
    wear_map.save(ensure_parent(out))
    info = {**wear_map.info, "path": str(out)}
    if args.json:
        print(json.dumps(info))
    else:
        print(f"wear map of {info['station']} / {info['robot']}: {info['settled']} of {info['drawn']} drawn "
              f"configurations settled ({info['unconverged']} unconverged) in {info['build_seconds']} s; "
              f"wrote {out}")
    return 0


def cmd_robots(args) -> int:
    from tqdm import tqdm

    from ..io.loading import list_robots, load_robot
    from ..robots.checks import ik_round_trip

    names = args.names or list_robots()
    robots = [load_robot(n) for n in names]
    rows = []
    with tqdm(total=len(robots) * args.poses, desc="IK round trips", unit="pose", disable=args.json,
              dynamic_ncols=True) as bar:
        for r in robots:
            bar.set_postfix_str(r.name)
            rows.append(ik_round_trip(r, args.poses, args.seed, progress=bar).row() | {"source": r.source})
    if args.export:
        from ..robots.importer import to_mjcf, to_urdf

        args.export.mkdir(parents=True, exist_ok=True)
        for r in robots:
            (args.export / f"{r.name}.urdf").write_text(to_urdf(r))
            (args.export / f"{r.name}.xml").write_text(to_mjcf(r))
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{'robot':26} {'poses':>6} {'max pose err':>13} {'max joint err':>14} {'branches/pose':>14} "
          f"{'raw branches':>13}  q found")
    for r in rows:
        print(f"{r['robot']:26} {r['poses']:6d} {r['max_pose_error']:13.1e} {r['max_joint_error']:14.1e} "
              f"{r['mean_branches']:14.2f} {r['max_raw_branches']:13d}  {r['found_q']}")
    return 0


def _robot_index(config, robot: int) -> int:
    if not 0 <= robot < len(config.robots):
        raise ConfigError("--robot", f"robot index {robot} does not exist: the station has {len(config.robots)} "
                                     f"robot(s) (0..{len(config.robots) - 1})")
    return robot


def _checked_plan(args):
    """(trajectory, meta, station config, robot index, identity) of ``args.plan`` for the station and robot named
    (default: the plan's), refused if the plan was made for another robot or station."""
    from ..io.loading import load_station
    from ..io.program_checks import check_identity, resolve_robot
    from ..physics.trajectory import load_trajectory_file

    traj, meta = load_trajectory_file(args.plan)
    station_ref = args.station or meta.get("station")
    if not station_ref:
        raise ConfigError("--station", "the plan does not say which station it was made for: give --station")
    cfg = load_station(str(station_ref))
    robot = resolve_robot(meta, cfg, getattr(args, "robot", None))
    identity = check_identity(meta, cfg, robot, args.station is not None, load_station)
    return traj, meta, cfg, robot, identity


def _speed_fraction(given, meta: dict, cfg):
    """The speed a plan runs at: as given, else as the plan says (checked, whatever it holds), else the station's."""
    if given is not None:
        return given
    return meta["speed_fraction"] if meta.get("speed_fraction") is not None else cfg.simulation.speed_fraction


def cmd_export(args) -> int:
    from ..io.program_checks import SAMPLE_PERIOD, check_program, check_written
    from ..io.programs import TimedPath, write

    traj, meta, cfg, robot, identity = _checked_plan(args)
    fraction = _speed_fraction(args.speed_fraction, meta, cfg)
    placement = cfg.robots[robot]
    owner = f" of robot {placement.name!r} ({placement.robot.name})"
    report = check_program(traj, placement.robot, fraction, owner, identity)
    path = TimedPath.of(traj, placement.robot, fraction, cfg.name, placement.name)
    text = write(path, args.format)
    check_written(text, args.format, path, placement.robot)
    summary = {"station": cfg.name, "robot": placement.name, "format": args.format, **report.summary()}
    if args.dry_run:
        if args.json:
            print(json.dumps(summary, indent=2))
            return 0
        print(f"{args.plan}: {report.waypoints} waypoints for robot {placement.name!r} ({placement.robot.name}) of "
              f"station {cfg.name!r}; {identity}")
        print(f"  cycle time {report.cycle_time:.3f} s at {report.speed_fraction:g} x rated joint speed")
        w, j = report.limit_margin_at
        print(f"  closest to a joint limit: {report.limit_margin_deg:.3f} deg (joint {j + 1} at waypoint {w}); "
              f"{report.interpolated_points} interpolated points checked every {1000 * SAMPLE_PERIOD:.0f} ms")
        for kind, (ratio, seg, jj) in report.peak_ratio.items():
            print(f"  peak {kind:12s} {100 * ratio:6.1f} % of the rated limit "
                  f"(joint {jj + 1}, move {seg} -> {seg + 1})")
        print(f"  all checks passed: a {args.format} program would be written (dry run: nothing written)")
        return 0
    if args.out:
        ensure_parent(args.out).write_text(text)
        msg = f"wrote {args.out} ({args.format}, {len(path.joints)} waypoints, {path.times[-1]:.2f} s)"
        print(json.dumps({**summary, "out": str(args.out)}) if args.json else msg)
    elif args.json:
        print(json.dumps({**summary, "program": text}))
    else:
        print(text, end="")
    return 0


def cmd_animate(args) -> int:
    from tqdm import tqdm

    from ..io.animation import animate
    from ..io.program_checks import check_program
    from ..physics.simulation import CableSimulator
    from ..stations.station import Station

    traj, meta, cfg, robot, identity = _checked_plan(args)
    placement = cfg.robots[robot]
    check_program(traj, placement.robot, _speed_fraction(None, meta, cfg),
                  f" of robot {placement.name!r} ({placement.robot.name})", identity)
    result = animate(CableSimulator(Station(cfg)), traj, ensure_parent(args.out), robot=robot, fps=args.fps,
                     width=args.width, height=args.height, shadows=args.shadows,
                     progress=lambda label, total: tqdm(total=total, desc=label, unit="frame", dynamic_ncols=True))
    print(f"wrote {result['path']} ({result['frames']} frames, {result['duration_s']:.1f} s)")
    return 0


def cmd_bench(args) -> int:
    from .bench import (
        collision_benchmark,
        env_benchmark,
        physics_benchmark,
        restrictions_benchmark,
        robustness_benchmark,
    )

    bench = {"physics": physics_benchmark, "restrictions": restrictions_benchmark, "env": env_benchmark,
             "robustness": robustness_benchmark, "collision": collision_benchmark}[args.what]
    options = {} if args.repeats is None else {"repeats": args.repeats}
    if args.what == "physics":
        options["engine"] = args.physics
    elif args.physics != "dynamic":
        raise ConfigError("--physics", f"only 'bench physics' chooses the engine; 'bench {args.what}' runs on MuJoCo")
    result = bench(args.station, **options)
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


class _Parser(argparse.ArgumentParser):
    """argparse, except that while :func:`main` runs with ``--json`` a usage error becomes a :class:`UsageError`,
    so scripts that asked for JSON get a JSON error object too."""

    json_errors = False

    def error(self, message):
        if _Parser.json_errors:
            raise UsageError(self.prog, message)
        super().error(message)


class UsageError(DresspackError):
    """A command line argparse refused (reported as JSON under ``--json``)."""

    def __init__(self, prog: str, message: str):
        self.field = message.split(":", 1)[0].removeprefix("argument ") if message.startswith("argument ") else ""
        super().__init__(f"{prog}: {message}")


INTERRUPTED = 130  # the shell's exit status of a command ended by Ctrl-C (128 + SIGINT)
MAX_WORKERS = 256  # worker processes (one per core; Ray clusters may have more)


def _add_inspect(sub) -> None:
    """``dresspack inspect``."""
    q = sub.add_parser("inspect", help="build a station, settle at Home and print robot, cable and wear measures")
    add_station_argument(q, deprecated_positional=True)
    q.add_argument("--json", action="store_true", help="print one JSON object")
    q.set_defaults(func=cmd_inspect)


def _add_render(sub) -> None:
    """``dresspack render``."""
    from ..stations.rendering import OFFSCREEN_HEIGHT, OFFSCREEN_WIDTH

    r = sub.add_parser("render", help="write a PNG picture of the station at Home")
    add_station_argument(r, deprecated_positional=True)
    r.add_argument("--out", required=True, type=output_file, help="output PNG path (missing folders are made)")
    r.add_argument("--width", type=number(1, OFFSCREEN_WIDTH, integer=True, unit="px"), default=960,
                   help="picture width [px] (default %(default)s)")
    r.add_argument("--height", type=number(1, OFFSCREEN_HEIGHT, integer=True, unit="px"), default=720,
                   help="picture height [px] (default %(default)s)")
    r.add_argument("--azimuth", type=number(-360, 360, unit="deg"), default=-60.0,
                   help="camera azimuth about the vertical axis [deg] (default %(default)s)")
    r.add_argument("--elevation", type=number(-90, 90, unit="deg"), default=-22.0,
                   help="camera elevation, negative looking down [deg] (default %(default)s)")
    r.add_argument("--distance", type=number(0, 100, lo_open=True, unit="m"), default=5.5,
                   help="camera distance from the station's centre [m] (default %(default)s)")
    r.set_defaults(func=cmd_render)


def _add_restrictions(sub) -> None:
    """``dresspack restrictions``."""
    x = sub.add_parser("restrictions", help="list a station's joint restrictions and plot the forbidden j5/j6 zones")
    add_station_argument(x, deprecated_positional=True)
    x.add_argument("--plot", type=output_file, help="output PNG path for the forbidden-zone plot (thesis Figure 4.2)")
    x.set_defaults(func=cmd_restrictions)


def _add_worker_flags(p, result: str) -> None:
    """--workers and --backend of a robustness command (``result``: e.g. "the map does", which the count does not
    change)."""
    p.add_argument("--workers", type=number(1, MAX_WORKERS, integer=True), default=2,
                   help=f"worker processes, one per core (default %(default)s; {result} not depend on it)")
    p.add_argument("--backend", choices=["serial", "process", "ray"], default="process",
                   help="where the workers run: this process, local processes or a Ray cluster (default: %(default)s)")


def _add_robustness_map(sub) -> None:
    """``dresspack robustness-map``."""
    from ..maps.robustness.algorithm import START_MODES
    from ..physics.profiles import ENGINES

    rm = sub.add_parser("robustness-map", help="map non-robust cable configurations (thesis Algorithm 1), resumable")
    rm.add_argument("--grid", required=True, help="grid YAML or shipped grid name (thesis_24336, thesis_67500, small)")
    add_station_argument(rm, "station YAML or shipped name (its robot and dresspack are mapped; required)",
                         default=None, required=True)
    rm.add_argument("--out", required=True, type=output_dir,
                    help="output folder; rerunning with the same folder resumes")
    _add_worker_flags(rm, "the map does")
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
    rm.add_argument("--cable-robot-contact", action="store_true",
                    help="let the cable touch the robot's links (the thesis maps the cable alone: off by default)")
    rm.add_argument("--physics", choices=list(ENGINES), default="dynamic",
                    help="the cable engine: dynamic (MuJoCo, default) or fast (the quasi-static rod engine, whose "
                         "cable-robot contact is its barrier against the links' capsules); a map keeps its engine")
    rm.add_argument("--timestep", type=number(1e-4, 0.01, unit="s"), default=None,
                    help="physics step during motions [s] (default 0.004)")
    rm.add_argument("--settle-timestep", type=number(1e-4, 0.02, unit="s"), default=None,
                    help="physics step while the cable relaxes [s] (default 0.016)")
    rm.add_argument("--start", choices=START_MODES, default=None,
                    help="row: each configuration continues from the previous one of its grid row (default); "
                         "ry: every configuration from the settled state of its Ry")
    rm.add_argument("--limit", type=positive_int, default=None, help="compute at most this many new configurations")
    rm.add_argument("--json", action="store_true", help="print the summary as one JSON object (no progress bar)")
    rm.set_defaults(func=cmd_robustness)


def _add_robustness_paths(sub) -> None:
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
    _add_worker_flags(rp, "the maps do")
    rp.add_argument("--json", action="store_true", help="print the report as one JSON object (no progress bar)")
    rp.set_defaults(func=cmd_robustness_paths)


def _add_twist_sweep(sub) -> None:
    """``dresspack twist-sweep``."""
    tw = sub.add_parser("twist-sweep", help="clamp torque, twist and curvature against j4 + j6 (thesis 4.1)")
    add_station_argument(tw, deprecated_positional=True)
    tw.add_argument("--span", type=number(0, 720, lo_open=True, unit="deg"), default=400.0,
                    help="largest change of j4 + j6 from Home, both ways [deg] (default 400)")
    tw.add_argument("--step", type=number(0, 720, lo_open=True, unit="deg"), default=10.0,
                    help="step of j4 + j6 [deg] (default 10)")
    tw.add_argument("--plot", type=output_file, help="output PNG path (default: no plot)")
    tw.add_argument("--out", type=output_file, help="output JSON path (default: no file)")
    tw.add_argument("--json", action="store_true", help="print the sweep as one JSON object (no progress bar)")
    tw.set_defaults(func=cmd_twist_sweep)


def _add_wear_map(sub) -> None:
    """``dresspack wear-map``."""
    wm = sub.add_parser("wear-map", help="settle the free cable over sampled configurations: the planners' wear map")
    add_station_argument(wm, deprecated_positional=True)
    wm.add_argument("--robot", type=number(0, 63, integer=True), default=0, help="robot index (default 0)")
    wm.add_argument("--samples", type=number(1, 1_000_000, integer=True), default=16000,
                    help="configurations drawn (default 16000; those the cable cannot span are skipped)")
    wm.add_argument("--seed", type=seed, default=0, help="the map's own sampling seed (default 0)")
    wm.add_argument("--out", type=output_file, help="output .npz (default: the shipped location for this robot "
                                                    "and dresspack, configs/wear_maps/<key>.npz)")
    wm.add_argument("--json", action="store_true", help="print the map's summary as one JSON object (no progress "
                                                         "bar)")
    wm.set_defaults(func=cmd_wear_map)


def _add_robots(sub) -> None:
    """``dresspack robots``."""
    rb = sub.add_parser("robots", help="the shipped robots' FK/IK round trip: pose error and IK branches per robot")
    rb.add_argument("names", nargs="*", help="robot names or YAML files (default: every shipped robot)")
    rb.add_argument("--poses", type=number(1, 1_000_000, integer=True), default=1000,
                    help="random configurations per robot (default 1000)")
    rb.add_argument("--seed", type=seed, default=0, help="seed of the random configurations (default 0)")
    rb.add_argument("--export", type=output_dir, help="also write each robot's chain as <name>.urdf and <name>.xml "
                                                      "(MJCF) in its controller's joint convention to this folder")
    rb.add_argument("--json", action="store_true", help="print one JSON row per robot (no progress bar)")
    rb.set_defaults(func=cmd_robots)


def _add_export(sub) -> None:
    """``dresspack export``."""
    from ..io.programs import FORMATS as PROGRAM_FORMATS

    ex = sub.add_parser("export", help="write a planned trajectory as a robot program (CSV, JSON, ABB RAPID, KUKA KRL)")
    ex.add_argument("plan", help="trajectory .npz from `dresspack plan --out` or an evaluation's trajectories/")
    ex.add_argument("--format", choices=list(PROGRAM_FORMATS), required=True, help="program format")
    ex.add_argument("--out", type=output_file, default=None, help="output file (default: print)")
    add_station_argument(ex, "station YAML or shipped name (default: the one the plan was made for)", default=None)
    ex.add_argument("--robot", type=number(0, 63, integer=True), default=None, help="robot index (default: the plan's)")
    ex.add_argument("--speed-fraction", type=number(0, 1, lo_open=True), default=None,
                    help="of the rated joint speeds (default: the plan's, else the station's)")
    ex.add_argument("--dry-run", action="store_true", help="run every check and print the summary (limit margin, "
                                                           "peak speed/acceleration/jerk, cycle time); write nothing")
    ex.add_argument("--json", action="store_true", help="print the checks' summary (and the program, without "
                                                         "--out; errors too) as one JSON object")
    ex.set_defaults(func=cmd_export)


def _add_animate(sub) -> None:
    """``dresspack animate``."""
    from ..stations.rendering import OFFSCREEN_HEIGHT, OFFSCREEN_WIDTH

    an = sub.add_parser("animate", help="video of a planned trajectory with the wear measures under it (.mp4/.gif)")
    an.add_argument("plan", help="trajectory .npz from `dresspack plan --out` or an evaluation's trajectories/")
    an.add_argument("--out", type=output_file, required=True, help="video path: .mp4 or .gif")
    add_station_argument(an, "station YAML or shipped name (default: the one the plan was made for)", default=None)
    an.add_argument("--robot", type=number(0, 63, integer=True), default=None, help="robot index (default: the plan's)")
    an.add_argument("--fps", type=number(1, 60), default=20.0,
                    help="frames per second of motion time (default 20)")
    an.add_argument("--width", type=number(16, OFFSCREEN_WIDTH, integer=True, unit="px"), default=640,
                    help="video width [px] (default %(default)s)")
    an.add_argument("--height", type=number(16, OFFSCREEN_HEIGHT, integer=True, unit="px"), default=360,
                    help="height of the station's picture [px], the measures' strip below it (default %(default)s)")
    an.add_argument("--shadows", action="store_true",
                    help="draw shadows (about 10x slower per frame without a GPU; default: off)")
    an.set_defaults(func=cmd_animate)


def _add_bench(sub) -> None:
    """``dresspack bench``."""
    b = sub.add_parser("bench", help="measure this machine's speed on a station: physics steps/s, restriction "
                                     "checks, env steps/s, robustness-map configurations/s or collision queries",
                       description="Measures one speed of a station's computations on this machine (the best of "
                                   "--repeats) and prints each figure by name.")
    b.add_argument("what", choices=["physics", "restrictions", "env", "robustness", "collision"],
                   help="physics: raw MuJoCo steps/s and the wall time of a settled 90 deg move; restrictions: "
                        "microseconds per joint-restriction check; env: env steps/s against raw MuJoCo steps; "
                        "robustness: map configurations/s with 1 and 2 workers; collision: microseconds per "
                        "clearance query against posing the robot")
    add_station_argument(b)
    b.add_argument("--repeats", type=number(1, 1000, integer=True), default=None,
                   help="repetitions, the best reported (default: 3; robustness 1)")
    b.add_argument("--physics", choices=["dynamic", "fast"], default="dynamic",
                   help="the cable engine of 'bench physics': dynamic (MuJoCo, default) or fast (the rod engine); "
                        "both report replay_wall_per_motion_s over the same fixed weld cycles")
    b.add_argument("--json", action="store_true", help="print the timings as one JSON object")
    b.set_defaults(func=cmd_bench)


# the core subcommands, in the order --help lists them (after those the packages built on the core register)
CORE_COMMANDS = (_add_inspect, _add_render, _add_restrictions, _add_robustness_map, _add_robustness_paths,
                 _add_twist_sweep, _add_wear_map, _add_robots, _add_export, _add_animate, _add_bench)


def build_parser(extensions=None) -> argparse.ArgumentParser:
    """The ``dresspack`` parser with the core subcommands and ``extensions`` (default: the registered ones)."""
    p = _Parser(prog="dresspack", description="Robot dresspack wear simulation and planning.")
    sub = p.add_subparsers(dest="command", required=True)
    for add in registered_commands() if extensions is None else extensions:
        add(sub)
    for add in CORE_COMMANDS:
        add(sub)
    return p


def main(argv: list[str] | None = None, extensions=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    as_json = "--json" in argv  # every failure of a --json call is one JSON object on stdout, exit code 2
    _Parser.json_errors = as_json
    try:
        args = build_parser(extensions).parse_args(argv)
        args.argv = argv  # the command line as given: what an interrupted command prints to resume it
        return args.func(args)
    except DresspackError as exc:
        if as_json:
            print(json.dumps({"error": str(exc), "field": getattr(exc, "field", "")}))
        else:
            print(f"error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader closed the pipe (`dresspack inspect default | head`): nothing is wrong and nothing more can be
        # written; point stdout at devnull so the interpreter's final flush does not raise again (Python's docs)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    finally:
        _Parser.json_errors = False


if __name__ == "__main__":
    sys.exit(main())
