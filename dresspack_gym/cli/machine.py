"""``dresspack robots`` and ``bench``: the shipped robots' IK round trips and this machine's speed."""

from __future__ import annotations

import json

from ..errors import ConfigError
from ..io.outputs import write_text
from .args import add_station_argument, number, output_dir, seed


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
            write_text(args.export / f"{r.name}.urdf", to_urdf(r))
            write_text(args.export / f"{r.name}.xml", to_mjcf(r))
    if args.json:
        print(json.dumps(rows))
        return 0
    print(f"{'robot':26} {'poses':>6} {'max pose err':>13} {'max joint err':>14} {'branches/pose':>14} "
          f"{'raw branches':>13}  q found")
    for r in rows:
        print(f"{r['robot']:26} {r['poses']:6d} {r['max_pose_error']:13.1e} {r['max_joint_error']:14.1e} "
              f"{r['mean_branches']:14.2f} {r['max_raw_branches']:13d}  {r['found_q']}")
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
        options["segments"] = args.segments
    elif args.physics != "dynamic":
        raise ConfigError("--physics", f"only 'bench physics' chooses the engine; 'bench {args.what}' runs on MuJoCo")
    elif args.segments is not None:
        raise ConfigError("--segments", f"only 'bench physics' sets the cables' segments, not 'bench {args.what}'")
    result = bench(args.station, **options)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for k, v in result.items():
            print(f"{k:32s} {v}")
    return 0


def add_robots(sub) -> None:
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


def add_bench(sub) -> None:
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
    b.add_argument("--segments", type=number(2, 400, integer=True), default=None,
                   help="'bench physics': the cables' segments of the engine measured (default: the station's own); "
                        "the fast engine's run also times MuJoCo's replay of the station as it stands")
    b.add_argument("--json", action="store_true", help="print the timings as one JSON object")
    b.set_defaults(func=cmd_bench)
