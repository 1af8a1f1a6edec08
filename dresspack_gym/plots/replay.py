"""Measures over time for one or more replayed trajectories, like the thesis Figures A.1-A.3."""

from __future__ import annotations

from pathlib import Path

from ..physics.trajectory import MEASURES, Replay

LABELS = {"curvature": ("curvature κ [1/m]", 1.0), "tension": ("tension F [N]", 1.0),
          "clearance": ("clearance d [m]", 1.0), "twist_rate": ("twist rate [rad/m]", 1.0)}


def plot_replays(replays: dict[str, Replay], path: str | Path, measures=MEASURES) -> str:
    """One panel per measure; threshold lines (κ0, c) dashed; the stops (welds, Home) as grey lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(measures), 1, figsize=(8, 2.2 * len(measures)), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], measures):
        for label, r in replays.items():
            line, = ax.plot(r.time, r.measures[name], label=label, lw=1.4)
            for t in r.stop_times:
                ax.axvline(t, color=line.get_color(), lw=0.6, ls=":", alpha=0.7)
        first = next(iter(replays.values()))
        if name in first.thresholds:
            ax.axhline(first.thresholds[name], color="r", ls="--", lw=1,
                       label="κ0" if name == "curvature" else "c")
        ax.set_ylabel(LABELS[name][0])
        ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("motion time [s] (dotted: weld / Home stops)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)
