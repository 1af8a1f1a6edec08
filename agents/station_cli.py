"""``dresspack station-plan``: plan every weld of a multi-robot station and write trajectories, pictures and a
summary (a ``dresspack`` subcommand, registered by entry point)."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

from dresspack_gym.cli.args import (
    ALL_CORES,
    MAX_JOBS,
    Renamed,
    add_physics_argument,
    add_station_argument,
    number,
    output_dir,
    seed,
)
from dresspack_gym.physics.wear_cost import COST_VARIANTS

from .planners.budget import DEFAULT_ITERATIONS, MAX_WORK
from .stations.solver import BLOCKED_ESTIMATES, BOUND_WORK, DEFAULT_WORK, LEG_ROUTES, OBJECTIVES, PAIR_SOLVES

WORK = number(1, MAX_WORK, integer=True)
INTERRUPTED = 130  # the shell's exit status of a command ended by Ctrl-C (128 + SIGINT)


def add_station_plan_command(sub) -> None:
    p = sub.add_parser("station-plan", help="assign, order and plan the welds of a multi-robot station, "
                                            "coordinate the robots, and measure every cable")
    add_station_argument(p, "station YAML or shipped name, e.g. side_framing_4r (default: %(default)s)",
                         deprecated_positional=True)
    p.add_argument("--objective", nargs="+", choices=OBJECTIVES, default=["time", "wear"],
                   help="time: shortest makespan; wear: least estimated wear within --makespan-slack of the "
                        "time plan's makespan; balanced: time + wear in equal measure. Several: one plan each, "
                        "compared (default: time wear)")
    p.add_argument("--weld-time", type=number(0, 600, unit="s"), default=1.0,
                   help="seconds a robot stands still at each weld (default 1)")
    p.add_argument("--welds", nargs="+", default=None, metavar="WELD",
                   help="weld point names to plan, one per argument (default: all)")
    p.add_argument("--fixed-assignment", action="store_true",
                   help="each weld by the robot its YAML names (default: by any robot that reaches it)")
    p.add_argument("--makespan-slack", type=number(0, 10), default=0.10,
                   help="wear objective: makespan allowed above the time plan's, as a fraction (default 0.1)")
    p.add_argument("--work", type=number(0, 1e6, lo_open=True), default=DEFAULT_WORK,
                   help="solver work budget per solve, in CP-SAT deterministic seconds (machine-independent; "
                        f"default {DEFAULT_WORK:g})")
    p.add_argument("--time-budget", type=number(0, 86400, lo_open=True, unit="s"), default=None, metavar="SECONDS",
                   help="optional wall-time cap per solve [s]; a solve stopped by it depends on machine load "
                        "(default: none)")
    p.add_argument("--iterations", type=WORK, default=DEFAULT_ITERATIONS,
                   help=f"OMPL iterations per leg that is not a straight move (default {DEFAULT_ITERATIONS})")
    p.add_argument("--blocked-estimate", choices=list(BLOCKED_ESTIMATES), default="planned_ratio",
                   help="the solver's time for a move it has not planned yet (blocked as a straight move): its "
                        "straight-move time x the median slow-down of the detours planned so far (planned_ratio, "
                        "default) or the straight-move time alone (straight, a lower bound)")
    p.add_argument("--leg-route", choices=list(LEG_ROUTES), default="fastest",
                   help="a leg whose straight move is blocked: the straight move's neighbourhood searched for one "
                        "via point, else OMPL, then shortened under the time law (fastest, default), or OMPL's "
                        "RRTConnect path as the single-robot ompl planner plans it (ompl)")
    p.add_argument("--stop-at-via-points", action="store_true",
                   help="every leg stops at each of its via points (default: a leg flies by them, corners rounded "
                        "within the joint limits, where the rounded curve is collision-free)")
    p.add_argument("--pair-solves", type=number(0, 10_000, integer=True), default=PAIR_SOLVES,
                   help="after the rounds, solves of two robots at a time with the others' routes held, each better "
                        f"answer's legs planned and coordinated (work units; 0: none; default {PAIR_SOLVES})")
    p.add_argument("--bound-work", type=number(0, 1e6, lo_open=True), default=BOUND_WORK,
                   help="CP-SAT deterministic seconds proving the makespan's lower bound, shared by the groups of "
                        f"robots that share welds; changes the bound, never the plan (default {BOUND_WORK:g})")
    p.add_argument("--costed-options", type=number(1, 1000, integer=True), default=8,
                   help="per weld and robot: IK options (nearest Home first) whose settled cable is costed "
                        "(default 8)")
    p.add_argument("--kept-options", type=number(1, 100, integer=True), default=2,
                   help="per weld and robot: options the solver chooses from, half nearest Home, half cheapest "
                        "of those costed (default 2)")
    p.add_argument("--legs-up-front", action="store_true",
                   help="wear and balanced objectives: plan every robot's moves between its Home and weld options "
                        "before solving, so the solver knows every leg (slower: on side_framing_4r 1,722 legs, "
                        "cached in OUT/planned_legs.jsonl for a later run; the time objective plans lazily anyway)")
    add_physics_argument(p, "every cable simulation of the plan runs on (the options' settles, the legs' runs, "
                            "the replays; fast has no contact between two robots' cables)")
    p.add_argument("--jobs", "--leg-workers", action=Renamed, type=number(1, MAX_JOBS, integer=True),
                   default=ALL_CORES,
                   help="processes costing the weld options, checking the straight moves, planning the legs and "
                        f"running them with their cables; the plans do not depend on it (default {ALL_CORES}: all "
                        "cores)")
    p.add_argument("--cost-variant", choices=list(COST_VARIANTS), default="thesis",
                   help="wear cost the options, the wear objective and the replays use (default: %(default)s)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the solver and the leg planners (default %(default)s)")
    p.add_argument("--cable-repairs", type=number(0, 100, integer=True), default=3,
                   help="times a plan is run in the cable simulator and the legs that jammed a cable re-routed "
                        "before it is final (default 3)")
    p.add_argument("--no-replay", action="store_true", help="skip running the plans in the cable simulator (and "
                                                            "so the cable repairs)")
    p.add_argument("--out", type=output_dir, default=Path("station_plans"),
                   help="output folder (default: station_plans/): per objective a folder with plan.json, one "
                        "trajectory per robot, gantt.png, wear.png, assignment.png; summary.md compares them")
    p.add_argument("--json", action="store_true", help="print the summary of every objective's plan as one JSON "
                                                        "object (no progress bars)")
    p.set_defaults(func=cmd_station_plan)


def cmd_station_plan(args) -> int:
    from tqdm import tqdm

    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station

    from .stations.report import write_summary

    out = args.out  # created by the first file written: a refused run leaves no folder behind
    objectives = list(dict.fromkeys(args.objective))
    try:
        configs = [_config(args, o) for o in objectives]  # a bad combination is refused before any work
        station = Station(load_station(args.station))
        bar = (lambda label, total: tqdm(total=total, desc=label, leave=False)) if not args.json else None
        plans = _plan_objectives(args, station, configs, out, bar)
    except KeyboardInterrupt:
        print(f"\ninterrupted: {_saved(out, objectives)}; resume with: "
              f"dresspack {shlex.join(getattr(args, 'argv', sys.argv[1:]))}", file=sys.stderr)
        return INTERRUPTED
    summary = write_summary(station, plans, out)
    if args.json:
        print(json.dumps(summary, indent=2, default=float))
    else:
        print(f"wrote {out}/summary.md and one folder per objective")
    ok = all(p.verification["collisions"] == 0 and (p.replay is None or not p.replay.jammed()) for p in plans.values())
    return 0 if ok else 1


def _config(args, objective: str):
    """The plan settings of ``objective`` from the command line (checked: a bad combination names its field)."""
    from .stations import StationPlanConfig

    return StationPlanConfig(objective=objective, weld_time=args.weld_time, work=args.work,
                             time_budget=args.time_budget, iterations=args.iterations,
                             makespan_slack=args.makespan_slack, seed=args.seed, cost_variant=args.cost_variant,
                             fixed_assignment=args.fixed_assignment,
                             cable_repairs=0 if args.no_replay else args.cable_repairs,
                             blocked_estimate=args.blocked_estimate, leg_route=args.leg_route,
                             fly_by=not args.stop_at_via_points, pair_solves=args.pair_solves,
                             bound_work=args.bound_work, costed_options=args.costed_options,
                             kept_options=args.kept_options, legs_up_front=args.legs_up_front,
                             physics=args.physics, jobs=args.jobs, welds=tuple(args.welds) if args.welds else None)


def _plan_objectives(args, station, configs, out: Path, bar) -> dict:
    """Each objective planned (one planner: costs and legs shared), saved and drawn as it finishes."""
    from .stations import StationPlanner

    plans = {}
    planner = None
    try:
        for cfg in configs:
            # one planner object: settled-cable costs and planned legs are shared between the objectives
            planner = StationPlanner(station, cfg, progress=bar) if planner is None else planner.reconfigured(cfg)
            plans[cfg.objective] = _plan_objective(args, station, planner, out)
    finally:
        if planner is not None:
            planner.close()  # the worker processes, also after Ctrl-C
    return plans


def _plan_objective(args, station, planner, out: Path):
    """The objective of ``planner``'s config planned, replayed, saved and drawn, and its line printed."""
    from .stations import save_plan
    from .stations.report import ENGINE_NOTES, plot_plan

    cfg = planner.config
    plan = planner.plan(cache=out / "option_costs.json", leg_cache=out / "planned_legs.jsonl")
    if not args.no_replay and plan.replay is None:
        planner.replay(plan)
    folder = out / cfg.objective
    save_plan(plan, folder)
    plot_plan(station, plan, folder)
    if not args.json:
        s = plan.summary()
        line = (f"{cfg.objective}: makespan {s['makespan']:.1f} s (lower bound {s['makespan_lower_bound']:.1f} s), "
                f"waits {s['total_wait']:.1f} s, robot-robot collisions {s['verification']['collisions']}")
        if plan.replay is not None:
            line += f", integrated wear {s['replay']['cost']:.4g} ({ENGINE_NOTES[s['replay']['engine']]})"
            if not s["replay"]["start_settled"]:
                line += (f" -- the cables' start at Home is not settled (force residual "
                         f"{s['replay']['start_force_residual']:.3g} of a vertex weight)")
            if s["replay"]["jammed"]:
                line += f" -- JAMMED cable(s) {', '.join(s['replay']['jammed'])}: pulled beyond 5 % strain " \
                        "(pinned by a robot); the wear figure is not meaningful"
        if s["info"].get("rerouted_legs"):
            line += f" -- {len(s['info']['rerouted_legs'])} leg(s) re-routed or blocked after jamming a cable"
        if s["info"]["unconverged_cost_settles"]:
            line += (f" -- wear estimates of {', '.join(s['info']['unconverged_cost_settles'])} come from "
                     "settles that did not reach equilibrium")
        print(line)
    return plan


def _saved(out: Path, objectives: list[str]) -> str:
    """What an interrupted run leaves in ``out`` for the next run with the same arguments (which reads the option
    costs and the legs planned up front back, and plans the objectives again)."""
    kept = [f for f in ("option_costs.json", "planned_legs.jsonl") if (out / f).is_file()]
    kept += [f"{o}/plan.json" for o in objectives if (out / o / "plan.json").is_file()]
    return f"saved {', '.join(kept)} in {out}" if kept else "nothing saved yet"
