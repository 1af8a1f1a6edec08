"""The thesis (4.1) experiment it never showed: clamp torque, twist and curvature against j4 + j6.

At a fixed arm pose (Home's j1, j2, j3, j5) the wrist sum j4 + j6 is stepped quasi-statically away from
Home in both directions (j6 first, j4 for what j6's range cannot give), the cable settling to
equilibrium at every step. The joint restriction (4.1) |j4 + j6| <= 270 deg (re-centred on Home) exists
because the dresspack twists; the sweep shows how the measures grow up to and past that bound.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .simulation import CableSimulator


@dataclass
class TwistSweep:
    """Samples of the sweep, ordered by ``sum_deg`` (j4 + j6 minus its Home value, degrees)."""

    sum_deg: list[float] = field(default_factory=list)
    q_deg: list[list[float]] = field(default_factory=list)
    node_torque: list[list[float]] = field(default_factory=list)  # |torque| per node [N m]
    node_twist_torque: list[list[float]] = field(default_factory=list)  # torque about the cable axis [N m]
    max_twist_rate: list[float] = field(default_factory=list)
    total_twist: list[float] = field(default_factory=list)
    max_curvature: list[float] = field(default_factory=list)
    max_tension: list[float] = field(default_factory=list)
    converged: list[bool] = field(default_factory=list)
    node_names: list[str] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def wrist_configuration(home: np.ndarray, offset: float, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
    """Home with j4 + j6 changed by ``offset`` [rad]: j6 takes what its range allows, j4 the rest."""
    q = home.copy()
    j6 = np.clip(home[5] + offset, lower[5], upper[5])
    j4 = home[3] + offset - (j6 - home[5])
    if not lower[3] <= j4 <= upper[3]:
        return None
    q[3], q[5] = j4, j6
    return q


def twist_sweep(sim: CableSimulator, *, span_deg: float = 400.0, step_deg: float = 10.0,
                robot: int = 0, progress=None) -> TwistSweep:
    """Step j4 + j6 away from Home to +span and to -span (as far as the joint limits allow), settling each."""
    station = sim.station
    lim = station.config.robots[robot].robot.joint_limits
    home = station.home[robot]
    cable = station.cables[robot]
    out = TwistSweep(node_names=[a.node.name for a in cable.attachments])
    samples: list[tuple[float, dict]] = []
    for sign in (1.0, -1.0):
        sim.reset()
        for k in range(0 if sign > 0 else 1, int(round(span_deg / step_deg)) + 1):
            offset = np.radians(sign * k * step_deg)
            q1 = wrist_configuration(home, offset, lim[:, 0], lim[:, 1])
            if q1 is None:
                break
            q = station.home.copy()
            q[robot] = q1
            sim.move_to(q)
            forces, torques = sim.node_loads(robot)
            m = sim.cable_measures()[robot]
            samples.append((round(float(np.degrees(offset)), 9), {
                "q_deg": np.round(np.degrees(q1), 3).tolist(),
                "node_torque": np.linalg.norm(torques, axis=1).tolist(),
                "node_twist_torque": torques[:, 0].tolist(),
                "max_twist_rate": m.max_twist_rate, "total_twist": m.total_twist,
                "max_curvature": m.max_curvature, "max_tension": m.max_tension,
                "converged": bool(sim.last_settle.converged)}))
            if progress is not None:
                progress.update(1)
    for s, row in sorted(samples, key=lambda a: a[0]):
        out.sum_deg.append(s)
        for key, value in row.items():
            getattr(out, key).append(value)
    return out


def plot_twist_sweep(sweep: TwistSweep, path, *, bound_deg: float = 270.0) -> None:
    """Clamp torque, twist rate and curvature against j4 + j6 (from Home), the (4.1) bound marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.array(sweep.sum_deg)
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True)
    torque = np.array(sweep.node_twist_torque)
    for i, name in enumerate(sweep.node_names):
        axes[0].plot(x, np.abs(torque[:, i]), label=f"{name}: torque about the cable")
        axes[0].plot(x, np.array(sweep.node_torque)[:, i], "--", label=f"{name}: |torque|")
    axes[0].set_ylabel("clamp torque [N m]")
    axes[0].legend(fontsize=7)
    axes[1].plot(x, sweep.max_twist_rate, color="tab:purple", label="max twist rate [rad/m]")
    axes[1].plot(x, np.abs(sweep.total_twist), color="tab:gray", label="|total twist| [rad]")
    axes[1].set_ylabel("twist")
    axes[1].legend(fontsize=7)
    axes[2].plot(x, sweep.max_curvature, color="tab:red")
    axes[2].set_ylabel("max curvature [1/m]")
    axes[2].set_xlabel("j4 + j6 relative to Home [deg]")
    bad = [s for s, c in zip(x, sweep.converged) if not c]
    for ax in axes:
        for b in (-bound_deg, bound_deg):
            ax.axvline(b, color="k", ls=":", lw=1)
        for s in bad:
            ax.axvline(s, color="orange", alpha=0.3, lw=3)
        ax.grid(alpha=0.3)
    axes[0].set_title("Thesis (4.1): |j4 + j6| <= 270 deg (dotted); unconverged settles shaded", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
