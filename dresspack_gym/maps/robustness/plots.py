"""Robustness plots like thesis Figures 4.5 (deviation per configuration) and 4.7 (non-robust count over Ry), and
one j4 x j6 panel per Ry (where on the wrist the non-robust configurations lie). Unconverged configurations
(no equilibrium) are drawn grey and never counted, as in the summary."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .grid import RobustnessGrid
from .store import load_results, load_unconverged


def plot_map(out: str | Path, grid: RobustnessGrid, threshold: float) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out)
    rows = load_results(out)
    unconverged = load_unconverged(out)
    bad = np.array(sorted(unconverged & set(rows)), dtype=int)
    idx = np.array(sorted(set(rows) - unconverged), dtype=int)
    dev = np.array([rows[i][1] for i in idx])
    paths = []
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.scatter(idx, dev * 1000, s=3, c=np.where(dev >= threshold, "#d1495b", "#2e4057"))
    if len(bad):
        ax.scatter(bad, [rows[i][1] * 1000 for i in bad], s=6, c="#999999", marker="x",
                   label=f"unconverged ({len(bad)}, not counted)")
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
    paths.append(_plot_per_ry(out, grid, idx, dev >= threshold, bad))
    return paths


def _plot_per_ry(out: Path, grid: RobustnessGrid, idx: np.ndarray, non_robust: np.ndarray, bad: np.ndarray) -> str:
    """One j4 x j6 panel per Ry: the fraction of the j5 values whose configuration is non-robust."""
    import matplotlib.pyplot as plt

    n_ry, n4, n5, n6 = grid.shape
    count = np.zeros(grid.shape)
    seen = np.zeros(grid.shape)
    np.add.at(count, np.unravel_index(idx, grid.shape), non_robust)
    np.add.at(seen, np.unravel_index(idx, grid.shape), 1.0)
    frac = np.divide(count.sum(axis=2), seen.sum(axis=2), out=np.full((n_ry, n4, n6), np.nan),
                     where=seen.sum(axis=2) > 0)
    cols = min(6, n_ry)
    rows = int(np.ceil(n_ry / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.3 * cols + 1, 2.3 * rows + 0.6), squeeze=False,
                             sharex=True, sharey=True)
    def edges(axis):  # cells centred on the grid values
        a = np.degrees(axis)
        half = 0.5 * (a[1] - a[0]) if len(a) > 1 else 5.0
        return a[0] - half, a[-1] + half

    extent = [*edges(grid.j6), *edges(grid.j4)]
    image = None
    for k in range(rows * cols):
        ax = axes[k // cols, k % cols]
        if k >= n_ry:
            ax.axis("off")
            continue
        image = ax.imshow(frac[k], origin="lower", extent=extent, aspect="auto", vmin=0, vmax=1, cmap="Reds")
        done = int(seen[k].sum())
        pct = f"{100 * np.nansum(count[k]) / done:.1f} %" if done else "not mapped"
        ax.set_title(f"Ry {np.degrees(grid.ry[k]):g}: {pct}", fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in axes[-1]:
        ax.set_xlabel("j6 [deg]", fontsize=7)
    for ax in axes[:, 0]:
        ax.set_ylabel("j4 [deg]", fontsize=7)
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.6, label="non-robust fraction of the j5 values")
    fig.suptitle(f"{grid.name}: non-robust configurations per Ry (j4 x j6; {len(bad)} unconverged not counted)",
                 fontsize=9)
    path = str(out / "non_robust_per_ry.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
