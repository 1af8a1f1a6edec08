"""Write the comparison report: results.json/CSV, PNG figures, report.md and a self-contained report.html."""

from __future__ import annotations

import base64
import html
import json
import shutil
from pathlib import Path

import mujoco
import numpy as np
from dresspack.agents.learned.policy import resolve_policy
from dresspack.agents.learned.search import AUTO, resolve_cost_to_go
from dresspack.agents.planners.registry import COLORS

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.profiles import ENGINE_TITLES, make_simulator
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.physics.trajectory import Replay, replay
from dresspack_gym.plots.damage import plot_damage_along_cable, plot_damage_strip
from dresspack_gym.plots.replay import plot_replays
from dresspack_gym.plots.restrictions import plot_restrictions
from dresspack_gym.stations.station import Station

from .animations import Clip, render_clips
from .conclusion import conclude
from .runs import METRICS, EvalSpec, load_trajectory
from .summary import OPTIONAL, by_method, by_task, fmt, json_summary, rows_to_csv

HEADERS = {"cycle_time": "cycle time [s]", "max_curvature": "max κ [1/m]", "max_tension": "max F [N]",
           "min_clearance": "min d [m]", "max_twist_rate": "max twist [rad/m]", "cost": "∫C dt",
           "damage": "damage (worst seg.)", "life_cycles": "life [cycles]", "reversals_per_s": "reversals [1/s]",
           "peak_joint_acceleration": "peak q̈ [rad/s²]", "planning_time": "plan/infer [s]",
           "inference_time": "network [s]"}
# the overview's panels and which way is better on each
OVERVIEW = {"cycle_time": "lower", "cost": "lower", "max_curvature": "lower", "max_tension": "lower",
            "min_clearance": "higher", "planning_time": "lower"}


def write_report(spec: EvalSpec, rows: list[dict], out: str | Path, replays: dict[str, Replay] | None = None, *,
                 robustness_map: str | Path | None = None, render: bool = True, jobs: int = 1,
                 progress: bool = False) -> dict:
    """All report files into ``out``; returns {"report_md", "report_html", "results_json", "figures"}. The videos
    are rendered on ``jobs`` processes (the same files whatever ``jobs``)."""
    import matplotlib

    matplotlib.use("Agg")
    out = Path(out)
    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    replays = dict(replays or {})
    station = Station(load_station(spec.station))
    methods = list(spec.methods)
    summary = json_summary(rows, methods)
    (out / "results.json").write_text(json.dumps({"spec": spec.to_dict(), "summary": summary, "rows": rows},
                                                 indent=2) + "\n")
    (out / "results.csv").write_text(rows_to_csv(rows))

    answer = conclude(rows, methods, spec.time_weight)
    blocks: list[tuple] = [("h1", f"dresspack-gym evaluation: {station.config.name}"), ("h2", "Answer"),
                           ("ul", answer["bullets"])]
    if answer["table"]["rows"]:
        blocks.append(("table", answer["table"]))
    written = json.loads((out / "spec.json").read_text()) if (out / "spec.json").is_file() else {}
    blocks += [("h2", "Setup"), ("p", _intro(spec, station, written)), ("h2", "All tasks"),
               ("table", _table(by_method(rows, methods)))]
    figures = {}
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    if len(methods) > 1 or len(tasks) > 1:
        # one method: its bars over the tasks (bars over one method would be six panels of one bar each)
        groups = (by_method(rows, methods) if len(methods) > 1
                  else {t: per[methods[0]] for t, per in by_task(rows, methods).items()})
        colors = [COLORS.get(g if len(methods) > 1 else methods[0], "#444") for g in groups]
        wear = station.config.wear_cost
        thresholds = {"max_curvature": ("κ0", wear.curvature_threshold, "1/m"),
                      "min_clearance": ("c", wear.clearance, "m")}
        figures["overview"] = _overview_plot(groups, colors, thresholds, fig_dir / "overview.png")
        over = "method" if len(methods) > 1 else f"task ({methods[0]})"
        blocks.append(("img", figures["overview"],
                       f"Per {over}: mean ± std over the successful runs; the label at each bar's foot is its "
                       "success rate ('failed': no successful run, no bar). Dashed red: the wear cost's curvature "
                       "threshold κ0 and clearance threshold c.", "Overview of the headline metrics"))
    else:
        blocks.append(("p", "One method on one task: the table above is the whole overview."))
    blocks.append(("p", _settle_note(rows)))
    sim = make_simulator(station, spec.physics)
    if render:
        for anim in fig_dir.glob("anim_*.mp4"):  # a resumed report must not show the videos of an earlier run
            anim.unlink()
        render_clips(spec.station, spec.robot, _clips(rows, methods, out, fig_dir, replays), jobs=jobs,
                     progress=progress, engine=spec.physics)
    explained: set[str] = set()  # figure kinds whose legend a caption has explained (each explanation once)
    for task, per_method in by_task(rows, methods).items():
        blocks += [("h2", f"Task: home → {task} → home"), ("table", _table(per_method))]
        task_replays = {}
        for m in methods:
            r = next((r for r in rows if r["task"] == task and r["method"] == m and r["success"]), None)
            if r is not None:
                rep = replays.get(r["key"]) or _replay_saved(sim, out, r, spec.robot, spec.cost_variant)
                if rep is not None:
                    replays[r["key"]] = rep
                    task_replays[f"{m} (seed {r['seed']})"] = rep
        failed = [m for m in methods if not any(r["success"] for r in rows if r["task"] == task and r["method"] == m)]
        if task_replays:
            name = "measures_" + _slug(task) + ".png"
            plot_replays(task_replays, fig_dir / name, colors=COLORS)
            figures[f"measures {task}"] = str(fig_dir / name)
            caption = _once(explained, "measures", f"Measures over time on {task}",
                            " (thesis Figures A.1–A.3): the largest curvature κ, tension F and twist rate and the "
                            "smallest clearance d along the cable; dashed red: the thresholds κ0 and c; dotted: the "
                            "welds and the return Home")
            blocks.append(("img", str(fig_dir / name),
                           caption + "." + (f" Not shown (failed every seed): {', '.join(failed)}." if failed else ""),
                           f"Measures over time on {task}"))
            blocks += _damage_figures(task, task_replays, fig_dir, figures, explained)
            if render:
                blocks += _animations(task, rows, methods, fig_dir, figures, explained)
    blocks += [("h2", "Damage and fatigue life"), *_life_blocks(rows, methods, replays)]
    blocks.append(("h2", "Joint restrictions"))
    restr = fig_dir / "restrictions.png"
    plot_restrictions(station.config, str(restr))
    figures["restrictions"] = str(restr)
    blocks.append(("img", str(restr), "Where the joint restrictions forbid the wrist (thesis Figure 4.2 style): "
                                      "j5 over j6 in degrees, j1–j4 at Home; each shaded zone is labelled with the "
                                      "restriction that forbids it.", "Joint restrictions"))
    if robustness_map is not None:
        blocks += [("h2", "Robustness map")] + _robustness_blocks(robustness_map, fig_dir, figures)
    if render:
        blocks += [("h2", "Worst-wear moment per method")] + _worst_frames(rows, methods, replays, station, sim, out,
                                                                          fig_dir, figures, spec.robot,
                                                                          spec.cost_variant)
    blocks += [("h2", "Files"), ("p", "results.json (spec, per-method summary, every row), results.csv (one row "
                                       "per method × task × seed), results.jsonl (the resumable log), "
                                       "trajectories/ (each trajectory, replayable), figures/.")]
    (out / "report.md").write_text(_markdown(blocks, out))
    (out / "report.html").write_text(_html(blocks, station.config.name))
    return {"report_md": str(out / "report.md"), "report_html": str(out / "report.html"),
            "results_json": str(out / "results.json"), "figures": figures}


def _ranked_by(spec: EvalSpec) -> str:
    """What ranked ppo-search's proposals: the cost-to-go model's file, or the simulated continuations."""
    model = resolve_cost_to_go(spec.cost_to_go, resolve_policy(spec.policy)[0])
    if model is None:
        return " (each continued by the policy to the end in the simulation)"
    return (f" (ranked by the cost-to-go model {model.name} shipped with the policy)" if spec.cost_to_go == AUTO
            else f" (ranked by the cost-to-go model {spec.cost_to_go})")


def _intro(spec: EvalSpec, station: Station, written: dict) -> str:
    """The setup paragraph; ``written``: the folder's spec.json (the code and libraries its rows came from)."""
    starts = (f"each seed starts at its own valid configuration within {spec.start_noise_deg:g}° of Home"
              if spec.start_noise_deg > 0 else "every run starts at Home")
    search = (f"; ppo-search tries the policy's {spec.proposals} most probable moves per step{_ranked_by(spec)}, "
              f"{spec.alternatives} other routes per leg and {spec.refine} refinement queries"
              if "ppo-search" in spec.methods else "")
    libraries = ", ".join(f"{k} {v}" for k, v in (written.get("libraries") or {}).items() if v)
    provenance = (f" Rows computed by code {written['code']}" + (f" with {libraries}" if libraries else "") + "."
                  if written.get("code") else "")
    return (f"Methods {', '.join(spec.methods)} on {len(spec.tasks)} task(s) × seeds {list(spec.seeds)} "
            f"({starts}; every task ends at Home). Every trajectory is replayed in one cable engine, "
            + _engine_words(spec.physics, station)
            + "; the wear-aware planners simulate their legs on the " + ENGINE_TITLES[spec.planner_physics]
            + "; wear cost C is "
            + {"thesis": "eq. (4.10) with the station's weights", "normalized": "the normalized eq. (4.10)",
               "damage": "the worst segment's damage rate (dresspack damage weights)",
               "life": "w_life × the worst segment's fatigue damage of one excursion to each state (the dresspack's "
                       "strain–life model)"}[spec.cost_variant]
            + f" and ∫C dt its time integral. Planners get {spec.iterations} OMPL iterations per "
            f"connection, {spec.routes} sampled routes per leg (ompl-wear) and {spec.evaluations} cable-leg "
            f"evaluations of refinement per plan{search}"
            + (f", capped at {spec.time_budget:g} s. " if spec.time_budget is not None else ". ")
            + "Metrics are mean ± std over the successful runs (the mean alone where one run succeeded); a method "
              "that failed every run shows 'failed'." + provenance)


def _engine_words(engine: str, station: Station) -> str:
    """The judging engine and its resolution, as the report's setup paragraph names it."""
    segments = sorted({r.dresspack.segments for r in station.config.robots})
    cable = f"{'/'.join(map(str, segments))} cable segments"
    if engine == "dynamic":
        return f"the {ENGINE_TITLES[engine]} ({cable}, timestep {station.config.simulation.timestep * 1000:g} ms)"
    return f"the {ENGINE_TITLES[engine]} ({cable}, implicit steps of the rod's energy sample by sample)"


def _settle_note(rows: list[dict]) -> str:
    """Which runs had a settle (at a weld or Home) that missed the equilibrium residual: flagged, never hidden."""
    flagged = [f"{r['method']} on {r['task']} (seed {r['seed']}): {r['unconverged_stops']}"
               for r in rows if r.get("success") and r.get("unconverged_stops")]
    if not flagged:
        return "Every settle at the welds and Home reached the equilibrium residual."
    return "Settles that did not reach the equilibrium residual within their cap (stops per run): " + "; ".join(flagged)


def _table(per_method: dict[str, dict]) -> dict:
    # a learned planner's network time, apart from the env physics it also spends (planning_time holds both)
    extra = [k for k in OPTIONAL if any(a.get(k) for a in per_method.values())]
    header = ["method", "success", *[HEADERS[m] for m in (*METRICS, *extra)]]
    body = []
    for m, a in per_method.items():
        body.append([m, f"{a['n_success']}/{a['n_runs']} ({a['success_rate']:.0%})",
                     *[fmt(a[k]) for k in METRICS], *[fmt(a[k]) if a[k] else "–" for k in extra]])
    return {"header": header, "rows": body}


def _overview_plot(groups: dict[str, dict], colors: list[str], thresholds: dict[str, tuple], path: Path) -> str:
    """A bar per group (method, or task of the one method) on each headline metric; each panel says which way is
    better; the wear cost's thresholds are dashed lines with a legend entry."""
    import matplotlib.pyplot as plt

    labels = list(groups)
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5))
    for ax, (k, better) in zip(axes.ravel(), OVERVIEW.items()):
        means = [groups[g][k]["mean"] if groups[g][k] else 0.0 for g in labels]
        stds = [groups[g][k]["std"] if groups[g][k] else 0.0 for g in labels]
        yerr = [np.minimum(stds, means), stds] if k != "min_clearance" else stds  # no error bar below 0
        bars = ax.bar(labels, means, yerr=yerr, capsize=3, color=colors)
        for b, g in zip(bars, labels):
            a = groups[g]
            ax.annotate("failed" if a[k] is None else f"{a['success_rate']:.0%}", (b.get_x() + b.get_width() / 2, 0),
                        xytext=(0, 3), textcoords="offset points", ha="center", fontsize=7, color="black")
        if k in thresholds:
            symbol, value, unit = thresholds[k]
            ax.axhline(value, color="r", ls="--", lw=1, label=f"{symbol} = {value:g} {unit}")
            ax.set_ylim(0, 1.3 * max(value, *(m + s for m, s in zip(means, stds))))  # room for the legend
            ax.legend(fontsize=7, loc="upper right")
        if k in ("cost", "max_tension"):
            ax.set_yscale("symlog", linthresh=1.0)
        ax.set_title(HEADERS[k], fontsize=10)
        ax.set_ylabel(f"{better} is better", fontsize=8)
        ax.tick_params(axis="x", labelrotation=30, labelsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def _once(explained: set[str], kind: str, what: str, explanation: str) -> str:
    """``what`` plus ``explanation`` the first time a figure of ``kind`` appears; ``what`` alone after."""
    if kind in explained:
        return what
    explained.add(kind)
    return what + explanation


def _damage_figures(task: str, task_replays: dict[str, Replay], fig_dir: Path, figures: dict,
                    explained: set[str]) -> list[tuple]:
    """Damage and life along the cable per method, and the damage strip of the method whose cable lives least."""
    with_life = {k: r for k, r in task_replays.items() if r.fatigue is not None}
    if not with_life:
        return []
    along = fig_dir / f"damage_{_slug(task)}.png"
    plot_damage_along_cable(with_life, along, COLORS)
    worst = min(with_life, key=lambda k: with_life[k].fatigue.life_cycles.min())
    strip = fig_dir / f"damage_strip_{_slug(task)}.png"
    plot_damage_strip(with_life[worst], strip, f"Damage strip: {worst} on {task} (shortest life)")
    figures[f"damage {task}"], figures[f"damage strip {task}"] = str(along), str(strip)
    along_caption = _once(explained, "damage", f"Damage and fatigue life along the cable on {task}",
                          ": damage per cycle (all weighted terms, lower is better) and fatigue life (higher is "
                          "better) per segment, per method")
    strip_caption = _once(explained, "strip", f"Where and when the cable of {worst}, the shortest-lived on {task}, "
                                              "accrues damage", " (segment × time; dotted: welds and Home)")
    return [("img", str(along), along_caption + ".", f"Damage along the cable on {task}"),
            ("img", str(strip), strip_caption + ".", f"Damage strip of {worst} on {task}")]


def _life_blocks(rows: list[dict], methods, replays: dict[str, Replay]) -> list[tuple]:
    """Per method: the shortest fatigue life over its runs and where, the mean damage, and whether ranking the
    methods by life agrees with ranking them by ∫C dt (Spearman's rank correlation over the methods)."""
    body, life_mean, cost_mean = [], {}, {}
    for m in methods:
        reps = [(r, replays[r["key"]]) for r in rows if r["method"] == m and r["success"] and r["key"] in replays]
        reps = [(r, p) for r, p in reps if p.fatigue is not None]
        if not reps:
            body.append([m, "failed", "–", "–", "–"])
            continue
        lives = [p.fatigue.life_cycles.min() for _, p in reps]
        k = int(np.argmin(lives))
        worst = reps[k][1]
        life_mean[m] = float(np.exp(np.mean(np.log(lives))))
        cost_mean[m] = float(np.mean([r["cost"] for r, _ in reps]))
        body.append([m, f"{min(lives):.3g}", f"{life_mean[m]:.3g}",
                     f"{worst.fatigue.arc[worst.fatigue.weakest_segment]:.2f} m",
                     f"{np.mean([p.damage.total.max() for _, p in reps]):.3g}"])
    table = {"header": ["method", "shortest life [cycles]", "geometric-mean life", "weakest segment (shortest)",
                        "damage per cycle (worst segment)"], "rows": body}
    text = ("Fatigue life per station cycle from rainflow-counted conductor strains and the dresspack's strain–life "
            "curve (a model: read it as service life only where the dresspack's fatigue model is calibrated on its "
            "cable's rated tests, as stud_welding_rated's is; docs/wear.md, Calibrated life).")
    ranked = [m for m in methods if m in life_mean]
    if len(ranked) >= 3:
        by_life = _ranks([-life_mean[m] for m in ranked])  # longest life first
        by_cost = _ranks([cost_mean[m] for m in ranked])  # lowest ∫C dt first
        rho = float(np.corrcoef(by_life, by_cost)[0, 1])
        order_l = ", ".join(m for _, m in sorted(zip(by_life, ranked)))
        order_c = ", ".join(m for _, m in sorted(zip(by_cost, ranked)))
        text += (f" Ranked by life: {order_l}. Ranked by ∫C dt: {order_c}. Spearman's ρ = {rho:.2f} "
                 f"({'the two agree' if rho >= 0.8 else 'the two disagree'}).")
    return [("p", text), ("table", table)]


def _ranks(values) -> np.ndarray:
    return np.argsort(np.argsort(values)).astype(float)


def _replay_saved(sim: CableSimulator, out: Path, row: dict, robot: int, cost_variant: str = "thesis") -> Replay | None:
    traj = load_trajectory(out, row)
    return None if traj is None else replay(sim, traj, robot=robot, cost_variant=cost_variant, record_qpos=True)


def _robustness_blocks(folder, fig_dir: Path, figures: dict) -> list[tuple]:
    from dresspack_gym.maps.robustness.plots import plot_map
    from dresspack_gym.maps.robustness.query import RobustnessMap

    rmap = RobustnessMap(folder)
    blocks = [("p", f"Map {folder}: {rmap.n_measured} of {len(rmap.grid)} configurations measured, "
                    f"threshold {rmap.threshold * 1000:g} mm.")]
    explained: set[str] = set()
    for path in plot_map(folder, rmap.grid, rmap.threshold):
        dest = fig_dir / ("robustness_" + Path(path).name)
        shutil.copyfile(path, dest)
        figures[dest.stem] = str(dest)
        caption = _once(explained, "robustness", f"Robustness map: {Path(path).stem}",
                        " (thesis Figures 4.5 / 4.7 style)")
        blocks.append(("img", str(dest), caption + ".", f"Robustness map {Path(path).stem}"))
    return blocks


def _clips(rows, methods, out: Path, fig_dir: Path, replays: dict[str, Replay]) -> list[Clip]:
    """A video per task and method of its first successful run: the cable moving, measures underneath."""
    clips = []
    for task, per_method in by_task(rows, methods).items():
        for m in methods:
            row = next((r for r in rows if r["task"] == task and r["method"] == m and r["success"]), None)
            traj = load_trajectory(out, row) if row is not None else None
            if traj is not None:
                clips.append(Clip(str(_clip_path(fig_dir, task, m)), traj.waypoints, traj.stops,
                                  replays.get(row["key"])))
    return clips


def _clip_path(fig_dir: Path, task: str, method: str) -> Path:
    return fig_dir / f"anim_{_slug(task)}_{_slug(method)}.mp4"


def _animations(task: str, rows, methods, fig_dir: Path, figures: dict, explained: set[str]) -> list[tuple]:
    """The blocks of ``task``'s videos (rendered beforehand by :func:`render_clips`)."""
    blocks = []
    for m in methods:
        row = next((r for r in rows if r["task"] == task and r["method"] == m and r["success"]), None)
        path = _clip_path(fig_dir, task, m)
        if row is None or not path.is_file():
            continue
        figures[f"animation {task} {m}"] = str(path)
        blocks.append(("video", str(path), _once(explained, "animation", f"{m} (seed {row['seed']}) on {task}",
                                                 ": κ, F/10 and 10·d under the picture")))
    return blocks


def _worst_frames(rows, methods, replays, station, sim, out, fig_dir, figures, robot,
                  cost_variant: str = "thesis") -> list[tuple]:
    """Per method: its successful run with the highest instantaneous cost, rendered at that moment (on either
    engine: ``sim``'s; a rod-engine replay's cables are drawn from their points)."""
    from dresspack_gym.stations.rendering import StationRenderer, live_frame, replay_frame, save_png

    blocks = []
    renderer = None
    data = mujoco.MjData(station.model)
    try:
        for m in methods:
            ok = [r for r in rows if r["method"] == m and r["success"]]
            if not ok:
                blocks.append(("p", f"{m}: no successful run to render."))
                continue
            worst = max(ok, key=lambda r: r.get("max_cost") or 0.0)
            rep = replays.get(worst["key"]) or _replay_saved(sim, out, worst, robot, cost_variant)
            traj = load_trajectory(out, worst)
            if rep is None or traj is None:
                continue
            t = float(rep.time[int(np.argmax(rep.cost))])
            if rep.qpos is not None:  # the replay kept its positions: that moment without simulating again
                shown, cables = data, replay_frame(station, rep, int(np.argmax(rep.cost)), data)
            else:
                replay(sim, traj, robot=robot, until=t)
                shown, cables = live_frame(sim, data)
            if renderer is None:
                renderer = StationRenderer(station.model, width=640, height=480)
            path = fig_dir / f"worst_{_slug(m)}.png"
            save_png(renderer.render(shown, cables=cables), str(path))
            figures[f"worst {m}"] = str(path)
            i = int(np.argmax(rep.cost))
            blocks.append(("img", str(path), f"{m}: {worst['task']} (seed {worst['seed']}) at t = {t:.2f} s, "
                           f"C = {rep.cost[i]:.3g} (κ {rep.measures['curvature'][i]:.2f} 1/m, "
                           f"F {rep.measures['tension'][i]:.1f} N, d {rep.measures['clearance'][i]:.3f} m).",
                           f"Worst-wear moment of {m}"))
    finally:
        if renderer is not None:
            renderer.close()
    return blocks


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text).strip("_")


def _markdown(blocks, out: Path) -> str:
    lines = []
    for b in blocks:
        if b[0] == "h1":
            lines += [f"# {b[1]}", ""]
        elif b[0] == "h2":
            lines += [f"## {b[1]}", ""]
        elif b[0] == "p":
            lines += [b[1], ""]
        elif b[0] == "ul":
            lines += [f"- {item}" for item in b[1]] + [""]
        elif b[0] == "table":
            t = b[1]
            lines += ["| " + " | ".join(t["header"]) + " |", "|" + "---|" * len(t["header"])]
            lines += ["| " + " | ".join(row) + " |" for row in t["rows"]] + [""]
        elif b[0] == "img":
            lines += [f"![{b[3]}]({Path(b[1]).relative_to(out)})", "", f"*{b[2]}*", ""]
        elif b[0] == "video":
            lines += [f"[video: {b[2]}]({Path(b[1]).relative_to(out)})", ""]
    return "\n".join(lines)


CSS = """body{font-family:system-ui,sans-serif;max-width:1150px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:14px}th,td{border:1px solid #ccc;padding:4px 8px;
text-align:right}th{background:#f0f0f0}td:first-child,th:first-child{text-align:left;font-weight:600}
td.failed{color:#b00020;font-weight:600}img{max-width:100%;border:1px solid #ddd}figure{margin:1em 0}
figcaption{font-size:13px;color:#555}figure.video{display:inline-block;width:32%;margin:0.5em 1% 0.5em 0}
video{width:100%;border:1px solid #ddd}"""


def _html(blocks, title: str) -> str:
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{CSS}</style></head><body>"]
    for b in blocks:
        if b[0] in ("h1", "h2"):
            parts.append(f"<{b[0]}>{html.escape(b[1])}</{b[0]}>")
        elif b[0] == "p":
            parts.append(f"<p>{html.escape(b[1])}</p>")
        elif b[0] == "ul":
            parts.append("<ul>" + "".join(f"<li>{html.escape(item)}</li>" for item in b[1]) + "</ul>")
        elif b[0] == "table":
            t = b[1]
            head = "".join(f"<th>{html.escape(h)}</th>" for h in t["header"])
            body = "".join("<tr>" + "".join(f"<td{' class=failed' if c == 'failed' else ''}>{html.escape(c)}</td>"
                                            for c in row) + "</tr>" for row in t["rows"])
            parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
        elif b[0] == "img":
            data = base64.b64encode(Path(b[1]).read_bytes()).decode()
            parts.append(f"<figure><img src='data:image/png;base64,{data}' alt='{html.escape(b[3])}'>"
                         f"<figcaption>{html.escape(b[2])}</figcaption></figure>")
        elif b[0] == "video":
            data = base64.b64encode(Path(b[1]).read_bytes()).decode()
            parts.append(f"<figure class=video><video src='data:video/mp4;base64,{data}' autoplay loop muted "
                         f"playsinline controls></video><figcaption>{html.escape(b[2])}</figcaption></figure>")
    parts.append("</body></html>")
    return "\n".join(parts)
