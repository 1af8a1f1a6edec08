"""Robustness plots like thesis Figures 4.5 (deviation per configuration) and 4.7 (non-robust count over Ry)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .grid import RobustnessGrid
from .store import load_results


def plot_map(out: str | Path, grid: RobustnessGrid, threshold: float) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    rows = load_results(out)
    idx = np.array(sorted(rows), dtype=int)
    dev = np.array([rows[i][1] for i in idx])
    paths = []
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.scatter(idx, dev * 1000, s=3, c=np.where(dev >= threshold, "#d1495b", "#2e4057"))
    ax.axhline(threshold * 1000, color="red", ls="--", lw=1, label=f"d_thresh = {threshold * 1000:.0f} mm")
    ax.set_xlabel("configuration index")
    ax.set_ylabel("max shape deviation [mm]")
    ax.set_title(f"{grid.name}: {int((dev >= threshold).sum())} of {len(dev)} configurations non-robust "
                 f"({100 * np.mean(dev >= threshold):.1f} %)")
    ax.legend(loc="upper right")
    fig.tight_layout()
    paths.append(str(out / "deviation_per_config.png"))
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)
    per_ry_axis = len(grid) // len(grid.ry)
    counts = [int(((idx // per_ry_axis == k) & (dev >= threshold)).sum()) for k in range(len(grid.ry))]
    totals = [int((idx // per_ry_axis == k).sum()) for k in range(len(grid.ry))]
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(np.degrees(grid.ry), counts, width=0.8 * np.degrees(np.diff(grid.ry).min()) if len(grid.ry) > 1 else 10,
           color="#d1495b")
    for x, c, t in zip(np.degrees(grid.ry), counts, totals):
        if t:
            ax.text(x, c, f"{100 * c / t:.0f}%", ha="center", va="bottom", fontsize=7)
    ax.set_xlabel("Ry [deg]")
    ax.set_ylabel("non-robust configurations")
    ax.set_title("Non-robust configurations over Ry")
    fig.tight_layout()
    paths.append(str(out / "non_robust_over_ry.png"))
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)
    return paths
