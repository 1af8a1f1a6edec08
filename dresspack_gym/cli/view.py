"""``dresspack view``: a plan, or a station at Home, in MuJoCo's interactive viewer (dresspack_gym/io/viewer.py)."""

from __future__ import annotations

import shlex
import sys

from ..errors import ConfigError
from .args import add_physics_argument, add_station_argument, number


def add_view_command(sub) -> None:
    v = sub.add_parser("view", help="replay a plan in MuJoCo's interactive viewer, the cable coloured by its wear "
                                    "cost (play/pause/scrub); --station alone: the station at Home",
                       description="Opens MuJoCo's viewer on a plan's replay (or, without a plan, on the station "
                                   "settled at Home) with each cable segment coloured by its wear cost, eq. (4.10) "
                                   "on the segment's own curvature, pull, clearance and twist: blue none, red the "
                                   "replay's largest. Keys: space play/pause, left/right one frame, PgUp/PgDn one "
                                   "second, Home/End, up/down speed. Needs a display; `dresspack animate` writes a "
                                   "video instead.")
    v.add_argument("plan", nargs="?", default=None,
                   help="trajectory .npz from `dresspack plan --out` or an evaluation's trajectories/ "
                        "(none: the station at Home)")
    add_station_argument(v, "station YAML or shipped name (default: the one the plan was made for; without a "
                            "plan: default)", default=None)
    v.add_argument("--robot", type=number(0, 63, integer=True), default=None,
                   help="robot index whose cable is coloured (default: the plan's, else 0)")
    v.add_argument("--fps", type=number(1, 60), default=20.0,
                   help="frames per second of motion time (default 20)")
    v.add_argument("--at", type=number(0, None, unit="s"), default=None,
                   help="open paused at this motion time [s] (default: play from the start)")
    add_physics_argument(v, "that replays the plan (or settles the station)")
    v.set_defaults(func=cmd_view)


def cmd_view(args) -> int:
    from ..io.loading import load_station
    from ..io.viewer import record_frames, require_display, view
    from ..physics.profiles import ENGINE_TITLES, make_simulator
    from ..stations.station import Station

    if args.plan is None:
        cfg = load_station(args.station or "default")
        robot = args.robot or 0
        if robot >= len(cfg.robots):
            raise ConfigError("--robot", f"robot index {robot} does not exist: station {cfg.name!r} has "
                                         f"{len(cfg.robots)} robot(s)")
        traj, fraction = None, None
        instead = f"`dresspack render --station {shlex.quote(args.station or 'default')} --out station.png` " \
                  "draws it into a picture"
        title = f"{cfg.name} at Home"
    else:
        traj, cfg, robot, fraction = _checked_plan(args)
        instead = f"`dresspack animate {shlex.quote(args.plan)} --out plan.mp4` writes it as a video"
        title = f"{args.plan} on {cfg.name}"
    require_display(instead)  # before the replay: no minute of simulating for a window that cannot open
    sim = make_simulator(Station(cfg), args.physics)
    if traj is not None:
        print(f"replaying the plan on the {ENGINE_TITLES[args.physics]}, then opening MuJoCo's viewer",
              file=sys.stderr)
    frames = record_frames(sim, traj, robot=robot, fps=args.fps, speed_fraction=fraction)
    view(sim, frames, robot=robot, instead=instead, title=title, at=args.at)
    return 0


def _checked_plan(args):
    """(trajectory, station config, robot index, speed fraction) of ``args.plan``, refused as ``dresspack animate``
    refuses it: made for another robot or station, or outside the robot's limits."""
    from ..io.loading import load_station
    from ..io.program_checks import check_identity, check_program, resolve_robot
    from ..physics.trajectory import load_trajectory_file

    traj, meta = load_trajectory_file(args.plan)
    station_ref = args.station or meta.get("station")
    if not station_ref:
        raise ConfigError("--station", "the plan does not say which station it was made for: give --station")
    cfg = load_station(str(station_ref))
    robot = resolve_robot(meta, cfg, args.robot)
    identity = check_identity(meta, cfg, robot, args.station is not None, load_station)
    fraction = meta["speed_fraction"] if meta.get("speed_fraction") is not None else cfg.simulation.speed_fraction
    placement = cfg.robots[robot]
    check_program(traj, placement.robot, fraction, f" of robot {placement.name!r} ({placement.robot.name})", identity)
    return traj, cfg, robot, fraction
