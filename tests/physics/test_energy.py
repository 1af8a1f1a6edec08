"""Energy balance of a kicked hanging cable with every damping off: what is conserved, and what gains energy."""

import mujoco
import numpy as np
import pytest
from helpers import world_cable_station

from dresspack_gym.physics.measures import cable_points, vertex_twists
from dresspack_gym.physics.simulation import CableSimulator
from dresspack_gym.stations.station import SOLVER_TOLERANCE

G = 9.81
SEGMENTS = 12
SECONDS = 10.0
TOP = [{"name": "top", "body": "world", "pos": [0, 0, 3.0], "direction": [0, 0, -1]}]
UNDAMPED = {"cable_damping": 0.0, "bending_damping": 0.0, "settle_time": 0.0}  # settle_time 0: built unsettled


def _stations():
    """A damped station to settle the hanging cable, and the same cable with the drag and rod damping off."""
    cable = {"segments": SEGMENTS}
    damped = world_cable_station(TOP, cable=cable, simulation={"equilibrium_tolerance": 1e-3,
                                                               "equilibrium_speed": 1e-4, "settle_time": 30.0})
    settled = CableSimulator(damped)
    assert settled.last_settle.converged
    free = world_cable_station(TOP, cable=cable, simulation=UNDAMPED)
    return settled.get_state(), free


@pytest.fixture(scope="module")
def hanging():
    return _stations()


def mechanical_energy(sim: CableSimulator) -> dict[str, float]:
    """The cable's energy terms [J]: kinetic (vertices and twist hinges), gravity, stretch of the edge
    constraints (1/2 (EA/h)(l - h)^2, their static stiffness), and MuJoCo's discrete elastic rod energy:
    EI/(l0 + l1) |kappa b|^2 per interior vertex (kappa b = 2 e0 x e1 / (|e0||e1| + e0.e1), straight rest
    shape) and GJ/(l0 + l1) m^2 with m the material twist there (MuJoCo's XML reference, flex/elasticity)."""
    station, d = sim.station, sim.data
    cable, dp = station.cables[0], station.config.robots[0].dresspack
    h = dp.segment_length
    pts = cable_points(d, cable)
    held = np.zeros(len(pts), bool)
    for a in cable.attachments:
        held[list(a.vertices)] = True
    stretchable = ~(held[:-1] & held[1:])  # an edge with both ends on one clamp is rigid
    ell = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    e0, e1 = pts[1:-1] - pts[:-2], pts[2:] - pts[1:-1]
    kb = 2 * np.cross(e0, e1) / (np.linalg.norm(e0, axis=1) * np.linalg.norm(e1, axis=1)
                                 + np.einsum("ij,ij->i", e0, e1))[:, None]
    twist = np.concatenate(vertex_twists(station.model, d, cable))
    return {"kinetic": sim.kinetic_energy(),
            "gravity": station.config.simulation.gravity * float(cable.free_mass @ pts[list(cable.free_vertices), 2]),
            "stretch": 0.5 * dp.tensile_stiffness / h * float((((ell - h) ** 2)[stretchable]).sum()),
            "bending": dp.bending_stiffness / (2 * h) * float((kb ** 2).sum()),
            "twist": dp.torsional_stiffness / (2 * h) * float((twist ** 2).sum())}


def _kicked(hanging, timestep, tolerance):
    state, station = hanging
    station.model.opt.timestep = timestep
    station.model.opt.tolerance = tolerance
    sim = CableSimulator(station)
    sim.set_state(state)
    cable = station.cables[0]
    s = np.asarray(cable.free_vertices) / SEGMENTS
    sim.data.qvel[cable.free_dof.ravel()] = np.stack([0.5 * s, 0.2 * s ** 2, 0.0 * s], axis=1).ravel()
    mujoco.mj_forward(station.model, sim.data)
    return sim


def _simulate(sim, seconds=SECONDS):
    """Total energy at the start and at the end, and the fraction of steps on which Newton did no iteration."""
    q, zero = sim.q.ravel(), np.zeros(sim.q.size)
    start = mechanical_energy(sim)
    idle = 0
    steps = int(round(seconds / sim.model.opt.timestep))
    for _ in range(steps):
        sim._step(q, zero)
        idle += int(sim.data.solver_niter[0] == 0)
    return start, mechanical_energy(sim), idle / steps


def test_every_station_solves_at_that_tolerance_in_motions_and_settles():
    """The tolerance the energy balance below holds at is the model's own, not only the settles'."""
    from dresspack_gym.io.loading import load_station
    from dresspack_gym.stations.station import Station

    assert world_cable_station(TOP, cable={"segments": SEGMENTS}).model.opt.tolerance == SOLVER_TOLERANCE
    sim = CableSimulator(Station(load_station("default")))
    assert sim.model.opt.tolerance == SOLVER_TOLERANCE
    sim.move_to(sim.q + np.radians([20, 0, 0, 0, 0, 0]), settle=True)
    assert sim.model.opt.tolerance == SOLVER_TOLERANCE


@pytest.mark.parametrize("timestep", [0.002, 0.004, 0.008])
def test_total_energy_does_not_rise_when_every_step_is_solved(hanging, timestep):
    """With the Newton solve converged on every step, the total mechanical energy does not rise over 10 s: it
    falls by a few per cent of the kick (the edge constraints' damping and the implicit step dissipate)."""
    sim = _kicked(hanging, timestep, SOLVER_TOLERANCE)
    start, end, idle = _simulate(sim)
    assert idle == 0.0
    kick = start["kinetic"]
    change = (sum(end.values()) - sum(start.values())) / kick
    assert -0.10 < change < 0.005, change


def test_a_step_the_solver_skips_reuses_the_last_acceleration_and_gains_energy(hanging):
    """MuJoCo's tolerance is relative to the model's mean inertia (here the parked robot's, ~1e5 kg m^2, a million
    times a cable vertex's mass): at its default 1e-8 the warm-started Newton solve stops with no iteration on a third
    or more of the steps, so those steps reuse the previous step's acceleration (lagged, explicit rod forces) and the
    undamped cable gains energy; converged steps (above) do not."""
    sim = _kicked(hanging, 0.008, 1e-8)
    start, end, idle = _simulate(sim)
    assert sim.station.model.stat.meaninertia > 1e5 * sim.station.cables[0].free_mass.max()
    assert idle > 0.25
    change = (sum(end.values()) - sum(start.values())) / start["kinetic"]
    assert change > 0.10, change


def test_energy_terms_match_mujoco(hanging):
    """The rod energy is the potential of MuJoCo's rod forces (its change equals minus their work along the motion),
    and MuJoCo's own potential energy (mj_energyPos) is the gravity term alone: it leaves out stretch and the rod."""
    sim = _kicked(hanging, 0.004, SOLVER_TOLERANCE)
    m, d, cable = sim.station.model, sim.data, sim.station.cables[0]
    m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    twist_qpos = [m.jnt_qposadr[m.dof_jntid[i]] for i in sim._twist_dof]
    dofs = np.concatenate([cable.free_dof.ravel(), sim._twist_dof])
    qpos = np.concatenate([cable.free_qpos.ravel(), twist_qpos])
    q, zero = sim.q.ravel(), np.zeros(sim.q.size)
    mujoco.mj_forward(m, d)
    start, pot_start = mechanical_energy(sim), float(d.energy[0])
    f_prev, x_prev, work = d.qfrc_spring[dofs].copy(), d.qpos[qpos].copy(), 0.0
    for _ in range(250):
        sim._step(q, zero)
        mujoco.mj_forward(m, d)
        f, x = d.qfrc_spring[dofs].copy(), d.qpos[qpos].copy()
        work += 0.5 * float((f + f_prev) @ (x - x_prev))
        f_prev, x_prev = f, x
    end = mechanical_energy(sim)
    rod = end["bending"] + end["twist"] - start["bending"] - start["twist"]
    assert rod > 1e-3 * start["kinetic"]  # the rod did bend
    assert rod == pytest.approx(-work, rel=0.01)
    # the parked robot and the cable's held ends never move: MuJoCo's potential changes by the cable's gravity alone
    pot_change = float(d.energy[0]) - pot_start
    assert abs(pot_change - (end["gravity"] - start["gravity"])) < 0.01 * rod
