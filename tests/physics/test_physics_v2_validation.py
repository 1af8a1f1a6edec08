"""Physics v2 validation against mechanics: torsion, stretch (EA), catenary, node loads (SPEC §9).

Each effect is tested alone (the others switched off or made negligible) and at several
resolutions, so that discretisation and constraint errors cannot cancel.
"""

import math

import numpy as np
import pytest
from helpers import settled, world_cable_station

from dresspack_gym.physics.measures import edge_tensions, vertex_twists
from dresspack_gym.physics.simulation import CableSimulator

G = 9.81
# Validation cases settle to a tight residual (1e-3 of a vertex weight): the cumulative force error along
# the cable is then below 0.1 % of its weight, well inside the tolerances checked.
TIGHT = {"equilibrium_tolerance": 1e-3, "equilibrium_speed": 1e-4, "settle_time": 30.0}


def _wrist_axis_station(length, segments, *, gj=0.1, ei=0.1, gravity=0.0, simulation=None):
    """A straight rod along the j6 axis: clamped in the world at one end and on link 6 at the other.

    Turning j6 by theta twists the rod by exactly theta about its own axis (nothing else moves).
    The parked robot (all joints zero, base at (-20, -20, 0)) has link 6 aligned with the world axes.
    """
    probe = world_cable_station([{"name": "a", "body": "world", "pos": [0, 0, 3], "direction": [0, 0, -1]}])
    wrist = probe.robots[0].kinematics.link_frames(np.zeros(6))[6][:3, 3]
    tip = 0.3  # node on the tool axis, 0.3 m beyond the wrist centre
    start = wrist + np.array([tip + length, 0.0, 0.0])
    return world_cable_station(
        [{"name": "world_clamp", "body": "world", "pos": start.tolist(), "direction": [-1, 0, 0]},
         {"name": "wrist_clamp", "body": "link6", "pos": [tip, 0, 0], "direction": [-1, 0, 0], "at": "end"}],
        cable={"length": length, "segments": segments, "torsional_stiffness": gj, "bending_stiffness": ei},
        gravity=gravity, simulation=simulation)


@pytest.mark.parametrize("segments", [10, 20, 40])
@pytest.mark.parametrize("theta_deg", [90, 180])
def test_torsion_end_torque_and_uniform_twist(segments, theta_deg):
    """Clamped-clamped straight rod, one end turned theta: torque GJ theta / L_eff, uniform twist rate.

    The clamps hold the first and last edge, so the twisting length is L_eff = L - h (the distance
    between the clamped edges' outer vertices).
    """
    length, gj = 1.0, 0.1
    station = _wrist_axis_station(length, segments, gj=gj)
    sim = CableSimulator(station)
    theta = math.radians(theta_deg)
    q = station.home.copy()
    q[0, 5] = theta
    sim.move_to(q)
    assert sim.last_settle.converged
    l_eff = length - length / segments
    expected = gj * theta / l_eff
    forces, torques = sim.node_loads()
    for tau in torques:
        assert abs(tau[0]) == pytest.approx(expected, rel=0.02)
        assert np.hypot(tau[1], tau[2]) < 0.02 * expected  # a pure twist: no bending moment
    twists = np.concatenate(vertex_twists(station.model, sim.data, station.cables[0]))
    np.testing.assert_allclose(np.abs(twists) / (length / segments), theta / l_eff, rtol=0.02)
    m = sim.measures()
    assert m.max_twist_rate == pytest.approx(theta / l_eff, rel=0.02)
    assert m.total_twist == pytest.approx(theta, rel=0.02)
    assert m.max_node_torque == pytest.approx(expected, rel=0.02)


def test_torsion_does_not_move_an_untwisted_rod():
    """GJ alone changes nothing when nothing twists the rod (swivel-free clamps at rest): a straight rod
    with GJ = 0.1 and GJ = 10 has the same shape and zero twist."""
    pts = []
    for gj in (0.1, 10.0):
        sim = CableSimulator(_wrist_axis_station(1.0, 20, gj=gj, gravity=G))
        pts.append(sim.cable_points())
        assert sim.measures().max_twist_rate < 1e-6
    assert np.abs(pts[0] - pts[1]).max() < 1e-4


@pytest.mark.parametrize("segments", [12, 24, 48])
@pytest.mark.parametrize("timestep", [0.001, 0.002, 0.004])
def test_stretch_tension_is_ea_times_strain(segments, timestep):
    """A hanging (taut) cable: each edge's tension = EA * strain of its measured length, within 5 %,
    whatever the timestep and segment count; the hanging edge tension profile is rho g (L - s)."""
    ea, rho, length = 300.0, 1.25, 1.74
    station = world_cable_station([{"name": "top", "body": "world", "pos": [0, 0, 3.0], "direction": [0, 0, -1]}],
                                  cable={"tensile_stiffness": ea, "segments": segments},
                                  simulation={"timestep": timestep, "settle_timestep": timestep * 4, **TIGHT})
    sim = settled(station, 10.0)
    assert sim.last_settle.converged
    cable = station.cables[0]
    tension = edge_tensions(station.model, sim.static_forces(), cable)
    pts = sim.cable_points()
    h = length / segments
    strain = np.linalg.norm(np.diff(pts, axis=0), axis=1) / h - 1.0
    loaded = np.isfinite(tension) & (tension > 1.0)
    assert loaded.sum() >= segments // 2
    np.testing.assert_allclose(tension[loaded], ea * strain[loaded], rtol=0.05)
    s_mid = (np.arange(segments) + 0.5) * h
    np.testing.assert_allclose(tension[1:], rho * G * (length - s_mid[1:]), rtol=0.02, atol=0.05)
    assert np.isnan(tension[0])  # the clamp's own edge is rigid: no tension is reported for it
    assert sim.measures().max_compression == 0.0


def test_hanging_clamp_carries_the_whole_weight():
    """The connector load of the top clamp = rho g L (the cable below plus the piece in the clamp)."""
    for segments in (12, 24, 48):
        station = world_cable_station([{"name": "top", "body": "world", "pos": [0, 0, 3.0], "direction": [0, 0, -1]}],
                                      cable={"segments": segments}, simulation=TIGHT)
        sim = settled(station)
        assert sim.last_settle.converged
        forces, torques = sim.node_loads()
        # node frame x = cable direction (down): the cable pulls the clamp down with its whole weight
        assert forces[0][0] == pytest.approx(1.25 * G * 1.74, rel=0.005)
        assert np.hypot(forces[0][1], forces[0][2]) < 1e-3
        assert np.linalg.norm(torques[0]) < 1e-3


@pytest.mark.parametrize("segments", [24, 48])
def test_catenary_sag(segments):
    """A long, very flexible, nearly inextensible cable between two rings at equal height: catenary sag
    within 2 % (bending, stretch and twist made negligible, so only gravity and the chain remain)."""
    span, length = 2.0, 3.0
    station = world_cable_station(
        [{"name": "left", "body": "world", "pos": [0, 0, 3.0]},
         {"name": "right", "body": "world", "pos": [span, 0, 3.0], "at": "end"}],
        cable={"length": length, "segments": segments, "bending_stiffness": 1e-5, "tensile_stiffness": 1e6,
               "torsional_stiffness": 1e-5}, simulation=TIGHT)
    sim = settled(station, 20.0)
    assert sim.last_settle.converged
    a = _catenary_parameter(span, length)
    sag = a * (math.cosh(span / (2 * a)) - 1.0)
    measured = 3.0 - sim.cable_points()[:, 2].min()
    assert measured == pytest.approx(sag, rel=0.02)
    # each ring carries half the weight vertically and the horizontal tension rho g a
    forces, _ = sim.node_loads()
    w = 1.25 * G
    for f, rot in zip(forces, [sim.data.xmat[b].reshape(3, 3) for b in station.cables[0].node_bodies]):
        world = rot @ f
        assert -world[2] == pytest.approx(w * length / 2, rel=0.02)
        assert abs(world[0]) == pytest.approx(w * a, rel=0.03)


def _catenary_parameter(span, length):
    lo, hi = 1e-3, 1e3  # length = 2 a sinh(span / 2a) decreases with a
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if 2 * mid * math.sinh(span / (2 * mid)) > length else (lo, mid)
    return math.sqrt(lo * hi)


def test_cantilever_clamp_moment():
    """Horizontal cantilever: the clamp carries the weight w L and the moment w L^2 / 2 (statics only,
    independent of EI), at two resolutions."""
    for segments in (20, 40):
        length, rho = 1.0, 0.5
        station = world_cable_station([{"name": "clamp", "body": "world", "pos": [0, 0, 2.0], "direction": [1, 0, 0]}],
                                      cable={"length": length, "linear_density": rho, "bending_stiffness": 20.0,
                                             "segments": segments})
        sim = settled(station, 8.0)
        forces, torques = sim.node_loads()
        w = rho * G
        assert np.linalg.norm(forces[0]) == pytest.approx(w * length, rel=0.01)
        # the moment about the clamp point of the (slightly deflected) cable's weight: ~ w L^2 / 2
        assert np.linalg.norm(torques[0]) == pytest.approx(w * length ** 2 / 2, rel=0.02)


@pytest.mark.parametrize("segments", [20, 40])
def test_twisted_rod_buckles_near_greenhill_moment(segments):
    """Clamped-clamped straight rod, no tension, twisted by turning one clamp: it stays straight (a lateral
    push dies out) below the critical twisting moment M = 2.86 pi EI / L (Greenhill; Timoshenko & Gere) and
    buckles above it. The onset is found from the post-buckling amplitude (amplitude^2 grows linearly
    with the twist past a supercritical bifurcation) and must be within 10 % of Greenhill's moment."""
    length, ei, gj = 1.0, 0.01, 0.1
    h = length / segments
    station = _wrist_axis_station(length, segments, gj=gj, ei=ei, simulation=TIGHT)
    sim = CableSimulator(station)
    cable = station.cables[0]
    axis = sim.cable_points()
    mid = len(cable.free_vertices) // 2
    m_crit = 2.86 * math.pi * ei / (length - h)  # bending length between the clamped edges' outer vertices
    thetas, amplitudes, moments = [], [], []
    for deg in range(34, 79, 4):
        q = station.home.copy()
        q[0, 5] = math.radians(deg)
        sim.move_to(q)
        sim.data.qpos[cable.free_qpos[mid][1]] += 0.003  # a 3 mm lateral push at mid-span
        sim.settle(5.0)
        amplitudes.append(np.linalg.norm((sim.cable_points() - axis)[:, 1:], axis=1).max())
        moments.append(abs(sim.node_loads()[1][0][0]))
        thetas.append(math.radians(deg))
    thetas, amplitudes, moments = map(np.array, (thetas, amplitudes, moments))
    np.testing.assert_allclose(moments, gj * thetas / (length - h), rtol=0.02)  # torsion stays linear
    stable = moments < 0.85 * m_crit
    assert stable.any() and (amplitudes[stable] < 1e-4).all()  # the push dies out well below the critical moment
    buckled = amplitudes > 2e-3
    assert buckled.sum() >= 4 and (moments[buckled] > 0.95 * m_crit).all()
    slope, intercept = np.polyfit(thetas[buckled], amplitudes[buckled] ** 2, 1)
    onset_moment = gj * (-intercept / slope) / (length - h)
    print(f"segments {segments}: onset {onset_moment:.4f} N m, Greenhill {m_crit:.4f} N m")
    assert onset_moment == pytest.approx(m_crit, rel=0.10)


def test_twist_sweep_twist_grows_with_the_wrist_sum():
    """Thesis (4.1) sweep near Home: no twist at Home, twist rate and clamp twist torque grow with |j4 + j6|."""
    from dresspack_gym.io.loading import load_station
    from dresspack_gym.physics.twist_sweep import twist_sweep
    from dresspack_gym.stations.station import Station

    sweep = twist_sweep(CableSimulator(Station(load_station("default"))), span_deg=60, step_deg=20)
    assert sweep.sum_deg == pytest.approx([-60, -40, -20, 0, 20, 40, 60])
    rate = np.array(sweep.max_twist_rate)
    assert rate[3] < 1e-6
    assert np.all(np.diff(rate[:4]) < 0) and np.all(np.diff(rate[3:]) > 0)
    torque = np.abs(np.array(sweep.node_twist_torque))
    assert torque[3].max() < 1e-6 and torque[0].min() > 0.01 and torque[-1].min() > 0.01


@pytest.mark.parametrize("segments", [20, 40])
def test_standing_column_compression(segments):
    """A stiff rod clamped at its foot, standing up (below its self-weight buckling length): each edge is
    pushed by the weight above it, rho g (L - s), reported as compression, never as tension; the clamp
    carries the whole weight pushing down."""
    length, rho, ei = 0.5, 1.25, 20.0  # self-weight buckling needs L > 1.986 (EI / rho g)^(1/3) = 2.3 m
    station = world_cable_station([{"name": "foot", "body": "world", "pos": [0, 0, 1.0], "direction": [0, 0, 1]}],
                                  cable={"length": length, "bending_stiffness": ei, "segments": segments},
                                  simulation=TIGHT)
    sim = CableSimulator(station)
    cable = station.cables[0]
    h = length / segments
    # The reference shape lets a free end hang down; stand the column up and let it settle there.
    upright = np.array([0.0, 0.0, 1.0]) + np.outer(np.arange(segments + 1) * h, [0.0, 0.0, 1.0])
    sim.data.qpos[cable.free_qpos] = upright[cable.free_vertices] - station.model.body_pos[cable.free_bodies]
    sim.data.qvel[:] = 0.0
    assert sim.settle().converged
    assert np.abs(sim.cable_points()[:, :2]).max() < 1e-6 and sim.cable_points()[-1, 2] > 1.49  # it stands
    push = -edge_tensions(station.model, sim.static_forces(), station.cables[0])[1:]
    s_mid = (np.arange(1, segments) + 0.5) * h
    np.testing.assert_allclose(push, rho * G * (length - s_mid), rtol=0.02, atol=0.02)
    m = sim.measures()
    assert m.max_compression == pytest.approx(rho * G * (length - 1.5 * h), rel=0.02)
    assert m.max_tension == 0.0
    forces, _ = sim.node_loads()
    assert forces[0][0] == pytest.approx(-rho * G * length, rel=0.005)  # x = up: the column pushes down
