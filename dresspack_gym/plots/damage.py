"""Pictures of where the cable wears: damage and fatigue life along the cable per method, and the damage strip
(segment x time) of one replay."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..physics.fatigue import MAX_LIFE
from ..physics.trajectory import Replay


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_damage_along_cable(replays: dict[str, Replay], path: str | Path, colors: dict | None = None) -> str:
    """Per replay: accumulated damage (all terms) and fatigue life per segment against arc length."""
    plt = _plt()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for label, rep in replays.items():
        if rep.damage is None or rep.fatigue is None:
            continue
        color = (colors or {}).get(label.split(" ")[0])
        top.plot(rep.damage.arc, rep.damage.total, marker=".", label=label, color=color)
        life = np.where(rep.fatigue.life_cycles >= MAX_LIFE, np.nan, rep.fatigue.life_cycles)
        bottom.semilogy(rep.fatigue.arc, life, marker=".", label=label, color=color)
    top.set_ylabel("damage per cycle")
    top.legend(fontsize=7)
    bottom.set_ylabel("fatigue life [cycles]")
    bottom.set_xlabel("arc length along the cable [m]")
    top.set_title("Where the cable wears: damage (weighted terms) and fatigue life per segment", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def plot_damage_strip(rep: Replay, path: str | Path, title: str = "") -> str:
    """Damage added per second, segment x time (the damage strip), with the stops marked."""
    plt = _plt()
    d = rep.damage
    dt = np.diff(d.times)
    # a settle adds damage at one motion time (zero-width cells, not drawn); motion intervals show their rate
    rate = np.divide(d.strip, dt[:, None], out=np.zeros_like(d.strip), where=dt[:, None] > 0)
    h = d.arc[1] - d.arc[0] if len(d.arc) > 1 else 1.0
    arc_edges = np.concatenate([d.arc - h / 2, [d.arc[-1] + h / 2]])
    fig, ax = plt.subplots(figsize=(9, 3.6))
    image = ax.pcolormesh(d.times, arc_edges, rate.T, cmap="magma_r", shading="flat")
    for t in rep.stop_times:
        ax.axvline(t, color="grey", lw=0.6, ls=":")
    ax.set_xlabel("motion time [s]")
    ax.set_ylabel("arc length [m]")
    ax.set_title(title or "Damage strip", fontsize=10)
    fig.colorbar(image, ax=ax, label="damage rate [1/s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)
