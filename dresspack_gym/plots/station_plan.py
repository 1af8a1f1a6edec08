"""Pictures of a station plan: the Gantt chart (motion, welding, waiting per robot), each robot's wear cost over the
cycle, and the weld assignment drawn on the station seen from above."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ..robots.kinematics import rpy_matrix

ROBOT_COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666")
ACTIVITY_COLORS = {"motion": "#4c78a8", "weld": "#e45756", "wait": "#bbbbbb"}


def plot_gantt(schedule, names: list[str], path, title: str = "") -> None:
    fig, ax = plt.subplots(figsize=(10, 0.6 + 0.55 * len(names)))
    for s in schedule.robots:
        for kind, spans in s.intervals().items():
            if spans:
                ax.broken_barh([(a, b - a) for a, b in spans], (s.robot - 0.35, 0.7), color=ACTIVITY_COLORS[kind],
                               label=kind)
    handles = {h.get_label(): h for h in ax.get_children() if h.get_label() in ACTIVITY_COLORS}
    ax.legend(handles.values(), handles.keys(), loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=3, fontsize=8,
              frameon=False)
    ax.axvline(schedule.makespan, color="k", lw=0.8, ls="--")
    ax.set_yticks(range(len(names)), names)
    ax.invert_yaxis()
    ax.set_xlabel("station time [s]")
    ax.set_title(title or f"makespan {schedule.makespan:.1f} s", loc="left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_wear(replay, names: list[str], path, title: str = "") -> None:
    fields = [("cost", "wear cost C"), ("curvature", "max curvature [1/m]"), ("tension", "max tension [N]"),
              ("clearance", "min clearance [m]")]
    fig, axes = plt.subplots(len(fields), 1, figsize=(10, 8), sharex=True)
    for ax, (key, label) in zip(axes, fields):
        values = replay.cost if key == "cost" else replay.measures[key]
        for i, n in enumerate(names):
            ax.plot(replay.time, values[:, i], color=ROBOT_COLORS[i % len(ROBOT_COLORS)], lw=1, label=n)
        ax.set_ylabel(label, fontsize=8)
    axes[0].legend(ncol=len(names), fontsize=8)
    axes[-1].set_xlabel("station time [s]")
    axes[0].set_title(title or "wear measures per robot")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_assignment(station, plan_welds: dict[str, list[str]], path, title: str = "") -> None:
    """Top view: obstacles, robot bases, each robot's welds in its colour joined in welding order."""
    cfg = station.config
    fig, ax = plt.subplots(figsize=(8, 8))
    for o in cfg.obstacles:
        if o.type == "box":
            hx, hy = o.size[0], o.size[1]
            rot = rpy_matrix(o.rpy)[:2, :2]
            corners = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]]) @ rot.T + np.asarray(o.pos[:2])
            ax.fill(corners[:, 0], corners[:, 1], color="#cccccc", alpha=0.5, lw=0.5, ec="#888888")
    pos = {w.name: np.asarray(w.pos) for w in cfg.weld_points}
    for i, r in enumerate(cfg.robots):
        c = ROBOT_COLORS[i % len(ROBOT_COLORS)]
        base = np.asarray(r.base_pos)
        ax.add_patch(plt.Circle(base[:2], 0.25, color=c, alpha=0.8))
        ax.annotate(r.name, base[:2], ha="center", va="center", color="w", fontsize=9, weight="bold")
        welds = plan_welds.get(r.name, [])
        if welds:
            pts = np.array([base[:2]] + [pos[w][:2] for w in welds] + [base[:2]])
            ax.plot(pts[:, 0], pts[:, 1], "-", color=c, lw=1, alpha=0.6)
            ax.plot(pts[1:-1, 0], pts[1:-1, 1], "o", color=c, ms=5)
            for k, w in enumerate(welds):
                ax.annotate(str(k + 1), pos[w][:2], fontsize=6, xytext=(3, 3), textcoords="offset points", color=c)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or "weld assignment and order (top view)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
