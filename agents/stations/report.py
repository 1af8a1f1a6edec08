"""What ``dresspack station-plan`` writes beside the plans: the pictures of each plan and a summary comparing them."""

from __future__ import annotations

import json
from pathlib import Path

from dresspack_gym.physics.profiles import ENGINE_TITLES
from dresspack_gym.plots.station_plan import plot_assignment, plot_gantt, plot_wear

# a replay's engine, as the command's line names it beside the wear figure
ENGINE_NOTES = {"dynamic": "MuJoCo", "fast": "rod engine, no contact between two robots' cables"}
# what a plan judged on the rod engine cannot have seen (docs/rod_engine.md), said where its replay is reported
FAST_ENGINE_LIMIT = ("the rod engine has no contact between two robots' cables: a cable caught on another robot's "
                     "cable is neither felt nor flagged as a jam; `--physics dynamic` (MuJoCo) replays with it")


def plot_plan(station, plan, folder: Path) -> None:
    title = f"{station.config.name}: {plan.config.objective} objective"
    plot_gantt(plan.schedule, plan.names, folder / "gantt.png", f"{title}, makespan {plan.schedule.makespan:.1f} s")
    plot_assignment(station, plan.robot_welds(), folder / "assignment.png", title)
    if plan.replay is not None:
        plot_wear(plan.replay, plan.names, folder / "wear.png", f"{title}: wear measures per robot")


def write_summary(station, plans: dict, out: Path) -> dict:
    """summary.md (a table, one row per objective) and summary.json."""
    rows = {name: p.summary() for name, p in plans.items()}
    lines = [f"# Station plans: {station.config.name}", "",
             "| objective | makespan [s] | lower bound [s] | gap | waits [s] | robot-robot collisions "
             "(dense check) | min robot distance [mm] | integrated wear ∫C dt | wear estimate |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, s in rows.items():
        v = s["verification"]
        wear = f"{s['replay']['cost']:.4g}" if "replay" in s else "not run"
        if "replay" in s and s["replay"]["jammed"]:
            wear += f" (jammed: {', '.join(s['replay']['jammed'])})"
        lines.append(f"| {name} | {s['makespan']:.2f} | {s['makespan_lower_bound']:.2f} | "
                     f"{100 * s['gap_to_bound']:.1f} % | {s['total_wait']:.2f} | {v['collisions']} of {v['samples']} "
                     f"samples | {1000 * v['min_distance']:.0f} | {wear} | {s['estimate']['wear']:.4g} |")
    engines = sorted({s["replay"]["engine"] for s in rows.values() if "replay" in s})
    if engines:
        lines += ["", "Cables simulated on: " + ", ".join(ENGINE_TITLES[e] for e in engines)
                  + (f" ({FAST_ENGINE_LIMIT})" if "fast" in engines else "") + "."]
    for name, s in rows.items():
        b = s.get("wear_estimate_bound")
        if b and b.get("bound") is not None:
            line = (f"**{name}**: no routes over these weld options back Home within {b['makespan_cap']:.2f} s have a "
                    f"wear estimate below **{b['bound']:.4g}** (CP-SAT's bound on straight-move times, waits and "
                    "conflicts left out; the estimate charges a move its ends' mean settled rate)")
            if b.get("best") is not None:
                line += f"; the least-wear routes it found estimate {b['best']:.4g}"
            time_wear = rows.get("time", {}).get("replay", {}).get("cost")
            if time_wear:
                below = 100 * (1 - b["bound"] / time_wear)
                line += f"; that bound is {below:.1f} % below the time plan's replayed wear"
            lines += ["", line + "."]
    for name, s in rows.items():
        moved = s["info"].get("rerouted_legs") or []
        if moved:
            replays = s["info"].get("cable_replays")
            lines += ["", f"**{name}**: {len(moved)} leg(s) jammed a cable and were re-routed or blocked before this "
                          f"plan" + (f" ({replays} station replays)" if replays else "") + ": "
                      + "; ".join(f"{m['robot']} {m['from']} -> {m['to']} ({m['why']}): {m['now'].replace('_', ' ')}"
                                  for m in moved)]
    split = {name: s["replay"]["wear_split"] for name, s in rows.items() if "wear_split" in s.get("replay", {})}
    if split:
        phases = list(next(iter(next(iter(split.values())).values()))["by_phase"])
        terms = [t for t in next(iter(next(iter(split.values())).values()))["by_term"]
                 if any(r["by_term"][t] for per in split.values() for r in per.values())]
        lines += ["", ("Where the replayed wear ∫C dt accrues, all robots (by what each robot was doing, and by the "
                       "cost's terms); *cheapest welding* is every weld at its cheapest costed option:"), "",
                  "| objective | " + " | ".join(phases) + " | cheapest welding | " + " | ".join(terms) + " |",
                  "|---|" + "---|" * (len(phases) + 1 + len(terms))]
        for name, per in split.items():
            by_phase = [sum(r["by_phase"][p] for r in per.values()) for p in phases]
            by_term = [sum(r["by_term"][t] for r in per.values()) for t in terms]
            cheapest = rows[name]["info"].get("cheapest_weld_wear", float("nan"))
            lines.append(f"| {name} | " + " | ".join(f"{x:.4g}" for x in by_phase) + f" | {cheapest:.4g} | "
                         + " | ".join(f"{x:.4g}" for x in by_term) + " |")
    lines += ["", "Per robot (welds in order):", ""]
    for name, s in rows.items():
        lines.append(f"- **{name}**: " + "; ".join(f"{r}: {', '.join(w) if w else '(stays Home)'}"
                                               for r, w in s["welds"].items()))
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    (out / "summary.json").write_text(json.dumps(rows, indent=1, default=float))
    return rows
