"""``dresspack plan``: the planners from the command line (a ``dresspack`` subcommand, registered by entry point)."""

from __future__ import annotations

import json
import sys

from dresspack_gym.cli.args import (
    ALL_CORES,
    MAX_JOBS,
    add_physics_argument,
    add_station_argument,
    file_to_write,
    number,
    seed,
)
from dresspack_gym.cli.common import ctrl_c_remembered
from dresspack_gym.errors import ConfigError
from dresspack_gym.io.outputs import FIGURE_SUFFIXES, replacing
from dresspack_gym.physics.profiles import ENGINE_TITLES
from dresspack_gym.physics.wear_cost import COST_VARIANTS

from .planners.budget import DEFAULT_EVALUATIONS, DEFAULT_ITERATIONS, DEFAULT_ROUTES, MAX_WALL_TIME, MAX_WORK
from .planners.leg_cost import MAX_TENSION_PEAK_TIME, MAX_TIME_WEIGHT, TENSION_PEAK_TIME

WORK = number(1, MAX_WORK, integer=True)


def add_budget_arguments(p, iterations: int = DEFAULT_ITERATIONS, evaluations: int = DEFAULT_EVALUATIONS,
                         routes: int = DEFAULT_ROUTES, time_budget: float | None = None) -> None:
    """The planning budget flags (shared by ``dresspack plan``, ``dresspack eval`` and ``dresspack demo``)."""
    p.add_argument("--iterations", type=WORK, default=iterations,
                   help=f"OMPL planner iterations per connection (work units; default {iterations})")
    p.add_argument("--evaluations", type=WORK, default=evaluations,
                   help=f"cable-leg cost queries of the wear-aware refinement per plan (default {evaluations})")
    p.add_argument("--routes", type=WORK, default=routes,
                   help=f"candidate routes per leg sampled and scored by ompl-wear (default {routes})")
    p.add_argument("--time-budget", type=number(0, MAX_WALL_TIME, lo_open=True, unit="s"), default=time_budget,
                   metavar="SECONDS",
                   help="optional wall-time cap per plan [s]; a plan stopped by it depends on machine load "
                        f"(default: {'none' if time_budget is None else time_budget})")


def add_plan_command(sub) -> None:
    from .learned.policy import DEFAULT_POLICY
    from .learned.search import ALTERNATIVES, MAX_ALTERNATIVES, MAX_PROPOSALS, MAX_REFINE, PROPOSALS, REFINE
    from .planners.registry import PLANNERS

    p = sub.add_parser("plan", help="plan the station's weld cycle and measure it in the cable simulator")
    add_station_argument(p, "station or thesis scenario: YAML or shipped name, e.g. thesis_tension (default: "
                            "%(default)s)", deprecated_positional=True)
    p.add_argument("--planner", choices=list(PLANNERS), default="ompl", help="planning method (default: %(default)s)")
    p.add_argument("--seed", type=seed, default=0, help="the planner's random seed (default %(default)s)")
    p.add_argument("--robot", type=number(0, 7, integer=True), default=0,
                   help="index of the robot to plan for (default 0; its weld points by default)")
    add_budget_arguments(p)
    p.add_argument("--welds", nargs="+", default=None, metavar="WELD",
                   help="weld point names, one per argument, in visiting order (default: all the robot's)")
    p.add_argument("--cost-variant", choices=list(COST_VARIANTS), default="thesis",
                   help="wear cost the wear-aware planners minimise and the replay reports: thesis (4.10), "
                        "normalized, damage (the worst segment's damage rate) or life (w_life x the worst segment's "
                        "fatigue damage of one excursion to each state; see docs/wear.md); default: %(default)s")
    p.add_argument("--tension-peak-time", type=number(0, MAX_TENSION_PEAK_TIME, unit="s"), default=None,
                   metavar="SECONDS",
                   help="ompl-wear and ompl-wear-fmt only: charge each leg's highest tension term w_F F² as if it "
                        f"lasted this long, on top of (4.10)'s integral (default {TENSION_PEAK_TIME:g}; 0: the "
                        "integral alone)")
    p.add_argument("--time-weight", type=number(0, MAX_TIME_WEIGHT, unit="per s"), default=None,
                   help="wear-aware planners only: cost of one second of cycle time against one unit of ∫C dt in "
                        "their leg cost (default 1; larger trades wear for speed)")
    p.add_argument("--policy", default=None, help="ppo and ppo-search only: run folder, model .zip or shipped policy "
                                                  f"name (default: {DEFAULT_POLICY})")
    p.add_argument("--proposals", type=number(1, MAX_PROPOSALS, integer=True), default=None,
                   help="ppo-search only: the policy's most probable moves each step tries, each continued by the "
                        f"policy to the end (default {PROPOSALS}; 1: the policy's own rollout)")
    p.add_argument("--refine", type=number(0, MAX_REFINE, integer=True), default=None, metavar="QUERIES",
                   help="ppo-search only: leg-cost queries (accurate cable simulations of a leg) that move the found "
                        f"route's vias to cheaper ones (default {REFINE}; 0: the route as the search found it)")
    p.add_argument("--alternatives", type=number(0, MAX_ALTERNATIVES, integer=True), default=None, metavar="ROUTES",
                   help="ppo-search only: OMPL routes (the direct one, then through random vias) per leg, each scored "
                        "by cable simulation against the found route's leg before the refinement starts from the "
                        f"cheapest (default {ALTERNATIVES}; 0: the found route's legs only)")
    p.add_argument("--cost-to-go", default=None, metavar="MODEL",
                   help="ppo-search only: what ranks the proposals: none (default: simulate each one's "
                        "continuation by the policy), auto (the cost-to-go model shipped with the policy, if it ships "
                        "one), a model.pt of dresspack train-cost-model --config cost_to_go, or the name of a model "
                        "shipped with the policy")
    p.add_argument("--plot", type=file_to_write(*FIGURE_SUFFIXES), default=None,
                   help="PNG of κ, F, d, twist rate over time (thesis Figures A.1-A.3; missing folders are made)")
    p.add_argument("--out", type=file_to_write(".npz"), default=None,
                   help="save the planned trajectory (.npz) for `dresspack export` (missing folders are made)")
    add_physics_argument(p, "the wear-aware planners simulate legs on and the plan is replayed in")
    p.add_argument("--jobs", type=number(1, MAX_JOBS, integer=True), default=ALL_CORES,
                   help="wear-aware planners: processes simulating candidate legs and refinement trials at once (the "
                        f"plan does not depend on it) (default {ALL_CORES}: all cores)")
    p.add_argument("--json", action="store_true", help="print the plan's summary (or its failure) as one JSON object")
    p.set_defaults(func=cmd_plan)


def cmd_plan(args) -> int:
    from dresspack_gym.plots.replay import plot_replays

    from .planners.base import PlanningError
    from .planners.registry import PEAK_AWARE, POLICY_METHODS, WEAR_AWARE, plan_station

    if args.welds is not None and not all(w.strip() for w in args.welds):
        raise ConfigError("--welds", f"an empty weld name in {args.welds}: give each weld's name, one per argument")
    extra = {"policy": args.policy} if args.planner in POLICY_METHODS else {}
    if args.tension_peak_time is not None:
        if args.planner not in PEAK_AWARE:
            raise ConfigError("tension_peak_time", f"--tension-peak-time applies to {' and '.join(PEAK_AWARE)} "
                                                   f"only, not {args.planner}")
        extra["tension_peak_time"] = args.tension_peak_time
    for name in ("proposals", "refine", "alternatives", "cost_to_go"):  # the learned planner's own settings
        if getattr(args, name) is not None:
            if args.planner != "ppo-search":
                raise ConfigError(name, f"--{name.replace('_', '-')} applies to ppo-search only, not {args.planner}")
            extra[name] = getattr(args, name)
    if args.time_weight is not None:
        if args.planner not in WEAR_AWARE:
            raise ConfigError("time_weight", f"--time-weight applies to {', '.join(WEAR_AWARE)} only, not "
                                             f"{args.planner}")
        extra["time_weight"] = args.time_weight
    if args.planner == "ppo-search":
        from .learned.search import auto_fallback

        note = auto_fallback(args.cost_to_go, args.policy)
        if note:
            print(note, file=sys.stderr)
    with ctrl_c_remembered() as pressed:
        try:
            run, failure = plan_station(args.station, args.planner, seed=args.seed, iterations=args.iterations,
                                        evaluations=args.evaluations, routes=args.routes,
                                        time_budget=args.time_budget, welds=args.welds,
                                        cost_variant=args.cost_variant, robot=args.robot, physics=args.physics,
                                        jobs=args.jobs, **extra), None
        except PlanningError as exc:  # a failed plan is a result, not a crash
            run, failure = None, exc
    if pressed():  # a Ctrl-C that OMPL swallowed as a failed check: the command still ends as interrupted
        raise KeyboardInterrupt
    if failure is not None:
        exc = failure
        if args.json:
            print(json.dumps({"method": args.planner, "success": False, "error": str(exc)}, indent=2))
        else:
            print(f"{args.planner}: failed: {exc}")
        return 1
    s = run.summary()
    if args.out:
        from dresspack_gym.physics.trajectory import plan_fingerprint, save_trajectory

        station = run.station
        with replacing(args.out) as tmp:
            save_trajectory(tmp, run.plan.trajectory, station=str(args.station),
                            robot=station.config.robots[run.task.robot].name,
                            speed_fraction=station.config.simulation.speed_fraction,
                            fingerprint=plan_fingerprint(station.config, run.task.robot))
        s["out"] = str(args.out)
    if args.plot:
        with replacing(args.plot) as tmp:
            plot_replays({args.planner: run.replay}, tmp)
        s["plot"] = str(args.plot)
    if args.json:
        print(json.dumps(s, indent=2, default=float))
        return 0
    print(f"{args.planner}: success, {s['waypoints']} waypoints, planned in {s['planning_time']:.2f} s")
    print(f"  cycle time {s['cycle_time']:.2f} s   integrated wear cost {s['cost']:.4g}   "
          f"(cable on the {ENGINE_TITLES[s['engine']]})")
    print(f"  max curvature {s['max_curvature']:.2f} 1/m   max tension {s['max_tension']:.1f} N   "
          f"min clearance {1000 * s['min_clearance']:.0f} mm   max twist rate {s['max_twist_rate']:.3g} rad/m")
    if s["planner_info"].get("wall_cap_reached"):
        print(f"  the wall-time cap of {args.time_budget:g} s cut the search short: the best route found by then")
    print(f"  damage (worst segment) {s['damage']:.4g} at {s['damage_at_m']:.2f} m   fatigue life "
          f"{s['life_cycles']:.3g} cycles (weakest segment at {s['weakest_segment_m']:.2f} m)")
    for key in ("plot", "out"):
        if getattr(args, key):
            print(f"wrote {getattr(args, key)}")
    return 0

