"""``dresspack demo`` (the README's main job), registered as a ``dresspack`` subcommand (entry point)."""

from __future__ import annotations

from .compare import add_eval_arguments, evaluate_and_report
from .runs import EvalSpec

# ompl-wear-fmt is left out: the default station ships no wear map, where it plans exactly as ompl-wear does
DEMO = EvalSpec(methods=("ppo-search", "ppo", "ompl", "thesis-local", "ompl-wear", "random"),
                tasks=(("sill_rear", "roof_rail_top"), ("b_pillar_outer", "sill_front"), ("floor_pan_inner",)),
                seeds=(0, 1))  # every planner at its default budget; about 5 min of CPU, spread over --jobs processes


def add_demo_command(sub) -> None:
    p = sub.add_parser("demo", help="the learned planner vs the OMPL baselines on the default station: a report",
                       description="Runs ppo-search (the shipped goal-conditioned policy with a rollout search), "
                                   "ppo (the policy alone), ompl, thesis-local, ompl-wear and a random masked "
                                   "floor on three tasks x two seeds, replays everything in the same "
                                   "simulator and writes report.html / report.md (about 5 min of CPU, its runs "
                                   "spread over all cores: --jobs).")
    add_eval_arguments(p, DEMO)
    p.set_defaults(func=evaluate_and_report, out="out/demo")

