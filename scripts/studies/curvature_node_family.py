"""The thesis curvature scenario on a family of fixed-node positions: its geometric condition checked, and the
Figure A.1 plots.

The condition (configs/stations/thesis_curvature.yaml): the node stands delta = 0.1-0.3 m directly above the tool
support's position p(s) partway along the direct Home -> Weld motion, with both clamps pointing down. Each node of
the family is p(s) + delta * z (+ h * the horizontal direction away from the robot, for the controls that break
the condition). For every node this runs

- the direct motion (`dresspack plan --station STATION --planner ompl`): its peak curvature, and its curvature at
  Home and at the weld;
- on the shipped node and three around it, also `thesis-local` and `ompl-wear`: their peak curvature against the
  direct one.

    .venv/bin/python scripts/studies/curvature_node_family.py [--seeds 0] [--out docs/data/curvature_node_family.json]

Every plan goes through `dresspack plan --station VARIANT.yaml --planner P --seed S --json --out TRAJ.npz` (the default
work budgets, given explicitly) and is replayed from its saved trajectory for the curves over time, which must
reproduce the plan's own peak. Writes the JSON (rows, summary and the curves),
docs/thesis_curvature_scenario.png (the shipped node, like the thesis's Figure A.1) and
docs/curvature_node_family.png (the same for the three neighbours); `--replot` redraws them from the JSON."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[2]
STATION = ROOT / "configs" / "stations" / "thesis_curvature.yaml"
PLANNERS = ("ompl", "thesis-local", "ompl-wear")
BUDGET = {"iterations": 3000, "routes": 12, "evaluations": 40}  # the CLI's defaults, passed explicitly
# (name, s, delta [m], h [m]): the shipped node is the first; h != 0 moves the node off the path (condition broken)
SHIPPED = "shipped"
NEIGHBOURS = (("s 0.50", 0.50, 0.2, 0.0), ("s 0.60", 0.60, 0.2, 0.0), ("delta 0.3", None, 0.3, 0.0))
DIRECT_ONLY = (("s 0.50, delta 0.1", 0.50, 0.1, 0.0), ("s 0.60, delta 0.1", 0.60, 0.1, 0.0),
               ("s 0.50, delta 0.3", 0.50, 0.3, 0.0), ("s 0.60, delta 0.3", 0.60, 0.3, 0.0),
               ("delta 0.1", None, 0.1, 0.0),
               ("off path: h +0.3", None, 0.2, 0.3), ("off path: h -0.3", None, 0.2, -0.3))


def tool_support_path(station_dict: dict, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Tool-support positions (n, 3) along the direct Home -> Weld motion (the joint-space straight line the
    wear-unaware planner returns here), and the parameters s in [0, 1]."""
    from dresspack_gym.io.loading import CONFIG_DIR, station_from_dict
    from dresspack_gym.stations.collision import RobotCollisionChecker
    from dresspack_gym.stations.station import Station
    from dresspack_gym.stations.tasks import make_task

    station = Station(station_from_dict(station_dict, CONFIG_DIR / "stations"))
    task = make_task(station, 0, RobotCollisionChecker(station, 0).collides)
    support = next(nd for nd in station.config.robots[0].dresspack.nodes if nd.body == "link6")
    kin = station.robots[0].kinematics
    s = np.linspace(0.0, 1.0, n)
    frames = [kin.link_frames(task.start + x * (task.goals[0] - task.start))[-1] for x in s]
    return np.array([f[:3, :3] @ np.asarray(support.pos) + f[:3, 3] for f in frames]), s


def node_geometry(node: np.ndarray, path: np.ndarray, s: np.ndarray) -> dict:
    """Where the node stands against the path: the closest point's s, the node's height above it and horizontal
    offset from it, and the horizontal distances to the tool support at Home and at Weld."""
    horizontal = np.linalg.norm((path - node)[:, :2], axis=1)
    i = int(np.argmin(horizontal))
    return {"s_closest": round(float(s[i]), 3), "height_above_path": round(float(node[2] - path[i, 2]), 3),
            "horizontal_offset": round(float(horizontal[i]), 3),
            "horizontal_distance_home": round(float(horizontal[0]), 3),
            "horizontal_distance_weld": round(float(horizontal[-1]), 3)}


def shipped_parameters(node: np.ndarray, path: np.ndarray, s: np.ndarray) -> tuple[float, float]:
    g = node_geometry(node, path, s)
    return g["s_closest"], g["height_above_path"]


def node_at(path: np.ndarray, s: np.ndarray, s_node: float, delta: float, h: float) -> np.ndarray:
    p = path[int(np.argmin(np.abs(s - s_node)))]
    away = np.array([p[0], p[1], 0.0]) / np.linalg.norm(p[:2])
    return np.round(p + delta * np.array([0.0, 0.0, 1.0]) + h * away, 3)


def with_node(station_dict: dict, node: np.ndarray) -> dict:
    d = json.loads(json.dumps(station_dict))
    d["robots"][0]["dresspack_overrides"]["nodes"][0]["pos"] = [float(x) for x in node]
    return d


def plan(dresspack: list[str], station_yaml: Path, planner: str, seed: int, out: Path) -> dict:
    cmd = [*dresspack, "plan", "--station", str(station_yaml), "--planner", planner, "--seed", str(seed), "--json",
           "--out", str(out)] + [a for k, v in BUDGET.items() for a in (f"--{k}", str(v))]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    return json.loads(done.stdout)


def curvature_over_time(station_yaml: Path, trajectory: Path) -> dict:
    """Replay a saved plan: time [s], the cable's largest curvature [1/m] and the weld / Home stop times."""
    from dresspack_gym.io.loading import load_station
    from dresspack_gym.physics.simulation import CableSimulator
    from dresspack_gym.physics.trajectory import load_trajectory_file, replay
    from dresspack_gym.stations.station import Station

    traj, _ = load_trajectory_file(trajectory)
    r = replay(CableSimulator(Station(load_station(station_yaml))), traj, record_states=False)
    return {"time": r.time.round(4).tolist(), "curvature": r.measures["curvature"].round(4).tolist(),
            "stop_times": [round(t, 4) for t in r.stop_times], "kappa0": r.thresholds["curvature"]}


def plot_curvature(ax, curves: dict[str, dict], title: str) -> None:
    """Figure A.1's layout: one line per planner, kappa0 dashed, the weld (the robot welding) dash-dotted."""
    for planner, c in curves.items():
        cost = "without" if planner == "ompl" else "with"
        line, = ax.plot(c["time"], c["curvature"], lw=1.4, label=f"{planner} ({cost} curvature cost)")
        weld_t = c["stop_times"][0]
        ax.axvline(weld_t, color=line.get_color(), ls="-.", lw=1.0)
    kappa0 = next(iter(curves.values()))["kappa0"]
    ax.axhline(kappa0, color="r", ls="--", lw=1, label="κ0")
    ax.plot([], [], color="grey", ls="-.", lw=1.0, label="welding")
    ax.set_title(title, fontsize=9)
    ax.set_ylabel("largest curvature κ [1/m]")
    ax.grid(alpha=0.3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "data" / "curvature_node_family.json")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--replot", action="store_true", help="only redraw the plots from the JSON's curves")
    ap.add_argument("--dresspack", nargs="+", default=[str(Path(sys.executable).with_name("dresspack"))],
                    help="the dresspack command (default: the one beside this Python)")
    args = ap.parse_args()
    if args.replot:
        result = json.loads(args.out.read_text())
        plot_all(result["curves"], result["nodes"], args.out.parent)
        return
    shipped = yaml.safe_load(STATION.read_text())
    path, s = tool_support_path(shipped)
    shipped_node = np.asarray(shipped["robots"][0]["dresspack_overrides"]["nodes"][0]["pos"], dtype=float)
    s0, delta0 = shipped_parameters(shipped_node, path, s)
    variants = [(SHIPPED, shipped_node, True)]
    variants += [(name, node_at(path, s, s0 if sv is None else sv, d, h), True) for name, sv, d, h in NEIGHBOURS]
    variants += [(name, node_at(path, s, s0 if sv is None else sv, d, h), False) for name, sv, d, h in DIRECT_ONLY]
    result = {"station": "thesis_curvature", "shipped": {"s": s0, "delta": delta0}, "budget": BUDGET, "rows": [],
              "kappa0": shipped["wear_cost"]["curvature_threshold"],
              "nodes": {name: node_geometry(node, path, s) | {"node": node.tolist()} for name, node, _ in variants}}
    curves: dict[str, dict[str, dict]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, node, all_planners in variants:
            yaml_path = Path(tmp) / f"{''.join(ch if ch.isalnum() else '_' for ch in name)}.yaml"
            yaml_path.write_text(yaml.safe_dump(with_node(shipped, node), sort_keys=False))
            geometry = node_geometry(node, path, s)
            for planner in PLANNERS if all_planners else PLANNERS[:1]:
                for seed in args.seeds if planner != "ompl" else args.seeds[:1]:  # the direct motion has no seed
                    traj = Path(tmp) / f"{yaml_path.stem}_{planner}_{seed}.npz"
                    summary = plan(args.dresspack, yaml_path, planner, seed, traj)
                    c = curvature_over_time(yaml_path, traj)
                    if abs(max(c["curvature"]) - summary["max_curvature"]) > 1e-3:
                        raise SystemExit(f"{name} {planner}: the replay peaks at {max(c['curvature'])}, the plan at "
                                         f"{summary['max_curvature']}")
                    if seed == args.seeds[0] and all_planners:
                        curves.setdefault(name, {})[planner] = c
                    weld = c["curvature"][c["time"].index(c["stop_times"][0])]
                    row = {"variant": name, "node": node.tolist(), **geometry, "planner": planner, "seed": seed,
                           "max_curvature": round(summary["max_curvature"], 3),
                           "curvature_home": c["curvature"][0], "curvature_weld": weld,
                           "cycle_time": summary["cycle_time"], "cost": round(summary["cost"], 4),
                           "planning_time": summary["planning_time"]}
                    result["rows"].append(row)
                    print(json.dumps(row), flush=True)
    summarise(result)
    result["curves"] = curves
    args.out.write_text(json.dumps(result, indent=1))
    plot_all(curves, result["nodes"], args.out.parent)


def summarise(result: dict) -> None:
    """Per variant: the direct peak, and each wear-aware planner's peak as a fraction less than it."""
    out = {}
    for r in result["rows"]:
        out.setdefault(r["variant"], {}).setdefault(r["planner"], []).append(r["max_curvature"])
    table = {}
    for variant, peaks in out.items():
        direct = peaks["ompl"][0]
        table[variant] = {"direct_peak": direct, "above_kappa0": round(direct / result["kappa0"] - 1, 3)}
        for planner in PLANNERS[1:]:
            if planner in peaks:
                table[variant][planner] = {"peaks": peaks[planner],
                                           "reduction": [round(1 - p / direct, 3) for p in peaks[planner]]}
    result["summary"] = table
    for variant, t in table.items():
        cells = [f"{variant}: direct {t['direct_peak']:.2f} 1/m"]
        cells += [f"{p} {' / '.join(f'{x:.2f}' for x in t[p]['peaks'])} "
                  f"(-{' / -'.join(f'{100 * x:.0f}' for x in t[p]['reduction'])} %)" for p in PLANNERS[1:] if p in t]
        print("; ".join(cells))


def node_title(name: str, g: dict) -> str:
    x, y, z = g["node"]
    return (f"node {name} at ({x:.2f}, {y:.2f}, {z:.2f}) m: {g['height_above_path']:.2f} m above the direct path at "
            f"s = {g['s_closest']:.2f}")


def plot_all(curves: dict[str, dict[str, dict]], nodes: dict[str, dict], folder: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if SHIPPED in curves:
        fig, ax = plt.subplots(figsize=(8, 3.6))
        plot_curvature(ax, curves[SHIPPED], "thesis_curvature, Home -> Weld -> Home (cf. thesis Figure A.1)\n"
                                            + node_title(SHIPPED, nodes[SHIPPED]))
        ax.set_xlabel("motion time [s]")
        ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()
        fig.savefig(folder / "thesis_curvature_scenario.png", dpi=110)
        plt.close(fig)
    others = [n for n in curves if n != SHIPPED]
    if others:
        fig, axes = plt.subplots(len(others), 1, figsize=(8, 2.8 * len(others)), sharex=True, squeeze=False)
        for ax, name in zip(axes[:, 0], others):
            plot_curvature(ax, curves[name], node_title(name, nodes[name]))
        axes[0, 0].legend(loc="upper right", fontsize=8)
        axes[-1, 0].set_xlabel("motion time [s]")
        fig.tight_layout()
        fig.savefig(folder / "curvature_node_family.png", dpi=110)
        plt.close(fig)


if __name__ == "__main__":
    main()
