"""A fast wrist turn on both engines: the cable's largest twist rate and curvature at the move's end and while the robot
then stands still, with the cable's contact with its robot as modelled and varied (friction, cone, none).

    PYTHONPATH=. .venv/bin/python scripts/studies/fast_turn_engines.py

From Home on the default station, j4 turns 90 degrees and j6 70 degrees at the time law's speed (1.2 s); the robot
then holds still for 8 s. MuJoCo combines two friction coefficients by the larger, so the cable (0.5) slides on its
robot's links (1) at 1 unless the links' coefficient is lowered too.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from dresspack_gym.io.loading import load_station
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.rod.simulator import RodSimulator
from dresspack_gym.stations.station import Station

HOLD = 8.0  # [s] standing still after the turn
SAMPLE = 0.05  # [s]


def _station(robot_contact: bool) -> Station:
    config = load_station("default")
    if not robot_contact:
        config = dataclasses.replace(config, robots=tuple(
            dataclasses.replace(r, dresspack=dataclasses.replace(r.dresspack, collide_with_robot=False))
            for r in config.robots))
    return Station(config)


def _mujoco(robot_contact: bool = True, friction: float | None = None, elliptic: bool = False) -> CableSimulator:
    station = _station(robot_contact)
    m = station.model
    if friction is not None:  # every contact's coefficient, the cable's and the cell's alike
        m.flex_friction[:, 0] = friction
        m.geom_friction[:, 0] = friction
    if elliptic:
        m.opt.cone, m.opt.impratio = mujoco.mjtCone.mjCONE_ELLIPTIC, 100.0
    return CableSimulator(station)


def _turn(sim) -> dict:
    q = sim.station.home.copy()
    q[0, 3] += np.radians(90.0)
    q[0, 5] += np.radians(70.0)
    trace = sim.move_to(q, record_every=SAMPLE, settle=False)
    end = trace.measures[-1]
    held = sim.q.copy()
    times, samples = sim.follow(lambda t: (np.repeat(held[None], len(t), 0), np.zeros((len(t),) + held.shape)),
                                HOLD, record_every=SAMPLE)
    since = np.asarray(times) - (times[0] - SAMPLE)  # seconds standing still

    def at(seconds: float):
        return samples[int(np.argmin(np.abs(since - seconds)))][0]

    return {"twist_end": end.max_twist_rate, "twist_2s": at(2.0).max_twist_rate, "twist_8s": at(HOLD).max_twist_rate,
            "kappa_end": end.max_curvature, "kappa_8s": at(HOLD).max_curvature}


def _contact_twist_torque() -> tuple[float, float]:
    """During MuJoCo's turn as modelled: the largest torque the contacts put on a twist hinge (J^T f over the contact
    rows) and the largest radius x friction force of a cable vertex [N m]."""
    sim = _mujoco()
    m, d = sim.model, sim.data
    twist = sim._twist_dof
    radius = sim.station.config.robots[0].dresspack.radius
    q = sim.station.home.copy()
    q[0, 3] += np.radians(90.0)
    q[0, 5] += np.radians(70.0)
    most = [0.0, 0.0]

    def sample(_t):
        rows = np.flatnonzero(d.efc_type[: d.nefc] >= int(mujoco.mjtConstraint.mjCNSTR_CONTACT_FRICTIONLESS))
        if not len(rows):
            return
        jac = np.zeros((d.nefc, m.nv))
        mujoco.mju_sparse2dense(jac, d.efc_J, d.efc_J_rownnz, d.efc_J_rowadr, d.efc_J_colind)
        torque = jac[rows].T @ d.efc_force[rows]
        most[0] = max(most[0], float(np.abs(torque[twist]).max()))
        most[1] = max(most[1], radius * float(sim.segment_states()[0].friction_force.max()))

    sim.move_to(q, record_every=SAMPLE, settle=False, on_sample=sample)
    return most[0], most[1]


def main() -> None:
    cases = [
        ("MuJoCo as modelled (cable 0.5, links 1: slides at 1), pyramidal cones", lambda: _mujoco()),
        ("MuJoCo, every contact at 0.5, pyramidal cones", lambda: _mujoco(friction=0.5)),
        ("MuJoCo, every contact at 0.5, elliptic cones (impratio 100)", lambda: _mujoco(friction=0.5, elliptic=True)),
        ("MuJoCo, frictionless contacts", lambda: _mujoco(friction=0.0)),
        ("rod engine (0.5)", lambda: RodSimulator(_station(True))),
        ("MuJoCo, no cable-robot contact", lambda: _mujoco(robot_contact=False)),
        ("rod engine, no cable-robot contact", lambda: RodSimulator(_station(False))),
    ]
    print("| case | twist rate at the end [rad/m] | 2 s later | 8 s later | curvature at the end [1/m] | 8 s later |")
    print("|---|---|---|---|---|---|")
    for name, make in cases:
        r = _turn(make())
        print(f"| {name} | {r['twist_end']:.2f} | {r['twist_2s']:.2f} | {r['twist_8s']:.2f} | {r['kappa_end']:.1f} | "
              f"{r['kappa_8s']:.1f} |", flush=True)
    torque, lever = _contact_twist_torque()
    print(f"\nMuJoCo's contacts twist the cable: up to {torque:.3f} N m on a twist hinge during the turn, against a "
          f"largest radius x friction force of {lever:.3f} N m")


if __name__ == "__main__":
    main()
