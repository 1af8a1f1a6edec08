"""Measures over time for one or more replayed trajectories, like the thesis Figures A.1-A.3."""

from __future__ import annotations

from pathlib import Path

from ..physics.trajectory import MEASURES, Replay

LABELS = {"curvature": ("curvature κ [1/m]", 1.0), "tension": ("tension F [N]", 1.0),
          "clearance": ("clearance d [m]", 1.0), "twist_rate": ("twist rate [rad/m]", 1.0)}
BETTER = {"curvature": "lower", "tension": "lower", "clearance": "higher", "twist_rate": "lower"}
THRESHOLDS = {"curvature": ("curvature threshold κ0", "1/m"), "clearance": ("clearance threshold c", "m")}


def plot_replays(replays: dict[str, Replay], path: str | Path, measures=MEASURES, colors: dict | None = None) -> str:
    """One panel per measure; threshold lines (κ0, c) dashed; the stops (welds, Home) as dotted lines. ``colors``:
    a colour per label's first word (the method), as in the report's other figures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(measures), 1, figsize=(8, 2.2 * len(measures)), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], measures):
        for label, r in replays.items():
            line, = ax.plot(r.time, r.measures[name], label=label, lw=1.4,
                            color=(colors or {}).get(label.split(" ")[0]))
            for t in r.stop_times:
                ax.axvline(t, color=line.get_color(), lw=0.6, ls=":", alpha=0.7)
        first = next(iter(replays.values()))
        if name in first.thresholds:
            what, unit = THRESHOLDS[name]
            line = ax.axhline(first.thresholds[name], color="r", ls="--", lw=1,
                              label=f"{what} = {first.thresholds[name]:g} {unit}")
            if ax is not axes[0, 0]:  # the first panel's legend lists the runs too
                ax.legend(handles=[line], loc="upper right", fontsize=8)
        ax.set_ylabel(f"{LABELS[name][0]}\n{BETTER.get(name, 'lower')} is better", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("motion time [s] (dotted: weld / Home stops)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)
