"""Figure 4.2-style plot: forbidden j5 zones over j6 for each robot's joint restrictions."""

from __future__ import annotations

import numpy as np

from ..stations.config import StationConfig


def restriction_map(placement, j5_deg: np.ndarray, j6_deg: np.ndarray, j4_deg: float) -> np.ndarray:
    """Boolean (len(j5), len(j6)) grid of allowed (j5, j6) at fixed j1..j4 (Home's, with j4 given)."""
    j5, j6 = np.meshgrid(np.radians(j5_deg), np.radians(j6_deg), indexing="ij")
    q = np.tile(placement.home, (j5.size, 1))
    q[:, 3] = np.radians(j4_deg)
    q[:, 4], q[:, 5] = j5.ravel(), j6.ravel()
    return placement.restrictions.allowed(q).reshape(j5.shape)


def plot_restrictions(config: StationConfig, path: str) -> dict:
    """Write the plot; returns the forbidden fraction per robot (at Home's j4) for the summary."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    robots = config.robots
    fig, axes = plt.subplots(1, len(robots), figsize=(7 * len(robots), 5), squeeze=False)
    summary = {}
    for ax, r in zip(axes[0], robots):
        lim = np.degrees(r.robot.joint_limits)
        j6 = np.linspace(-180, 180, 721)
        j5 = np.linspace(lim[4, 0], lim[4, 1], 521)
        j4 = float(np.degrees(r.home[3]))
        allowed = restriction_map(r, j5, j6, j4)
        summary[r.name] = float(1.0 - allowed.mean())
        ax.imshow(~allowed, origin="lower", aspect="auto", extent=[j6[0], j6[-1], j5[0], j5[-1]],
                  cmap=matplotlib.colors.ListedColormap(["#f4f4f4", "#d1495b"]), vmin=0, vmax=1)
        ax.set_xlabel("j6 [deg]")
        ax.set_ylabel("j5 [deg]")
        ax.set_title(f"{r.name}: forbidden (red) j5 over j6 at j4 = {j4:.0f} deg")
        rules = "\n".join(rule.describe() for rule in r.restrictions.rules) or "no restrictions"
        ax.text(0.99, 0.99, rules, transform=ax.transAxes, fontsize=7, va="top", ha="right",
                bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"})
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return summary
