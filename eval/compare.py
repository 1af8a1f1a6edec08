"""``dresspack eval``: compare planners on the same welds and seeds and write the report folder.

    dresspack eval --planners ppo ompl ompl-wear --welds sill_rear,roof_rail_top --seeds 0 1 --out out/eval
    dresspack eval --station-plans station_plans/time station_plans/wear --station side_framing_4r --out out/plans
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from dresspack.agents.cli import add_budget_arguments
from dresspack.agents.learned.policy import DEFAULT_POLICY
from dresspack.agents.learned.search import MAX_ALTERNATIVES, MAX_PROPOSALS, MAX_REFINE
from dresspack.agents.planners.leg_cost import MAX_TIME_WEIGHT
from dresspack.agents.planners.registry import PLANNERS

from dresspack_gym.cli.args import (
    ALL_CORES,
    MAX_JOBS,
    Renamed,
    add_physics_argument,
    add_station_argument,
    number,
    output_dir,
    seed,
    warn_deprecated,
)
from dresspack_gym.errors import ConfigError, DresspackError
from dresspack_gym.io.outputs import output_folder
from dresspack_gym.physics.profiles import ENGINES
from dresspack_gym.physics.wear_cost import COST_VARIANTS

from .report import write_report
from .runs import EvalSpec, run_evaluation
from .summary import by_method, fmt, json_summary


def add_eval_arguments(p: argparse.ArgumentParser, defaults: EvalSpec = EvalSpec()) -> None:
    methods = "all" if set(defaults.methods) == set(PLANNERS) else " ".join(defaults.methods)
    tasks = " ".join(",".join(t) for t in defaults.tasks)
    if defaults.tasks == EvalSpec.tasks:
        tasks += ": the two weld pairs held out from the stud_welding policy's training"
    add_station_argument(p, default=defaults.station)
    p.add_argument("--planners", "--methods", action=Renamed, nargs="+", choices=list(PLANNERS),
                   default=list(defaults.methods), metavar="NAME",
                   help=f"the planners compared, any of {list(PLANNERS)} (default: {methods}; --methods: deprecated "
                        "spelling)")
    p.add_argument("--welds", "--tasks", action=Renamed, nargs="+", default=[",".join(t) for t in defaults.tasks],
                   metavar="WELDS",
                   help="one task per argument: its weld names, comma-separated, in visiting order (e.g. "
                        f"sill_rear,roof_rail_top) (default: {tasks}; --tasks: deprecated spelling)")
    p.add_argument("--seeds", nargs="+", type=seed, default=list(defaults.seeds),
                   help="seeds each planner runs each task with (the planners' seed, the start's draw) "
                        f"(default: {' '.join(map(str, defaults.seeds))})")
    p.add_argument("--drawn-tasks", type=number(0, 10_000, integer=True), default=defaults.drawn_tasks, metavar="N",
                   help="instead of --welds: N tasks of one weld each, drawn on the station's parts (weld k from "
                        f"--drawn-seed, k; default {defaults.drawn_tasks}: --welds)")
    p.add_argument("--drawn-seed", type=seed, default=defaults.drawn_seed,
                   help=f"seed of the welds --drawn-tasks draws (default {defaults.drawn_seed})")
    add_budget_arguments(p, defaults.iterations, defaults.evaluations, defaults.routes, defaults.time_budget)
    p.add_argument("--start-noise-deg", type=number(0, 90, unit="deg"), default=defaults.start_noise_deg,
                   help="> 0: each seed starts at a valid configuration within this many degrees of Home "
                        f"(default {defaults.start_noise_deg:g}: at Home)")
    p.add_argument("--policy", default=None,
                   help="ppo, ppo-search and random: run folder, model .zip or shipped policy name (default: "
                        f"{DEFAULT_POLICY})")
    p.add_argument("--cost-variant", choices=list(COST_VARIANTS), default=defaults.cost_variant,
                   help="wear cost the wear-aware planners minimise and the tables report (default: %(default)s)")
    p.add_argument("--time-weight", type=number(0, MAX_TIME_WEIGHT, unit="per s"), default=defaults.time_weight,
                   help="wear-aware planners: cost of one second of cycle time against one unit of ∫C dt in "
                        f"their leg cost (default: {defaults.time_weight:g}; larger trades wear for speed)")
    p.add_argument("--proposals", type=number(1, MAX_PROPOSALS, integer=True), default=defaults.proposals,
                   help="ppo-search: the policy's most probable moves each step tries, each continued by the policy "
                        f"to the end (default: {defaults.proposals}; 1: the policy's own rollout)")
    p.add_argument("--refine", type=number(0, MAX_REFINE, integer=True), default=defaults.refine, metavar="QUERIES",
                   help="ppo-search: leg-cost queries (accurate cable simulations of a leg) that move the found "
                        f"route's vias to cheaper ones (default: {defaults.refine}; 0: the route as found)")
    p.add_argument("--alternatives", type=number(0, MAX_ALTERNATIVES, integer=True), default=defaults.alternatives,
                   metavar="ROUTES",
                   help="ppo-search: OMPL routes (the direct one, then through random vias) per leg, each scored by "
                        "one cable simulation against the found route's leg before the refinement starts from the "
                        f"cheapest (default: {defaults.alternatives}; 0: the found route's legs only)")
    p.add_argument("--cost-to-go", default=defaults.cost_to_go, metavar="MODEL",
                   help="ppo-search: what ranks the proposals: auto (the cost-to-go model shipped with the policy, "
                        "if it ships one), none (simulate each one's continuation by the policy), a model.pt of "
                        "dresspack train-cost-model --config cost_to_go, or the name of a model shipped with the "
                        f"policy (default: {defaults.cost_to_go or 'none'})")
    add_physics_argument(p, "every method's final trajectory is replayed and measured in", defaults.physics)
    p.add_argument("--planner-physics", choices=list(ENGINES), default=defaults.planner_physics,
                   help="the cable engine the wear-aware planners simulate their legs on (default: %(default)s; "
                        "plans made on one engine can be judged on the other)")
    p.add_argument("--robustness-map", default=None,
                   help="robustness map folder to include in the report (default: none)")
    p.add_argument("--jobs", type=number(1, MAX_JOBS, integer=True), default=ALL_CORES,
                   help="processes the runs are spread over (one per core; the rows do not depend on it) "
                        f"(default {ALL_CORES}: all cores)")
    p.add_argument("--no-render", action="store_true", help="skip the rendered worst-wear frames")
    p.add_argument("--out", type=output_dir, default="out/eval",
                   help="report folder; an interrupted run resumes there (default: %(default)s)")
    p.add_argument("--json", action="store_true", help="print the per-method summary as JSON")


def spec_from_args(args) -> EvalSpec:
    """The evaluation the command line asks for; contradictory or empty arguments refused with the reason."""
    given = getattr(args, "_given_as", {})
    if args.drawn_tasks and "welds" in given:
        raise ConfigError("--drawn-tasks", f"draws its {args.drawn_tasks} tasks instead of the ones {given['welds']} "
                                           "names: give --drawn-tasks or --welds, not both")
    for task in args.welds:
        if not all(w.strip() for w in task.split(",")):
            raise ConfigError("--welds", f"{task!r} has an empty weld name: one task per argument, its weld names "
                                         "separated by single commas (e.g. sill_rear,roof_rail_top)")
    return EvalSpec(station=args.station, methods=tuple(args.planners),
                    tasks=tuple(tuple(t.split(",")) for t in args.welds), seeds=tuple(args.seeds),
                    iterations=args.iterations, evaluations=args.evaluations, routes=args.routes,
                    time_budget=args.time_budget,
                    start_noise_deg=args.start_noise_deg, policy=args.policy, cost_variant=args.cost_variant,
                    time_weight=args.time_weight, proposals=args.proposals, refine=args.refine,
                    alternatives=args.alternatives, cost_to_go=args.cost_to_go,
                    drawn_tasks=args.drawn_tasks, drawn_seed=args.drawn_seed, physics=args.physics,
                    planner_physics=args.planner_physics)


def evaluate_and_report(args) -> int:
    """Run, write the report, print the summary (JSON or a short table)."""
    try:
        spec = spec_from_args(args)
        if "ppo-search" in spec.methods:
            from dresspack.agents.learned.search import auto_fallback

            note = auto_fallback(spec.cost_to_go, spec.policy)
            if note:
                print(note, file=sys.stderr)
        if args.robustness_map is not None:  # checked now, not after the whole evaluation
            from dresspack_gym.maps.robustness.query import RobustnessMap

            RobustnessMap(args.robustness_map)
        rows, replays = run_evaluation(spec, args.out, progress=not args.json, jobs=args.jobs)
        paths = write_report(spec, rows, args.out, replays, robustness_map=args.robustness_map,
                             render=not args.no_render, jobs=args.jobs, progress=not args.json)
    except DresspackError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(json_summary(rows, spec.methods), indent=2))
        return 0
    print(short_table(rows, spec.methods))
    print(f"\nreport: {Path(paths['report_html']).resolve()}\n        {Path(paths['report_md']).resolve()}")
    return 0


def short_table(rows: list[dict], methods) -> str:
    agg = by_method(rows, methods)
    lines = [f"{'method':<13}{'success':>9}{'cycle time [s]':>18}{'∫C dt':>18}{'max κ':>14}{'max F [N]':>16}"]
    for m, a in agg.items():
        lines.append(f"{m:<13}{a['success_rate']:>9.0%}{fmt(a['cycle_time']):>18}{fmt(a['cost']):>18}"
                     f"{fmt(a['max_curvature']):>14}{fmt(a['max_tension']):>16}")
    return "\n".join(lines)


def compare_plans_and_report(args) -> int:
    """``--station-plans``: replay and measure each plan folder alike, write the comparison, print its table."""
    from .station_compare import compare_station_plans, station_table

    say = None if args.json else (lambda msg: print(msg, flush=True))
    try:  # the comparison is written only when every plan is replayed: a refused one leaves no folder behind
        with output_folder(args.out, keep_on_interrupt=False) as out:
            rows = compare_station_plans(args.station_plans, args.station, out, args.cost_variant, progress=say,
                                         engine=args.physics)
    except DresspackError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        print(station_table(rows, args.station, args.cost_variant, args.physics))
        print(f"\nwrote {Path(args.out).resolve()}/station_comparison.md (.json, .csv) and station_wear.png")
    return 0 if all(r["collisions"] == 0 and not r["jammed"] for r in rows) else 1


def add_eval_command(sub) -> None:
    """``dresspack eval`` (a ``dresspack`` subcommand, registered by entry point)."""
    p = sub.add_parser("eval", help="compare planners on the same welds, seeds and station and write a report folder",
                       description="Runs every planner on every task and seed, replays each plan in the same cable "
                                   "simulator and writes report.html / report.md with the tables and figures; an "
                                   "interrupted run resumes in its --out folder. With --station-plans: compares "
                                   "plan folders of `dresspack station-plan` instead.")
    add_eval_arguments(p)
    p.add_argument("--station-plans", nargs="+", type=Path, default=None, metavar="DIR",
                   help="instead of planners: plan folders written by `dresspack station-plan` (e.g. "
                        "station_plans/time station_plans/wear), each replayed on --station and measured alike; "
                        "the first is the reference of the relative columns (default: none)")
    p.set_defaults(func=cmd_eval)


def cmd_eval(args) -> int:
    try:
        if args.station_plans:
            return compare_plans_and_report(args)
        return evaluate_and_report(args)
    except KeyboardInterrupt:
        print(f"\ninterrupted: {_saved(args)}; resume with: dresspack {shlex.join(args.argv)}", file=sys.stderr)
        return INTERRUPTED


def main(argv: list[str] | None = None) -> int:
    """The ``dresspack-eval`` executable, kept for one release: ``dresspack eval`` with the same arguments."""
    from dresspack_gym.cli.main import main as dresspack_main

    warn_deprecated("dresspack-eval is deprecated; use dresspack eval")
    return dresspack_main(["eval", *(sys.argv[1:] if argv is None else argv)])


INTERRUPTED = 130  # the shell's exit status of a command ended by Ctrl-C (128 + SIGINT)


def _saved(args) -> str:
    """What an interrupted evaluation leaves: the runs finished so far (results.jsonl), which a rerun keeps."""
    if args.station_plans:
        return f"the comparison is written only when every plan is replayed (nothing in {args.out} is final)"
    results = Path(args.out) / "results.jsonl"
    done = sum(1 for line in results.read_text().splitlines() if line.strip()) if results.is_file() else 0
    return f"{done} finished runs saved in {results}"


if __name__ == "__main__":
    sys.exit(main())
