"""Figure 4.2-style plot: forbidden j5 zones over j6 for each robot's joint restrictions."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..robots.restrictions import RestrictionSet, SupportClearance, TwistSum
from ..stations.config import StationConfig


def restriction_map(placement, j5_deg: np.ndarray, j6_deg: np.ndarray, j4_deg: float) -> np.ndarray:
    """Boolean (len(j5), len(j6)) grid of allowed (j5, j6) at fixed j1..j4 (Home's, with j4 given)."""
    j5, j6 = np.meshgrid(np.radians(j5_deg), np.radians(j6_deg), indexing="ij")
    q = np.tile(placement.home, (j5.size, 1))
    q[:, 3] = np.radians(j4_deg)
    q[:, 4], q[:, 5] = j5.ravel(), j6.ravel()
    return placement.restrictions.allowed(q).reshape(j5.shape)


# what a robot programmer calls the wrist joints the figure spans
JOINT_NAMES = {4: "j5, wrist bend", 5: "j6, tool flange turn"}
ZONE_STYLES = (("#d1495b", "//"), ("#edae49", "\\\\"), ("#00798c", "xx"), ("#8f2d56", ".."), ("#30638e", "++"))


def rule_label(rule) -> str:
    """What a zone of ``rule`` means, in words: the rule it breaks."""
    if isinstance(rule, SupportClearance):
        return f"cable support closer than {rule.c * 1000:g} mm to the forearm ({rule.shape})"
    if isinstance(rule, TwistSum):
        twist = "j4 + j6" + (f" - {np.degrees(rule.offset):g}°" if rule.offset else "")
        lo, hi = np.degrees(rule.lower), np.degrees(rule.upper)
        if np.isfinite(lo) and np.isfinite(hi):
            return f"cable twist {twist} outside [{lo:g}°, {hi:g}°]"
        return f"cable twist {twist} below {lo:g}°" if np.isfinite(lo) else f"cable twist {twist} above {hi:g}°"
    return f"breaks {rule.describe()}"


def plot_restrictions(config: StationConfig, path: str) -> dict:
    """Write the plot; returns the forbidden fraction per robot (at Home's j4, over the j5 x j6 joint ranges).

    Per robot: j5 over j6 in degrees with j1-j4 at Home; each restriction's forbidden zone shaded in its own colour
    and hatch, numbered in the plot and named in the legend; Home marked. Where the controller counts j5 or j6
    another way (sign, zero), its axis values are a second scale on the top or right."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    robots = config.robots
    fig, axes = plt.subplots(1, len(robots), figsize=(8 * len(robots), 5.5), squeeze=False)
    summary = {}
    for ax, r in zip(axes[0], robots):
        lim = np.degrees(r.robot.joint_limits)
        j6 = np.linspace(lim[5, 0], lim[5, 1], 721)
        j5 = np.linspace(lim[4, 0], lim[4, 1], 261)
        j4 = float(np.degrees(r.home[3]))
        allowed = restriction_map(r, j5, j6, j4)
        summary[r.name] = float(1.0 - allowed.mean())
        handles = []
        placed: list[tuple[float, float]] = []
        for i, rule in enumerate(r.restrictions.rules):
            forbidden = ~restriction_map(_single(r, rule), j5, j6, j4)
            if not forbidden.any():
                continue
            color, hatch = ZONE_STYLES[i % len(ZONE_STYLES)]
            ax.contourf(j6, j5, forbidden.astype(float), levels=[0.5, 1.5], colors=[color], alpha=0.35,
                        hatches=[hatch])
            x, y = _label_point(forbidden, j5, j6, placed)
            ax.text(x, y, f"({i + 1})", ha="center", va="center", fontsize=10, fontweight="bold",
                    bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": color})
            handles.append(Patch(facecolor=color, alpha=0.5, hatch=hatch, label=f"({i + 1}) forbidden: "
                                                                               f"{rule_label(rule)}"))
        home = np.degrees(r.home)
        handles += ax.plot(home[5], home[4], "k*", ms=12, label=f"Home (j5 {home[4]:.0f}°, j6 {home[5]:.0f}°)")
        ax.set_xlim(j6[0], j6[-1])
        ax.set_ylim(j5[0], j5[-1])
        ax.set_xlabel(f"{JOINT_NAMES[5]} [deg]")
        ax.set_ylabel(f"{JOINT_NAMES[4]} [deg]")
        ax.set_title(f"{r.name}: wrist positions the restrictions forbid (shaded); white is allowed\n"
                     f"j1–j4 at Home (j4 = {j4:.0f}°)", fontsize=10)
        ax.grid(alpha=0.3)
        if not r.restrictions.rules:
            ax.text(0.5, 0.5, "no restrictions", transform=ax.transAxes, ha="center")
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.13), fontsize=8, ncol=1,
                  frameon=False)
        _controller_scales(ax, r.robot)
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return summary


def _single(placement, rule):
    """``placement`` with ``rule`` as its only restriction (to shade each rule's zone on its own)."""
    return replace(placement, restrictions=RestrictionSet((rule,)))


def _label_point(forbidden: np.ndarray, j5: np.ndarray, j6: np.ndarray, placed: list) -> tuple[float, float]:
    """A point inside the zone for its number: the middle of the j6 columns most forbidden, at the forbidden j5
    nearest their median; moved down if another number sits there already."""
    counts = forbidden.sum(axis=0)
    columns = np.flatnonzero(counts == counts.max())
    col = int(columns[len(columns) // 2])
    rows = np.flatnonzero(forbidden[:, col])
    row = int(rows[np.argmin(np.abs(rows - np.median(rows)))])
    x, y = float(j6[col]), float(j5[row])
    step = 0.08 * (j5[-1] - j5[0])
    while any(abs(x - px) < 0.05 * (j6[-1] - j6[0]) and abs(y - py) < step for px, py in placed):
        y -= step
    placed.append((x, y))
    return x, y


def _controller_scales(ax, robot) -> None:
    """The controller's axis values of j6 (top) and j5 (right) where they differ from the model's joints."""
    sign, offset = np.array(robot.controller_sign), np.degrees(robot.controller_offset_rad)
    for joint, make, side in ((5, ax.secondary_xaxis, "top"), (4, ax.secondary_yaxis, "right")):
        s, o = float(sign[joint]), float(offset[joint])
        if s == 1.0 and o == 0.0:
            continue
        scale = make(side, functions=(lambda v, s=s, o=o: s * v + o, lambda a, s=s, o=o: (a - o) * s))
        if side == "top":
            scale.set_xlabel(f"controller axis {joint + 1} [deg]")
        else:
            scale.set_ylabel(f"controller axis {joint + 1} [deg]")
