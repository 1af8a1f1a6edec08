"""``dresspack render``, ``restrictions`` and ``twist-sweep``: pictures and sweeps of one station."""

from __future__ import annotations

import json

from ..errors import ConfigError
from ..io.outputs import FIGURE_SUFFIXES, PICTURE_SUFFIXES, replacing, write_text
from .args import add_station_argument, file_to_write, number
from .common import load_simulated


def cmd_render(args) -> int:
    from ..stations.rendering import StationRenderer, default_camera, save_png

    station, sim = load_simulated(args.station)
    renderer = StationRenderer(station.model, width=args.width, height=args.height)
    cam = default_camera(station.model, azimuth=args.azimuth, elevation=args.elevation, distance=args.distance)
    try:
        with replacing(args.out) as tmp:
            save_png(renderer.render(sim.data, cam), tmp)
    finally:
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

        with replacing(args.plot) as tmp:
            summary = plot_restrictions(cfg, tmp)
        for name, frac in summary.items():
            print(f"{name}: {100 * frac:.1f} % of the (j5, j6) plane is forbidden at Home's j4")
        print(f"wrote {args.plot}")
    return 0


def cmd_twist_sweep(args) -> int:
    from tqdm import tqdm

    from ..physics.twist_sweep import plot_twist_sweep, twist_sweep

    if not 0 < args.step <= args.span:
        raise ConfigError("--step", f"must be in (0, --span={args.span}] degrees, got {args.step}")
    station, sim = load_simulated(args.station)
    with tqdm(total=2 * int(round(args.span / args.step)) + 1, desc="twist sweep", unit="step",
              disable=args.json) as bar:
        sweep = twist_sweep(sim, span_deg=args.span, step_deg=args.step, progress=bar)
    if args.plot:
        with replacing(args.plot) as tmp:
            plot_twist_sweep(sweep, tmp)
    if args.out:
        write_text(args.out, json.dumps(sweep.as_dict(), indent=1))
    if args.json:
        print(json.dumps(sweep.as_dict()))
        return 0
    print(f"{'j4+j6 [deg]':>11} {'twist torque [N m]':>30} {'max twist rate':>15} {'max curvature':>14} converged")
    for i, s in enumerate(sweep.sum_deg):
        tq = " ".join(f"{t:7.3f}" for t in sweep.node_twist_torque[i])
        print(f"{s:11.0f} {tq:>30} {sweep.max_twist_rate[i]:15.3f} {sweep.max_curvature[i]:14.2f} "
              f"{sweep.converged[i]}")
    return 0


def add_render(sub) -> None:
    """``dresspack render``."""
    from ..stations.rendering import OFFSCREEN_HEIGHT, OFFSCREEN_WIDTH

    r = sub.add_parser("render", help="write a PNG picture of the station at Home")
    add_station_argument(r, deprecated_positional=True)
    r.add_argument("--out", required=True, type=file_to_write(*PICTURE_SUFFIXES),
                   help="output PNG path (missing folders are made)")
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


def add_restrictions(sub) -> None:
    """``dresspack restrictions``."""
    x = sub.add_parser("restrictions", help="list a station's joint restrictions and plot the forbidden j5/j6 zones")
    add_station_argument(x, deprecated_positional=True)
    x.add_argument("--plot", type=file_to_write(*FIGURE_SUFFIXES),
                   help="output PNG (or .pdf, .svg) path for the forbidden-zone plot (thesis Figure 4.2)")
    x.set_defaults(func=cmd_restrictions)


def add_twist_sweep(sub) -> None:
    """``dresspack twist-sweep``."""
    tw = sub.add_parser("twist-sweep", help="clamp torque, twist and curvature against j4 + j6 (thesis 4.1)")
    add_station_argument(tw, deprecated_positional=True)
    tw.add_argument("--span", type=number(0, 720, lo_open=True, unit="deg"), default=400.0,
                    help="largest change of j4 + j6 from Home, both ways [deg] (default 400)")
    tw.add_argument("--step", type=number(0, 720, lo_open=True, unit="deg"), default=10.0,
                    help="step of j4 + j6 [deg] (default 10)")
    tw.add_argument("--plot", type=file_to_write(*FIGURE_SUFFIXES), help="output PNG (or .pdf, .svg) path (default: "
                                                                         "no plot)")
    tw.add_argument("--out", type=file_to_write(".json"), help="output JSON path (default: no file)")
    tw.add_argument("--json", action="store_true", help="print the sweep as one JSON object (no progress bar)")
    tw.set_defaults(func=cmd_twist_sweep)
