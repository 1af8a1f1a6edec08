"""``dresspack export`` and ``animate``: a planned trajectory as a robot program or a video."""

from __future__ import annotations

import json

from ..errors import ConfigError
from ..io.outputs import replacing, write_text
from .args import add_physics_argument, add_station_argument, file_to_write, number, output_file


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
        write_text(args.out, text)
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
    from ..physics.profiles import make_simulator
    from ..stations.station import Station

    traj, meta, cfg, robot, identity = _checked_plan(args)
    placement = cfg.robots[robot]
    check_program(traj, placement.robot, _speed_fraction(None, meta, cfg),
                  f" of robot {placement.name!r} ({placement.robot.name})", identity)
    with replacing(args.out) as tmp:
        result = animate(make_simulator(Station(cfg), args.physics), traj, tmp, robot=robot, fps=args.fps,
                         width=args.width, height=args.height, shadows=args.shadows, wear_colours=args.wear_colours,
                         progress=lambda label, total: tqdm(total=total, desc=label, unit="frame", dynamic_ncols=True))
    print(f"wrote {args.out} ({result['frames']} frames, {result['duration_s']:.1f} s)")
    return 0


def add_export(sub) -> None:
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


def add_animate(sub) -> None:
    """``dresspack animate``."""
    from ..io.animation import VIDEO_FORMATS
    from ..stations.rendering import OFFSCREEN_HEIGHT, OFFSCREEN_WIDTH

    an = sub.add_parser("animate", help="video of a planned trajectory with the wear measures under it (.mp4/.gif)")
    an.add_argument("plan", help="trajectory .npz from `dresspack plan --out` or an evaluation's trajectories/")
    an.add_argument("--out", type=file_to_write(*VIDEO_FORMATS), required=True, help="video path: .mp4 or .gif")
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
    an.add_argument("--wear-colours", action="store_true",
                    help="draw the robot's cable segment by segment in the colour of its wear cost, as `dresspack "
                         "view` does (blue none, red the plan's largest C; default: the cable's own colour)")
    add_physics_argument(an, "that replays the plan for the video")
    an.set_defaults(func=cmd_animate)
