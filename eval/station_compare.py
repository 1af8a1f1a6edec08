"""``dresspack eval --station-plans``: station plans (e.g. time-only against wear-aware) compared like single-robot
methods: each plan replayed in the same cable simulator, checked by the same dense collision check and measured the
same way (makespan, ∫C dt, peak measures, smoothness), into one table, a JSON/CSV and a picture of the wear over the
cycle. The cables run on one engine (physics.profiles.ENGINES, ``--physics``); the rod engine (fast) has no contact
between two robots' cables, so a plan whose cables meet reads better on it than on MuJoCo (dynamic).

    dresspack eval --station-plans station_plans/time station_plans/wear --station side_framing_4r --out out/plans
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
from dresspack.agents.stations import RECORD_EVERY

from dresspack_gym.io.loading import load_station
from dresspack_gym.multi.coordination import verify
from dresspack_gym.multi.replay import replay_station
from dresspack_gym.multi.schedule import load_schedule
from dresspack_gym.physics.profiles import DEFAULT_ENGINE, ENGINE_TITLES, make_simulator
from dresspack_gym.physics.trajectory import schedule_smoothness
from dresspack_gym.stations.station import Station

COLUMNS = ("plan", "makespan", "waits", "cost", "max_curvature", "max_tension", "min_clearance", "collisions",
           "samples", "min_robot_distance", "reversals_per_s", "peak_joint_acceleration", "jammed", "start_settled")


def station_plan_row(name: str, folder: Path, station: Station, cost_variant: str = "thesis",
                     engine: str = DEFAULT_ENGINE) -> tuple[dict, object]:
    """One plan folder replayed on ``engine`` and measured: (its row, its replay)."""
    schedule, _ = load_schedule(folder, station)
    replay = replay_station(make_simulator(station, engine), schedule, record_every=RECORD_EVERY,
                            cost_variant=cost_variant)
    check = verify(station, schedule)
    names = [r.name for r in station.config.robots]
    per = replay.integrated_cost()
    moving = [schedule_smoothness(s) for s in schedule.robots if s.welds]
    row = {"plan": name, "folder": str(folder), "engine": replay.engine, "makespan": schedule.makespan,
           "waits": max(0.0, schedule.total_wait()),
           "cost": float(per.sum()),
           "max_curvature": float(replay.measures["curvature"].max()),
           "max_tension": float(replay.measures["tension"].max()),
           "min_clearance": float(replay.measures["clearance"].min()),
           "collisions": int(check["collisions"]), "samples": int(check["samples"]),
           "min_robot_distance": float(check["min_distance"]),
           # per robot that works, averaged (reversals) and the largest (acceleration), as the eval tables read them
           "reversals_per_s": float(np.mean([m["reversals_per_s"] for m in moving])) if moving else 0.0,
           "peak_joint_acceleration": max((m["peak_joint_acceleration"] for m in moving), default=0.0),
           "jammed": [names[i] for i in replay.jammed()],
           "start_settled": bool(replay.start.converged) if replay.start is not None else None,
           "robots": {n: {"cost": float(per[i]), "max_tension": float(replay.measures["tension"][:, i].max()),
                          "end_time": schedule.robots[i].end_time, **schedule_smoothness(schedule.robots[i])}
                      for i, n in enumerate(names)}}
    return row, replay


def compare_station_plans(folders: list[Path], station_ref: str, out: Path, cost_variant: str = "thesis",
                          progress=None, engine: str = DEFAULT_ENGINE) -> list[dict]:
    """Replay every plan folder (named by its folder) on ``engine`` and measure it, write ``station_comparison.md``,
    ``.json``, ``.csv`` and ``station_wear.png`` under ``out``; the rows."""
    station = Station(load_station(station_ref))
    out.mkdir(parents=True, exist_ok=True)
    names = _plan_names(folders)
    rows, replays = [], []
    for name, folder in zip(names, folders):
        if progress is not None:
            progress(f"replaying {folder}")
        row, replay = station_plan_row(name, Path(folder), station, cost_variant, engine)
        rows.append(row)
        replays.append(replay)
    (out / "station_comparison.json").write_text(json.dumps(rows, indent=1))
    with open(out / "station_comparison.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([", ".join(r[c]) if isinstance(r[c], list) else r[c] for c in COLUMNS])
    (out / "station_comparison.md").write_text(station_table(rows, station.config.name, cost_variant, engine) + "\n")
    _plot_wear(rows, replays, out / "station_wear.png", station.config.name)
    return rows


def station_table(rows: list[dict], station_name: str = "", cost_variant: str = "thesis",
                  engine: str = DEFAULT_ENGINE) -> str:
    """The comparison as a markdown table (the first plan is the reference of the relative columns)."""
    ref = rows[0]
    limit = " (no contact between two robots' cables)" if engine == "fast" else ""
    lines = [f"# Station plans compared: {station_name} (cost: {cost_variant}; cables: {ENGINE_TITLES[engine]}{limit})",
             "",
             ("| plan | makespan [s] | waits [s] | ∫C dt | vs first | max κ [1/m] | max F [N] | min clearance [m] | "
              "robot-robot collisions | min robot distance [mm] | reversals/s | peak q̈ [rad/s²] | jammed |"),
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        rel = f"{100 * (r['cost'] / ref['cost'] - 1):+.1f} %" if ref["cost"] > 0 else "-"
        lines.append(f"| {r['plan']} | {r['makespan']:.2f} ({100 * (r['makespan'] / ref['makespan'] - 1):+.1f} %) | "
                     f"{r['waits']:.2f} | {r['cost']:.4g} | {rel} | {r['max_curvature']:.1f} | "
                     f"{r['max_tension']:.1f} | {r['min_clearance']:.3f} | {r['collisions']} of {r['samples']} | "
                     f"{1000 * r['min_robot_distance']:.0f} | {r['reversals_per_s']:.2f} | "
                     f"{r['peak_joint_acceleration']:.1f} | {', '.join(r['jammed']) or 'none'} |")
    return "\n".join(lines)


def _plan_names(folders: list[Path]) -> list[str]:
    """Each folder's last part (e.g. ``time``, ``wear``), with its parent where two would read the same."""
    short = [Path(f).name for f in folders]
    return [s if short.count(s) == 1 else f"{Path(f).parent.name}/{s}" for s, f in zip(short, folders)]


def _plot_wear(rows: list[dict], replays: list, path: Path, station_name: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    for row, rep in zip(rows, replays):
        label = f"{row['plan']}: {row['cost']:.4g} in {row['makespan']:.2f} s"
        ax.plot(rep.time, rep.running_cost().sum(axis=1), label=label)
    ax.set_xlabel("station clock [s]")
    ax.set_ylabel("∫C dt, all cables")
    ax.set_title(f"{station_name}: wear over the cycle")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
